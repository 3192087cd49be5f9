"""Lift ranges of a path program: which boundaries open and close them, and what kind of lift
each one is (vendor text §2.1.1, §2.1.3, §2.6)."""

from __future__ import annotations

from dataclasses import dataclass

from liftd.cnc.nc.blocks import LiftStart
from liftd.cnc.params import ChannelParams
from liftd.cnc.path.program import ActionKind, PathProgram
from liftd.cnc.pause import EVERY, pause


@dataclass(frozen=True, slots=True)
class LiftRange:
    index: int
    start: LiftStart
    k_start: int  # boundary of LIFT_START
    k_end: int  # boundary of LIFT_END (== k_start for a lift without path motion)
    length: float  # path length between them (m)
    suppressed: bool  # shorter than lift_min_dist (P-CHAN-00244)
    beyond_limit: bool  # POS or the start outside POS_LIMIT: the limit has no effect
    end_line: int

    @property
    def direct(self) -> bool:
        """Z goes straight (time-optimally) to POS instead of lifting."""
        return self.suppressed or self.beyond_limit

    @property
    def moves_z(self) -> bool:
        return abs(self.start.target - self.start.z_start) > 1e-12


def beyond_limit(z_start: float, target: float, limit: float, down: bool) -> bool:
    """Special case 1 (vendor §2.1.3): POS or the start position outside POS_LIMIT."""
    if down:
        return target < limit or z_start < limit
    return target > limit or z_start > limit


def find_ranges(program: PathProgram, ch: ChannelParams) -> tuple[LiftRange, ...]:
    ranges: list[LiftRange] = []
    open_start: tuple[LiftStart, int] | None = None
    for boundary in program.boundaries:
        if not boundary.index & EVERY:
            pause()
        for action in boundary.actions:
            if action.kind is ActionKind.LIFT_START and action.lift_start is not None:
                open_start = (action.lift_start, boundary.index)
            elif action.kind is ActionKind.LIFT_END and open_start is not None:
                spec, k_start = open_start
                length = boundary.s - program.boundaries[k_start].s
                suppressed = ch.lift_min_dist > 0.0 and length < ch.lift_min_dist
                ranges.append(
                    LiftRange(
                        len(ranges),
                        spec,
                        k_start,
                        boundary.index,
                        length,
                        suppressed,
                        beyond_limit(spec.z_start, spec.target, spec.pos_limit, spec.down),
                        action.line,
                    )
                )
                open_start = None
    if open_start is not None:  # open at a program error: Z goes to POS_LIMIT and stays
        spec, k_start = open_start
        ranges.append(LiftRange(len(ranges), spec, k_start, -1, float("inf"), False, False, 0))
    return tuple(ranges)
