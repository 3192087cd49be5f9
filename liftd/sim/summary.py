"""The summary of a simulated run (docs/reference/design.md §3.3) as frozen values, and its JSON.

The fields hold what the JSON reports, in its units (mm where the name says so, else s or a
ratio) and already rounded as the JSON has them, so every reader (compare, plot, study, the
CLI) sees the numbers the user sees. `to_json()` maps them to the contract's keys in the
contract's order. Pure: built from the core's `LiftRecord`s after a run, no IO.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from liftd.cnc.geo_task import LIFT_LATE_ID
from liftd.cnc.lift.controller import LiftRecord
from liftd.cnc.params import AxisParams, ChannelParams, LiftMethod
from liftd.sim.trace import MM

JsonObject = dict[str, Any]


@dataclass(frozen=True, slots=True)
class LiftSummary:
    """One lift range as the summary reports it.

    `open`: the program stopped (an NC error, or --max-time) inside the range (issue 15 item 6).
    Then `t_end` is the time of the cycle it stopped in (the run's `duration_s`), `peak_mm`
    and `mean_clearance_mm` are what Z did until then, `arrival_error_mm` is |Z − POS| at the
    stop, `path_delay_s` is 0 (the path never reached LIFT_END), and `end_line` is the line
    the program stopped at when the range's LIFT_END was never decoded."""

    start_line: int
    end_line: int
    method: str
    suppressed: bool
    z_start_mm: float
    z_target_mm: float
    pos_limit_mm: float
    peak_mm: float
    mean_clearance_mm: float
    t_start: float
    t_end: float
    arrival_error_mm: float
    path_delay_s: float
    duration_s: float
    z_a_max_ratio: float
    premature: bool
    open: bool = False

    @classmethod
    def closed(cls, rec: LiftRecord, method: LiftMethod) -> LiftSummary:
        """A range the path left through LIFT_END (the core's `lift.records`)."""
        return cls._of(rec, method, rec.t_end, rec.arrival_error, rec.path_delay)

    @classmethod
    def at_stop(
        cls, rec: LiftRecord, method: LiftMethod, t_stop: float, z: float, stop_line: int
    ) -> LiftSummary:
        """The range still open (the core's `lift.record`) when the program stopped at t_stop
        in `stop_line`, Z at z [m]."""
        error = abs(z - rec.range.start.target)
        lift = cls._of(rec, method, t_stop, error, 0.0, open=True)
        if rec.range.end_line > 0:
            return lift
        return dataclasses.replace(lift, end_line=stop_line)

    @classmethod
    def _of(
        cls,
        rec: LiftRecord,
        method: LiftMethod,
        t_end: float,
        arrival_error: float,
        path_delay: float,
        open: bool = False,
    ) -> LiftSummary:
        spec = rec.range.start
        duration = t_end - rec.t_start
        return cls(
            start_line=spec.line,
            end_line=rec.range.end_line,
            method=method.value,
            suppressed=rec.range.suppressed,
            z_start_mm=round(rec.z_start * MM, 6),
            z_target_mm=round(spec.target * MM, 6),
            pos_limit_mm=round(spec.pos_limit * MM, 6),
            peak_mm=round(rec.peak * MM, 6),
            mean_clearance_mm=round(rec.area / duration * MM, 6) if duration > 0 else 0.0,
            t_start=round(rec.t_start, 6),
            t_end=round(t_end, 6),
            arrival_error_mm=round(arrival_error * MM, 6),
            path_delay_s=round(path_delay, 6),
            duration_s=round(duration, 6),
            z_a_max_ratio=round(rec.z_a_max_ratio, 6),
            premature=rec.premature,
            open=open,
        )

    @property
    def height_mm(self) -> float:
        """How far Z rose (or, DOWN, fell) from its start: |peak − z_start|."""
        return abs(self.peak_mm - self.z_start_mm)

    def to_json(self) -> JsonObject:
        return {
            "start_line": self.start_line,
            "end_line": self.end_line,
            "method": self.method,
            "suppressed": self.suppressed,
            "z_start": self.z_start_mm,
            "z_target": self.z_target_mm,
            "pos_limit": self.pos_limit_mm,
            "peak": self.peak_mm,
            "mean_clearance": self.mean_clearance_mm,
            "t_start": self.t_start,
            "t_end": self.t_end,
            "arrival_error": self.arrival_error_mm,
            "path_delay_s": self.path_delay_s,
            "duration_s": self.duration_s,
            "z_a_max_ratio": self.z_a_max_ratio,
            "premature": self.premature,
            "open": self.open,
        }


@dataclass(frozen=True, slots=True)
class AxisLimits:
    """max |v|, |a|, |j| / limit of one axis over the run (finite differences of the sampled
    positions); `prefix` is "z" for the lift axis, else the axis name in lower case, and
    "path_z" for an axis named Z that is not the lift axis (W lifts, Z is a path axis): its
    keys would overwrite the lift axis's. `segment` and `transition`: the same over the
    differences that span no block transition and over those that span one (issue 36: a
    transition may step an axis' acceleration as far as the CNC's block-transition parameters
    allow, path/limits.py); (v, a, j) each."""

    prefix: str
    v_max_ratio: float
    a_max_ratio: float
    j_max_ratio: float
    segment: tuple[float, float, float] = (0.0, 0.0, 0.0)
    transition: tuple[float, float, float] = (0.0, 0.0, 0.0)


Maxima = tuple[np.ndarray, np.ndarray, np.ndarray]


def _axis_ratios(ax: AxisParams, i: int, maxima: Maxima) -> tuple[float, float, float]:
    v, a, j = maxima
    return (
        float(v[i] / ax.v_max),
        float(a[i] / ax.a_max),
        float(j[i] / ax.j_max) if ax.j_max != math.inf else 0.0,
    )


@dataclass(frozen=True, slots=True)
class Limits:
    axes: tuple[AxisLimits, ...]  # the lift axis first, then the others in channel order

    @classmethod
    def of(
        cls, ch: ChannelParams, max_v: np.ndarray, max_a: np.ndarray, max_j: np.ndarray,
        segments: Maxima | None = None, transitions: Maxima | None = None,
    ) -> Limits:  # fmt: skip
        """From the maxima per channel axis [SI] (trace.LimitMonitor.result, .segments,
        .transitions)."""
        z = ch.lift_axis_index
        order = [z] + [i for i in range(len(ch.axes)) if i != z]
        axes = []
        for i in order:
            ax = ch.axes[i]
            name = ax.name.lower()
            whole = _axis_ratios(ax, i, (max_v, max_a, max_j))
            axes.append(
                AxisLimits(
                    "z" if i == z else ("path_z" if name == "z" else name),
                    *whole,
                    segment=_axis_ratios(ax, i, segments) if segments is not None else whole,
                    transition=(
                        _axis_ratios(ax, i, transitions)
                        if transitions is not None
                        else (0.0, 0.0, 0.0)
                    ),
                )
            )
        return cls(tuple(axes))

    def worst(self) -> float:
        """The largest ratio of any axis and derivative."""
        return max((r for ax in self.axes for r in _ratios(ax)), default=0.0)

    def to_json(self) -> dict[str, float]:
        out: dict[str, float] = {}
        for ax in self.axes:
            out[f"{ax.prefix}_v_max_ratio"] = ax.v_max_ratio
            out[f"{ax.prefix}_a_max_ratio"] = ax.a_max_ratio
            out[f"{ax.prefix}_j_max_ratio"] = ax.j_max_ratio
        for kind in ("segment", "transition"):
            for ax in self.axes:
                ratios = ax.segment if kind == "segment" else ax.transition
                for name, r in zip(("v", "a", "j"), ratios, strict=True):
                    out[f"{ax.prefix}_{kind}_{name}_max_ratio"] = r
        return out


def _ratios(ax: AxisLimits) -> tuple[float, float, float]:
    return ax.v_max_ratio, ax.a_max_ratio, ax.j_max_ratio


@dataclass(frozen=True, slots=True)
class Overload:
    """The P-AXIS-00441/00442 monitor of the lift axis: levels as multiples of a_max (inf when
    off) and the cycles above each."""

    warning_ratio: float
    error_ratio: float
    warning_cycles: int
    error_cycles: int

    @property
    def cycles(self) -> int:
        """Cycles above the warning level (the error level included)."""
        return self.warning_cycles + self.error_cycles

    def to_json(self) -> JsonObject:
        return {
            "warning_ratio": self.warning_ratio,
            "error_ratio": self.error_ratio,
            "warning_cycles": self.warning_cycles,
            "error_cycles": self.error_cycles,
        }


@dataclass(frozen=True, slots=True)
class StepCpu:
    """CPU time of GeoTask.step per cycle [µs]: percentiles (1 µs buckets) and the maximum."""

    p50_us: float
    p99_us: float
    p999_us: float
    max_us: float

    def to_json(self) -> dict[str, float]:
        return {"p50": self.p50_us, "p99": self.p99_us, "p999": self.p999_us, "max": self.max_us}


@dataclass(frozen=True, slots=True)
class ErrorEntry:
    """An NC error that stopped the program (ISG id), or LIFT_LATE_ID (990037): a lift whose Z
    was not at POS when the path passed LIFT_END (never expected; the program goes on)."""

    error_id: int
    line: int
    message: str
    # the subroutine file `line` is in ("": the program), as `liftd check` names it
    file: str = ""

    @property
    def stops_program(self) -> bool:
        return self.error_id != LIFT_LATE_ID

    def to_json(self) -> JsonObject:
        out: JsonObject = {"id": self.error_id, "line": self.line, "message": self.message}
        if self.file:
            out["file"] = self.file
        return out


@dataclass(frozen=True, slots=True)
class SimSummary:
    """The JSON summary of one run (docs/reference/design.md §3.3 and its extensions)."""

    cycle_time_s: float
    duration_s: float
    cycles: int
    method: str
    lifts: tuple[LiftSummary, ...]  # in the order they started; an open one last
    limits: Limits
    z_overload: Overload
    errors: tuple[ErrorEntry, ...]
    step_cpu_us: StepCpu

    @property
    def program_error(self) -> bool:
        """An NC error stopped the program (a late lift alone does not)."""
        return any(e.stops_program for e in self.errors)

    def to_json(self) -> JsonObject:
        return {
            "cycle_time_s": self.cycle_time_s,
            "duration_s": self.duration_s,
            "cycles": self.cycles,
            "method": self.method,
            "lifts": [x.to_json() for x in self.lifts],
            "limits": self.limits.to_json(),
            "z_overload": self.z_overload.to_json(),
            "errors": [e.to_json() for e in self.errors],
            "step_cpu_us": self.step_cpu_us.to_json(),
        }


def describe(summary: SimSummary) -> str:
    """One line for the terminal (and the figure's title)."""
    lifts = summary.lifts
    clear = [f"{x.mean_clearance_mm:.1f}" for x in lifts if not x.suppressed]
    return (
        f"method {summary.method}, {len(lifts)} lifts, mean clearance [mm]: "
        f"{', '.join(clear) or '-'}, duration {summary.duration_s:.2f} s"
    )


@dataclass(frozen=True, slots=True)
class ChannelSummary:
    """One channel's run in a machine of several channels."""

    channel_id: int
    program: str  # the program's path, "" for a channel that idled
    summary: SimSummary

    def to_json(self) -> JsonObject:
        return {"channel": self.channel_id, "program": self.program, **self.summary.to_json()}


def machine_json(primary: SimSummary, channels: tuple[ChannelSummary, ...]) -> JsonObject:
    """simulate's JSON for several channels: the [cnc] channel's summary where a single
    channel's is (docs/reference/design.md §3.3), and every channel's, that one included, under
    "channels" in channel order. One channel: exactly the single-channel JSON."""
    out = primary.to_json()
    if len(channels) > 1:
        out["channels"] = [c.to_json() for c in channels]
    return out
