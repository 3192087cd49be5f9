"""The lift ranges of a decoded program, one readable line each, for `liftd check` (issue 15):
where a range is, the lift method, POS, the limit in effect, the path it covers and whether
the lift is suppressed (P-CHAN-00244) — what the decoder knows, without simulating.

The planned peak height and the nominal time of an Advanced Lifting range come from the GEO
core, not from the decoder. `LiftPlanHook` is where it plugs in: given a range it returns
(peak m, nominal s), or None for a range it did not plan (`liftd check` runs the core over
the first CHECK_PLAN_SECONDS of the program: `liftd.sim.simulate.plan_lifts`)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from liftd.cnc.lift.ranges import beyond_limit
from liftd.cnc.nc.blocks import Block, LiftEndCause, LiftStart, Motion
from liftd.cnc.params import LiftMethod

MM = 1e3  # mm per m, for the text only


@dataclass(frozen=True, slots=True)
class LiftRangeSummary:
    index: int  # 1-based, in program order
    start: LiftStart
    start_file: str  # "" = the program's own file
    end_line: int | None  # None: the range is still open where the program stops
    end_file: str
    end_cause: LiftEndCause | None
    length: float  # m: path from the LIFT_START block's start to the LIFT_END block's end
    suppressed: bool  # shorter than lift_min_dist: no lift, Z goes to POS (vendor §2.6)

    @property
    def beyond_limit(self) -> bool:
        """Vendor §2.1.3 special case 1 (and its DOWN mirror): the limit has no effect."""
        s = self.start
        return beyond_limit(s.z_start, s.target, s.pos_limit, s.down)


# (peak height m, nominal time s) of a range as the lift planner would plan it, or None
LiftPlanHook = Callable[[LiftRangeSummary], tuple[float, float] | None]


def motion_length(motion: Motion) -> float:
    """Path length of one block's motion, m (lines: every axis; arcs: the arc in the plane)."""
    if motion.center is not None:
        cx, cy = motion.center
        radius = math.hypot(motion.start[0] - cx, motion.start[1] - cy)
        return abs(motion.sweep) * radius
    return math.dist(motion.start, motion.end)


class LiftRangeTracker:
    """Follows a block stream and keeps one summary per lift range (memory: the ranges, not
    the blocks)."""

    def __init__(self, lift_min_dist: float) -> None:
        self.lift_min_dist = lift_min_dist  # P-CHAN-00244, m
        self.ranges: list[LiftRangeSummary] = []
        self._open: tuple[LiftStart, str] | None = None
        self._length = 0.0

    def feed(self, block: Block) -> None:
        if block.lift_start is not None:
            self._open = (block.lift_start, block.file)
            self._length = 0.0
        if self._open is not None and block.motion is not None:
            self._length += motion_length(block.motion)
        if block.lift_end is not None and self._open is not None:
            self._close(block.line, block.file, block.lift_end.cause)

    def finish(self) -> list[LiftRangeSummary]:
        """The ranges; one still open (the program stopped at an error) is listed open."""
        if self._open is not None:
            self._close(None, "", None)
        return self.ranges

    def _close(self, line: int | None, file: str, cause: LiftEndCause | None) -> None:
        assert self._open is not None
        start, start_file = self._open
        suppressed = (
            line is not None and self.lift_min_dist > 0.0 and self._length < self.lift_min_dist
        )
        self.ranges.append(
            LiftRangeSummary(
                len(self.ranges) + 1,
                start,
                start_file,
                line,
                file,
                cause,
                self._length,
                suppressed,
            )
        )
        self._open = None


def _lines(r: LiftRangeSummary, program: str) -> str:
    """`lines 12-18`, `lines sub.nc:1-5`; a range that starts in one file and ends in another
    names each end with its own file: `lines sub.nc:1 to job.nc:6` (`program`: the name of
    the program's own file, whose lines carry no file)."""
    start = f"{r.start_file}:{r.start.line}" if r.start_file else str(r.start.line)
    if r.end_line is None:
        return f"from line {start}"
    if r.end_file != r.start_file:
        return (
            f"lines {r.start_file or program}:{r.start.line} to "
            f"{r.end_file or program}:{r.end_line}"
        )
    return f"line {start}" if r.end_line == r.start.line else f"lines {start}-{r.end_line}"


METHOD_NAMES = {
    LiftMethod.ADVANCED: "Advanced Lifting",
    LiftMethod.LIFTING: "Lifting (path-based)",
    LiftMethod.NONE: "no lift method",
}


def describe(
    r: LiftRangeSummary,
    method: LiftMethod,
    plan: LiftPlanHook | None = None,
    program: str = "program",
) -> str:
    """One line: `lift 3: lines 12-18, Advanced Lifting, Z 1.000 -> POS 1.000 mm, limit
    30.000 mm, path 23.400 mm: lifts (planned peak 41.2 mm, nominal 0.120 s)`. `program`:
    the program's own file, named where a range spans two files."""
    s = r.start
    kind = ", single block" if s.single_block else ""
    down = ", DOWN" if s.down else ""
    head = (
        f"lift {r.index}: {_lines(r, program)}{kind}{down}, {METHOD_NAMES[method]}, "
        f"{s.axis} {s.z_start * MM:.3f} -> POS {s.target * MM:.3f} mm"
    )
    limit = f"limit {s.pos_limit * MM:.3f} mm"
    if s.limit_programmed is not None:
        limit += f" (POS_LIMIT {s.limit_programmed * MM:.3f} held at the software limit)"
    if r.beyond_limit:
        limit += " without effect (POS or the start beyond it, vendor §2.1.3 special case 1)"
    path = f"path {r.length * MM:.3f} mm"
    if r.end_line is None:
        # the maximum lift height: POS_LIMIT, raised to the start or POS beyond it (§2.1.1)
        far = min if s.down else max
        top = far(far(s.pos_limit, s.target), s.z_start)
        state = (
            f"open where the program stops: {s.axis} goes to {top * MM:.3f} mm, the maximum "
            "lift height, and stays (vendor §2.1.1, §2.4)"
        )
    elif r.suppressed:
        state = f"suppressed (path shorter than lift_min_dist, P-CHAN-00244): {s.axis} goes to POS"
    elif r.beyond_limit:
        state = f"{s.axis} goes to POS at the start"
    else:
        state = "lifts"
        if method is LiftMethod.ADVANCED:
            planned = plan(r) if plan is not None else None
            if plan is None:
                state += " (peak and nominal time: not planned by check)"
            elif planned is None:
                state += " (peak and nominal time: beyond what check plans; liftd simulate)"
            else:
                peak, seconds = planned
                state += f" (planned peak {peak * MM:.3f} mm, nominal {seconds:.3f} s)"
    return f"{head}, {limit}, {path}: {state}"
