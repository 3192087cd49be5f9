"""A program ready for the GEO task: decoded, path-prepared, lift ranges found, and the path
limited where Z needs more time than the path would give it.

Advanced Lifting: if Z cannot reach POS in the path time of a range, "the path feed rate is
reduced automatically; in extreme cases (path length 0) the path axes stop" (vendor §2.1.1).
liftd caps the path velocity inside such a range at length / t_Z, where t_Z is Z's time-optimal
move to POS; a range without path motion is a stop where the path waits for Z.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from liftd.cnc.lift.profile import LiftProfileError, LiftProfiles
from liftd.cnc.lift.ranges import LiftRange, find_ranges
from liftd.cnc.nc import DecoderContext, NcError, decode
from liftd.cnc.nc.blocks import Severity
from liftd.cnc.params import ChannelParams, LiftMethod
from liftd.cnc.path.geometry import Vec
from liftd.cnc.path.program import Action, ActionKind, PathProgram, prepare


@dataclass(frozen=True, slots=True)
class GeoProgram:
    path: PathProgram
    ranges: tuple[LiftRange, ...]
    error: NcError | None  # first decode error: execution stops at the end of `path`
    warnings: tuple[NcError, ...]
    first_line: int
    stops: tuple[tuple[int, ...], ...]  # per range: waiting points strictly inside it
    z_index: int

    def range_at(self, action: Action) -> LiftRange:
        for rng in self.ranges:
            if rng.start is action.lift_start:
                return rng
        raise KeyError(action.line)

    def stops_in(self, rng: LiftRange) -> tuple[int, ...]:
        return self.stops[rng.index]

    def conditional_for(self, number: int) -> list[int]:
        """Boundaries where an MVS_SNS M<number> waits for its acknowledge."""
        return [
            b.index
            for b in self.path.boundaries
            if b.conditional_stop
            and any(a.kind is ActionKind.M_WAIT and a.m_number == number for a in b.actions)
        ]

    def boundary_position(self, k: int) -> Vec:
        segs = self.path.segments
        if k < len(segs):
            return segs[k].geom.start
        return self.path.end_position

    def z_direction_into(self, k: int) -> float:
        """Direction cosine of the lift axis at the end of the segment before boundary k."""
        if k == 0 or not self.path.segments:
            return 0.0
        seg = self.path.segments[k - 1]
        return seg.geom.tangent(seg.length)[self.z_index]


def _cap_for_lifts(
    path: PathProgram, ranges: tuple[LiftRange, ...], ch: ChannelParams
) -> PathProgram:
    z = ch.axis(ch.lift_axis)
    prof = LiftProfiles(z.v_max, z.a_max, z.j_max)
    segs = list(path.segments)
    for rng in ranges:
        if rng.k_end <= rng.k_start or not rng.moves_z:
            continue
        try:
            t_z = prof.to_rest(rng.start.z_start, 0.0, 0.0, rng.start.target).duration
        except LiftProfileError:
            continue
        if t_z <= 0.0:
            continue
        cap = rng.length / t_z
        for k in range(rng.k_start, rng.k_end):
            segs[k] = dataclasses.replace(segs[k], v_lift=min(segs[k].v_lift, cap))
    return dataclasses.replace(path, segments=tuple(segs))


def _stops_inside(path: PathProgram, rng: LiftRange) -> tuple[int, ...]:
    if rng.k_end < 0:
        return ()
    return tuple(k for k in range(rng.k_start + 1, rng.k_end) if path.boundaries[k].stop)


def load_program(text: str, ch: ChannelParams, start: Vec) -> GeoProgram:
    result = decode(text, DecoderContext.from_channel(ch, start))
    path = prepare(result.blocks, ch, start)
    ranges = find_ranges(path, ch)
    if ch.lift_method is LiftMethod.ADVANCED:
        path = _cap_for_lifts(path, ranges, ch)
    first = result.blocks[0].line if result.blocks else 1
    warnings = tuple(e for e in result.errors if e.severity is Severity.WARNING)
    return GeoProgram(
        path=path,
        ranges=ranges,
        error=result.first_error,
        warnings=warnings,
        first_line=first,
        stops=tuple(_stops_inside(path, r) for r in ranges),
        z_index=ch.lift_axis_index,
    )
