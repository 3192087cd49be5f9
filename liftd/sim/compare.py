"""`liftd simulate PROGRAM --compare`: the same program and PLC schedule run with Advanced
Lifting and with path-based Lifting, paired lift by lift.

The JSON holds both full summaries (DESIGN.md §3.3) and, per lift, both lift entries with the
ratios advanced / lifting of mean clearance and peak. The figure (plot.plot_compare) overlays
each lift's Z over time and over path distance, needing per-lift samples: `LiftSampler` keeps
them for the first MAX_PLOTTED lifts only, so memory stays bounded on any program.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any, TextIO

import numpy as np

from liftd.cnc.params import ChannelParams
from liftd.cnc.plc import Schedule
from liftd.cnc.snapshot import GeoSnapshot
from liftd.sim.simulate import SimResult, channel_for, simulate

METHODS = ("advanced", "lifting")
MAX_PLOTTED = 12
MARGIN = 30  # cycles shown before and after each lift


@dataclass
class LiftSamples:
    """One lift of one run: rows of (t, s, z, a_z) in SI units, s the path distance."""

    start_line: int
    rows: list[tuple[float, float, float, float]] = field(default_factory=list)
    t_start: float = 0.0
    s_start: float = 0.0
    t_end: float = -1.0
    s_end: float = 0.0


class LiftSampler:
    """Per-cycle hook of `simulate`: the path distance (trapezoidal ∫v dt), Z, and Z's sampled
    acceleration (second finite difference) around each of the first `limit` lifts."""

    def __init__(self, z_index: int, dt: float, limit: int = MAX_PLOTTED) -> None:
        self.z_index = z_index
        self.dt = dt
        self.limit = limit
        self.lifts: list[LiftSamples] = []
        self.recent: deque[tuple[float, float, float, float]] = deque(maxlen=MARGIN)
        self.open: LiftSamples | None = None
        self.tail = 0  # cycles still recorded after a lift ended
        self.s = 0.0
        self.v = 0.0
        self.z1: float | None = None
        self.z2: float | None = None

    def add(self, snap: GeoSnapshot) -> None:
        self.s += 0.5 * (self.v + snap.v_path) * self.dt
        self.v = snap.v_path
        z = snap.positions[self.z_index]
        a = 0.0
        if self.z1 is not None and self.z2 is not None:
            a = (z - 2.0 * self.z1 + self.z2) / (self.dt * self.dt)
        self.z2, self.z1 = self.z1, z
        row = (snap.t, self.s, z, a)
        for ev in snap.events:
            if ev.name == "lift.start" and len(self.lifts) < self.limit:
                self.open = LiftSamples(ev.line, list(self.recent), ev.t, self.s)
                self.lifts.append(self.open)
            elif ev.name == "lift.end" and self.open is not None and self.open.t_end < 0.0:
                self.open.t_end, self.open.s_end = ev.t, self.s
                self.tail = MARGIN
        self.recent.append(row)
        if self.open is None:
            return
        self.open.rows.append(row)
        if self.open.t_end >= 0.0:
            self.tail -= 1
            if self.tail <= 0:
                self.open = None


@dataclass
class Comparison:
    results: dict[str, SimResult]
    samples: dict[str, LiftSampler]
    summary: dict[str, Any]

    @property
    def program_error(self) -> bool:
        return any(r.program_error for r in self.results.values())

    @property
    def finished(self) -> bool:
        return all(r.finished for r in self.results.values())


def _ratio(a: float, b: float) -> float | None:
    return round(a / b, 6) if b > 0.0 else None


def occurrence_keys(lines: Iterable[int]) -> list[tuple[int, int]]:
    """(start line, how many lifts started on that line before): identifies a lift across runs
    (a program repeated by a run may start lifts on the same line again)."""
    seen: dict[int, int] = {}
    keys = []
    for line in lines:
        n = seen.get(line, 0)
        seen[line] = n + 1
        keys.append((line, n))
    return keys


def pair_lifts(adv: list[dict[str, Any]], lift: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Pair the lifts of both runs by start line and occurrence (a run stopped by an error has
    fewer lifts)."""

    def keyed(lifts: list[dict[str, Any]]) -> dict[tuple[int, int], dict[str, Any]]:
        return dict(zip(occurrence_keys(x["start_line"] for x in lifts), lifts, strict=True))

    a, b = keyed(adv), keyed(lift)
    pairs = []
    for key in sorted(set(a) | set(b), key=lambda k: (a.get(k) or b[k])["t_start"]):
        x, y = a.get(key), b.get(key)
        ref = x or y
        assert ref is not None
        pairs.append(
            {
                "start_line": ref["start_line"],
                "end_line": ref["end_line"],
                "advanced": x,
                "lifting": y,
                "clearance_ratio": _ratio(x["mean_clearance"], y["mean_clearance"])
                if x and y
                else None,
                "peak_ratio": _ratio(x["peak"] - x["z_start"], y["peak"] - y["z_start"])
                if x and y
                else None,
            }
        )
    return pairs


