"""`liftd simulate PROGRAM --compare`: the same program and PLC schedule run with Advanced
Lifting and with path-based Lifting, paired lift by lift.

The summary (ComparisonSummary, its JSON) holds both full summaries (docs/reference/design.md §3.3)
and, per lift, both lift entries with the ratios advanced / lifting of mean clearance and peak. The
figure (plot.plot_compare) overlays each lift's Z over time and over path distance, needing
per-lift samples: `LiftSampler` keeps them (only for a figure: `compare(plot=True)`) for the
first MAX_PLOTTED lifts, each in at most 2·MAX_ROWS rows (a long lift decimated: each row kept
is the one of largest |a_z| of the cycles it stands for, so the figure's over-limit marks stay),
so memory stays bounded on any program: at most 2 · MAX_PLOTTED · 2·MAX_ROWS rows, ~16 MB.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Generic, TextIO, TypeVar

import numpy as np

from liftd.cnc import batch as cycle_row
from liftd.cnc.params import ChannelParams
from liftd.cnc.plc import Schedule
from liftd.cnc.snapshot import GeoSnapshot
from liftd.sim.simulate import SimResult, channel_for, simulate
from liftd.sim.summary import JsonObject, LiftSummary, SimSummary

METHODS = ("advanced", "lifting")
MAX_PLOTTED = 12
MARGIN = 30  # cycles shown before and after each lift
MAX_ROWS = 4096  # a lift's rows before they are halved (a figure is ~550 px wide)

Row = tuple[float, float, float, float]


def _peak(a: Row, b: Row) -> Row:
    """Of two rows, the one of larger |a_z| (the earlier on a tie)."""
    return b if abs(b[3]) > abs(a[3]) else a


@dataclass
class LiftSamples:
    """One lift of one run: rows of (t, s, z, a_z) in SI units, s the path distance. Past
    2·MAX_ROWS rows they are halved (each pair to its `_peak`) and each later row stands for
    `stride` cycles (the peak of them): a lift of any length keeps at most 2·MAX_ROWS."""

    start_line: int
    rows: list[Row] = field(default_factory=list)
    t_start: float = 0.0
    s_start: float = 0.0
    t_end: float = -1.0
    s_end: float = 0.0
    stride: int = 1
    pending: Row | None = None  # the peak of the cycles since the last row kept
    count: int = 0  # how many cycles `pending` stands for

    def push(self, row: Row) -> None:
        if self.stride == 1:
            self.rows.append(row)
        else:
            self.pending = row if self.pending is None else _peak(self.pending, row)
            self.count += 1
            if self.count < self.stride:
                return
            self.rows.append(self.pending)
            self.pending, self.count = None, 0
        if len(self.rows) >= 2 * MAX_ROWS:
            rows = self.rows
            self.rows = [_peak(rows[i], rows[i + 1]) for i in range(0, len(rows) - 1, 2)]
            self.stride *= 2

    def extend(self, rows: list[Row]) -> None:
        if self.stride == 1 and len(self.rows) + len(rows) < 2 * MAX_ROWS:
            self.rows.extend(rows)
            return
        for row in rows:
            self.push(row)

    def close(self) -> None:
        """The cycles since the last row kept, as one more row (the lift's last cycles)."""
        if self.pending is not None:
            self.rows.append(self.pending)
            self.pending, self.count = None, 0


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
        row = self._sample(snap.t, snap.v_path, snap.positions[self.z_index])
        for ev in snap.events:
            if ev.name == "lift.start" and len(self.lifts) < self.limit:
                self.open = LiftSamples(ev.line, list(self.recent), ev.t, self.s)
                self.lifts.append(self.open)
            elif ev.name == "lift.end" and self.open is not None and self.open.t_end < 0.0:
                self.open.t_end, self.open.s_end = ev.t, self.s
                self.tail = MARGIN
        self._keep(row)

    def _sample(self, t: float, v_path: float, z: float) -> tuple[float, float, float, float]:
        """A cycle's row: the distance and Z's second difference brought up to it."""
        self.s += 0.5 * (self.v + v_path) * self.dt
        self.v = v_path
        a = 0.0
        if self.z1 is not None and self.z2 is not None:
            a = (z - 2.0 * self.z1 + self.z2) / (self.dt * self.dt)
        self.z2, self.z1 = self.z1, z
        return (t, self.s, z, a)

    def _keep(self, row: tuple[float, float, float, float]) -> None:
        """A cycle's row into the recent ones and, while a lift is open or just ended, its."""
        self.recent.append(row)
        if self.open is None:
            return
        self.open.push(row)
        if self.open.t_end >= 0.0:
            self.tail -= 1
            if self.tail <= 0:
                self.open.close()
                self.open = None

    def add_rows(self, rows: list[float], axes_at: int, width: int) -> None:
        """The rows of quiet cycles (liftd/cnc/batch.py; no event: no lift starts or ends in
        them), as `add` of each: s by a sequential sum (`np.add.accumulate`, the same
        additions in the same order), Z's second difference elementwise as `add` writes it;
        the row tuples built only for an open lift and the last MARGIN."""
        n = len(rows) // width
        k = 0
        while k < n and (self.z1 is None or self.z2 is None):  # a run's first cycles
            at = k * width
            z_at = rows[at + axes_at + self.z_index]
            self._keep(self._sample(rows[at + cycle_row.T], rows[at + cycle_row.V_PATH], z_at))
            k += 1
        if k == n:
            return
        base = k * width
        t = rows[base + cycle_row.T :: width]
        v = np.array([self.v, *rows[base + cycle_row.V_PATH :: width]])
        z = np.array([self.z2, self.z1, *rows[base + axes_at + self.z_index :: width]])
        s = np.add.accumulate(np.concatenate(([self.s], 0.5 * (v[:-1] + v[1:]) * self.dt)))[1:]
        a = (z[2:] - 2.0 * z[1:-1] + z[:-2]) / (self.dt * self.dt)
        m = n - k
        self.s, self.v = float(s[-1]), float(v[-1])
        self.z2, self.z1 = float(z[-2]), float(z[-1])
        first = 0 if self.open is not None else max(m - MARGIN, 0)  # the rows kept
        new = list(zip(t[first:], s[first:].tolist(), z[first + 2 :].tolist(),
                       a[first:].tolist(), strict=True))  # fmt: skip
        self.recent.extend(new[-MARGIN:])
        if self.open is None:
            return
        if self.open.t_end < 0.0:
            self.open.extend(new)
            return
        take = min(self.tail, m)
        self.open.extend(new[:take])
        self.tail -= take
        if self.tail <= 0:
            self.open.close()
            self.open = None

    def close(self) -> None:
        """The run ended: a lift still open keeps its last cycles."""
        if self.open is not None:
            self.open.close()


T = TypeVar("T", int, float)


@dataclass(frozen=True, slots=True)
class PerMethod(Generic[T]):
    """One figure of both runs."""

    advanced: T
    lifting: T

    def to_json(self) -> dict[str, T]:
        return {"advanced": self.advanced, "lifting": self.lifting}


@dataclass(frozen=True, slots=True)
class LiftPair:
    """The same lift range in both runs (None where that run never started it: stopped by an
    error before), with the ratios advanced / lifting of mean clearance and of the height Z
    rose (None where either is missing, open at a stop, or nothing was lifted)."""

    start_line: int
    end_line: int
    advanced: LiftSummary | None
    lifting: LiftSummary | None
    clearance_ratio: float | None
    peak_ratio: float | None

    @property
    def ref(self) -> LiftSummary:
        """Either run's entry (for what both share: lines, POS, POS_LIMIT, suppressed)."""
        ref = self.advanced or self.lifting
        assert ref is not None  # a pair has at least one side
        return ref

    def of(self, method: str) -> LiftSummary | None:
        return self.advanced if method == "advanced" else self.lifting

    def to_json(self) -> JsonObject:
        return {
            "start_line": self.start_line,
            "end_line": self.end_line,
            "advanced": self.advanced.to_json() if self.advanced else None,
            "lifting": self.lifting.to_json() if self.lifting else None,
            "clearance_ratio": self.clearance_ratio,
            "peak_ratio": self.peak_ratio,
        }


@dataclass(frozen=True, slots=True)
class CompareTotals:
    duration_s: PerMethod[float]
    min_clearance_ratio: float | None
    mean_clearance_ratio: float | None
    z_a_max_ratio: PerMethod[float]  # the largest of the lifts
    z_overload_cycles: PerMethod[int]  # above the P-AXIS-00441 warning level

    def to_json(self) -> JsonObject:
        return {
            "duration_s": self.duration_s.to_json(),
            "min_clearance_ratio": self.min_clearance_ratio,
            "mean_clearance_ratio": self.mean_clearance_ratio,
            "z_a_max_ratio": self.z_a_max_ratio.to_json(),
            "z_overload_cycles": self.z_overload_cycles.to_json(),
        }


@dataclass(frozen=True, slots=True)
class ComparisonSummary:
    """`simulate --compare --json`: both runs' summaries, their lifts paired, and totals."""

    program: str
    cycle_time_s: float
    lifts: tuple[LiftPair, ...]
    totals: CompareTotals
    advanced: SimSummary
    lifting: SimSummary

    def run(self, method: str) -> SimSummary:
        return self.advanced if method == "advanced" else self.lifting

    def to_json(self) -> JsonObject:
        return {
            "program": self.program,
            "cycle_time_s": self.cycle_time_s,
            "lifts": [p.to_json() for p in self.lifts],
            "totals": self.totals.to_json(),
            "advanced": self.advanced.to_json(),
            "lifting": self.lifting.to_json(),
        }


@dataclass
class Comparison:
    results: dict[str, SimResult]
    samples: dict[str, LiftSampler]
    summary: ComparisonSummary

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


def pair_lifts(adv: tuple[LiftSummary, ...], lift: tuple[LiftSummary, ...]) -> tuple[LiftPair, ...]:
    """Pair the lifts of both runs by start line and occurrence (a run stopped by an error has
    fewer lifts)."""

    def keyed(lifts: tuple[LiftSummary, ...]) -> dict[tuple[int, int], LiftSummary]:
        return dict(zip(occurrence_keys(x.start_line for x in lifts), lifts, strict=True))

    a, b = keyed(adv), keyed(lift)
    pairs = []
    for key in sorted(set(a) | set(b), key=lambda k: (a.get(k) or b[k]).t_start):
        x, y = a.get(key), b.get(key)
        ref = x or y
        assert ref is not None
        if x is None or y is None or x.open or y.open:  # nothing to compare it with
            pairs.append(LiftPair(ref.start_line, ref.end_line, x, y, None, None))
            continue
        pairs.append(
            LiftPair(
                ref.start_line,
                ref.end_line,
                x,
                y,
                _ratio(x.mean_clearance_mm, y.mean_clearance_mm),
                _ratio(x.peak_mm - x.z_start_mm, y.peak_mm - y.z_start_mm),
            )
        )
    return tuple(pairs)


def _largest_z_a(run: SimSummary) -> float:
    return max((x.z_a_max_ratio for x in run.lifts), default=0.0)


def compare_summary(adv: SimSummary, lift: SimSummary, program: str) -> ComparisonSummary:
    pairs = pair_lifts(adv.lifts, lift.lifts)
    ratios = [p.clearance_ratio for p in pairs if p.clearance_ratio is not None]
    return ComparisonSummary(
        program=program,
        cycle_time_s=adv.cycle_time_s,
        lifts=pairs,
        totals=CompareTotals(
            duration_s=PerMethod(adv.duration_s, lift.duration_s),
            min_clearance_ratio=min(ratios, default=None),
            mean_clearance_ratio=round(sum(ratios) / len(ratios), 6) if ratios else None,
            z_a_max_ratio=PerMethod(_largest_z_a(adv), _largest_z_a(lift)),
            z_overload_cycles=PerMethod(adv.z_overload.cycles, lift.z_overload.cycles),
        ),
        advanced=adv,
        lifting=lift,
    )


def compare(
    ch: ChannelParams,
    text: str,
    schedule: Schedule,
    m_ack_delay: float,
    traces: dict[str, TextIO] | None = None,
    max_time: float = 3600.0,
    program: str = "",
    batch: bool = True,
    plot: bool = True,
) -> Comparison:
    """Both runs (`batch`: simulate's, the samplers take the quiet cycles' rows). `plot`: keep
    the per-lift samples a figure needs (`samples`; a study needs none: they cost a Python
    call per cycle that is not batched). Neither run keeps simulate's plot series."""
    results: dict[str, SimResult] = {}
    samplers: dict[str, LiftSampler] = {}
    for method in METHODS:
        run_ch = channel_for(ch, method)
        trace = (traces or {}).get(method)
        if not plot:
            results[method] = simulate(
                run_ch, text, schedule, m_ack_delay, trace, max_time, series=False, batch=batch
            )
            continue
        sampler = LiftSampler(run_ch.lift_axis_index, run_ch.cycle_time)
        results[method] = simulate(
            run_ch, text, schedule, m_ack_delay, trace, max_time, sampler.add,
            series=False, batch=batch, on_rows=sampler.add_rows,
        )  # fmt: skip
        sampler.close()
        samplers[method] = sampler
    summary = compare_summary(results["advanced"].summary, results["lifting"].summary, program)
    return Comparison(results, samplers, summary)


def describe(summary: ComparisonSummary) -> str:
    """A table for the terminal."""
    lines = [
        f"{'lines':>12}  {'clearance adv':>13}  {'lifting':>8}  {'ratio':>6}  "
        f"{'Z a/a_max adv':>13}  {'lifting':>8}"
    ]
    for p in summary.lifts:
        x, y = p.advanced, p.lifting
        name = f"{p.start_line}-{p.end_line}"
        ca = f"{x.mean_clearance_mm:.2f}" if x else "-"
        cb = f"{y.mean_clearance_mm:.2f}" if y else "-"
        ratio = f"{p.clearance_ratio:.3f}" if p.clearance_ratio is not None else "-"
        aa = f"{x.z_a_max_ratio:.3f}" if x else "-"
        ab = f"{y.z_a_max_ratio:.3f}" if y else "-"
        lines.append(f"{name:>12}  {ca:>13}  {cb:>8}  {ratio:>6}  {aa:>13}  {ab:>8}")
    tot = summary.totals
    lines.append(
        f"duration advanced {tot.duration_s.advanced:.3f} s, lifting "
        f"{tot.duration_s.lifting:.3f} s; Z overload cycles (above the P-AXIS-00441 "
        f"level) advanced {tot.z_overload_cycles.advanced}, lifting "
        f"{tot.z_overload_cycles.lifting}"
    )
    return "\n".join(lines)


def as_arrays(lift: LiftSamples) -> np.ndarray:
    rows = lift.rows if lift.pending is None else [*lift.rows, lift.pending]
    return np.asarray(rows, dtype=float).reshape(-1, 4)