def compare_summary(adv: dict[str, Any], lift: dict[str, Any], program: str) -> dict[str, Any]:
    pairs = pair_lifts(adv["lifts"], lift["lifts"])
    ratios = [p["clearance_ratio"] for p in pairs if p["clearance_ratio"] is not None]
    return {
        "program": program,
        "cycle_time_s": adv["cycle_time_s"],
        "lifts": pairs,
        "totals": {
            "duration_s": {"advanced": adv["duration_s"], "lifting": lift["duration_s"]},
            "min_clearance_ratio": min(ratios, default=None),
            "mean_clearance_ratio": round(sum(ratios) / len(ratios), 6) if ratios else None,
            "z_a_max_ratio": {
                m: max((x["z_a_max_ratio"] for x in s["lifts"]), default=0.0)
                for m, s in (("advanced", adv), ("lifting", lift))
            },
            "z_overload_cycles": {
                m: s["z_overload"]["warning_cycles"] + s["z_overload"]["error_cycles"]
                for m, s in (("advanced", adv), ("lifting", lift))
            },
        },
        "advanced": adv,
        "lifting": lift,
    }


def compare(
    ch: ChannelParams,
    text: str,
    schedule: Schedule,
    m_ack_delay: float,
    traces: dict[str, TextIO] | None = None,
    max_time: float = 3600.0,
    program: str = "",
) -> Comparison:
    results: dict[str, SimResult] = {}
    samplers: dict[str, LiftSampler] = {}
    for method in METHODS:
        run_ch = channel_for(ch, method)
        sampler = LiftSampler(run_ch.lift_axis_index, run_ch.cycle_time)
        trace = (traces or {}).get(method)
        results[method] = simulate(
            run_ch, text, schedule, m_ack_delay, trace, max_time, sampler.add
        )
        samplers[method] = sampler
    summary = compare_summary(results["advanced"].summary, results["lifting"].summary, program)
    return Comparison(results, samplers, summary)


def describe(summary: dict[str, Any]) -> str:
    """A table for the terminal."""
    lines = [
        f"{'lines':>12}  {'clearance adv':>13}  {'lifting':>8}  {'ratio':>6}  "
        f"{'Z a/a_max adv':>13}  {'lifting':>8}"
    ]
    for p in summary["lifts"]:
        x, y = p["advanced"], p["lifting"]
        name = f"{p['start_line']}-{p['end_line']}"
        ca = f"{x['mean_clearance']:.2f}" if x else "-"
        cb = f"{y['mean_clearance']:.2f}" if y else "-"
        ratio = f"{p['clearance_ratio']:.3f}" if p["clearance_ratio"] is not None else "-"
        aa = f"{x['z_a_max_ratio']:.3f}" if x else "-"
        ab = f"{y['z_a_max_ratio']:.3f}" if y else "-"
        lines.append(f"{name:>12}  {ca:>13}  {cb:>8}  {ratio:>6}  {aa:>13}  {ab:>8}")
    tot = summary["totals"]
    lines.append(
        f"duration advanced {tot['duration_s']['advanced']:.3f} s, lifting "
        f"{tot['duration_s']['lifting']:.3f} s; Z overload cycles (above the P-AXIS-00441 "
        f"level) advanced {tot['z_overload_cycles']['advanced']}, lifting "
        f"{tot['z_overload_cycles']['lifting']}"
    )
    return "\n".join(lines)


def as_arrays(lift: LiftSamples) -> np.ndarray:
    return np.asarray(lift.rows, dtype=float).reshape(-1, 4)
