"""A program ready for the GEO task: decoded, path-prepared, lift ranges found, and the path
limited where Z needs more time than the path would give it.

Advanced Lifting: if Z cannot reach POS in the path time of a range, "the path feed rate is
reduced automatically; in extreme cases (path length 0) the path axes stop" (vendor §2.1.1).
liftd caps the path velocity inside such a range at length / t_Z, where t_Z is Z's time-optimal
move to POS; a range without path motion is a stop where the path waits for Z.

Path-based Lifting: z(s) is planned here for every range with path motion (lift/path_based.py)
and the segments of the range get the reduced feed and the path acceleration and jerk limits
the coupling needs. A range without path motion, or one ruckig refuses to plan, is run
time-based like Advanced Lifting (the path waits for Z).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import cast

from liftd.cnc.lift.advanced import FirstRise
from liftd.cnc.lift.path_based import RangePlan, ZLimits, plan_range
from liftd.cnc.lift.profile import LiftProfiles, ProfileError
from liftd.cnc.lift.ranges import LiftRange, find_ranges
from liftd.cnc.nc import DecoderContext, NcError, decode
from liftd.cnc.nc.blocks import Severity
from liftd.cnc.params import PLANNING_MARGIN, ChannelParams, LiftMethod
from liftd.cnc.path.geometry import Vec, within
from liftd.cnc.path.program import ActionKind, PathProgram, prepare
from liftd.cnc.path.table import PathTable, build_table
from liftd.cnc.path.velocity import brake_distance
from liftd.cnc.pause import EVERY, pause, release
from liftd.cnc.plc import MAX_OVERRIDE


@dataclass(frozen=True, slots=True)
class GeoProgram:
    path: PathProgram
    ranges: tuple[LiftRange, ...]
    error: NcError | None  # first decode error: execution stops at the end of `path`
    warnings: tuple[NcError, ...]
    first_line: int
    # per range: its waiting points inside it (LIFT_START's boundary where a wait follows the
    # LIFT_START there, `_waits_after_start`)
    stops: tuple[tuple[int, ...], ...]
    # per range: boundaries strictly inside it where the path stops only for a #FLUSH / #FLUSH
    # WAIT (not waiting points of the lift: vendor §2.1.3 case 3, `LiftAhead.horizon`)
    flushes: tuple[tuple[int, ...], ...]
    z_index: int
    plans: tuple[RangePlan | None, ...]  # per range: z(s) of path-based Lifting, else None
    table: PathTable  # what the path tracker reads (with the lift ranges' limits)
    nominal: PathTable  # the same path without any lift's limits (for path_delay_s)
    conditional: dict[int, tuple[int, ...]]  # M number → boundaries where MVS_SNS waits for it
    # per range: whether the lifts' limits change the path the tracker sees while it runs (the
    # range and a look-ahead on either side); if not, its nominal run is the path itself until
    # an override limit, a stop for Z or a wait makes them part
    nominal_differs: tuple[bool, ...] = ()
    # per range: direction cosine of its lift axis at the end of the segment before LIFT_START
    # (Z's velocity when the path passes it); the LIFT_START spec (by identity) → range index
    # (the GEO cycle's lookup of the range a LIFT_START action opens: `BoundaryActions._do`)
    entry_dir: tuple[float, ...] = ()
    range_of: dict[int, int] = dataclasses.field(default_factory=dict)
    # per time-based range: Advanced Lifting's rise from Z at rest at the programmed start,
    # (start in the generator's coordinates, profile), prepared so that a lift start costs
    # one ruckig solve less in its GEO cycle; None for coupled or suppressed ranges
    rises: tuple[FirstRise | None, ...] = ()
    # the axes the program lifts (its LIFT_STARTs' axes, in order of first use): a run's lift
    # generators, guards and monitors are built for these, not once per range
    lift_axes: tuple[str, ...] = ()

    def boundary_position(self, k: int) -> Vec:
        segs = self.path.segments
        if k < len(segs):
            return segs[k].geom.start
        return self.path.end_position


def _direction_into(path: PathProgram, k: int, axis: int) -> float:
    """Direction cosine of an axis at the end of the segment before boundary k."""
    if k == 0 or not path.segments:
        return 0.0
    seg = path.segments[k - 1]
    return seg.geom.tangent(seg.length)[axis]


def _first_rises(
    ranges: tuple[LiftRange, ...], plans: tuple[RangePlan | None, ...], ch: ChannelParams
) -> tuple[FirstRise | None, ...]:
    """Each time-based range's rise as `AdvancedLift` plans it when Z starts the range at
    rest at its programmed start: the same solve with the same inputs, done here."""
    profiles: dict[str, LiftProfiles] = {}
    out: list[FirstRise | None] = []
    for rng, plan in zip(ranges, plans, strict=True):
        pause()  # a ruckig solve per range
        spec = rng.start
        if plan is not None or rng.suppressed:
            out.append(None)
            continue
        if spec.axis not in profiles:
            z = ch.axis(spec.axis)
            profiles[spec.axis] = LiftProfiles(z.v_max, z.a_max, z.j_max)
        sign = -1.0 if spec.down else 1.0
        q0 = sign * spec.z_start
        try:
            rise = profiles[spec.axis].to_rest(
                q0, 0.0, 0.0, max(sign * spec.pos_limit, sign * spec.target)
            )
        except ProfileError:
            out.append(None)
            continue
        out.append(FirstRise(q0, rise))
    return tuple(out)


def _cap_for_lifts(
    path: PathProgram, ranges: tuple[LiftRange, ...], ch: ChannelParams
) -> PathProgram:
    profiles: dict[str, LiftProfiles] = {}
    segs = list(path.segments)
    for rng in ranges:
        pause()
        if rng.k_end <= rng.k_start or not rng.moves_z:
            continue
        axis = rng.start.axis
        if axis not in profiles:
            z = ch.axis(axis)
            profiles[axis] = LiftProfiles(z.v_max, z.a_max, z.j_max)
        try:
            t_z = profiles[axis].to_rest(rng.start.z_start, 0.0, 0.0, rng.start.target).duration
        except ProfileError:
            continue
        if t_z <= 0.0:
            continue
        cap = rng.length / t_z
        for k in range(rng.k_start, rng.k_end):
            segs[k] = dataclasses.replace(segs[k], v_lift=min(segs[k].v_lift, cap))
    return dataclasses.replace(path, segments=tuple(segs))


def lifting_profiles(ch: ChannelParams, axis: str | None = None) -> LiftProfiles:
    """Planning dynamics of path-based Lifting: a_max · P-AXIS-00442/1000 (vendor §4.2.2)."""
    z = ch.axis(axis or ch.lift_axis)
    share = z.dyn_a_err if z.dyn_a_err > 0.0 else 1.0
    return LiftProfiles(z.v_max, z.a_max * share, z.j_max)


def _couple_lifts(
    path: PathProgram, ranges: tuple[LiftRange, ...], ch: ChannelParams
) -> tuple[PathProgram, tuple[RangePlan | None, ...]]:
    segs = list(path.segments)
    plans: list[RangePlan | None] = [None] * len(ranges)
    profiles: dict[str, LiftProfiles] = {}
    for rng in ranges:
        pause()  # a range's z(s) plan
        k_last = rng.k_end if rng.k_end >= 0 else len(path.segments)
        if k_last <= rng.k_start:  # no path motion in the range: time-based, the path waits
            continue
        axis = rng.start.axis
        z = ch.axis(axis)
        if axis not in profiles:
            profiles[axis] = lifting_profiles(ch, axis)
        # Z within its limits at 100 % override: a_max, or P-AXIS-00442's planning
        # acceleration where that is higher (the vendor's a_max,Lift, §4.1); v_max at any.
        # P-AXIS-00442 (dyn_monitoring_a_err, 0.1 %, default 1000):
        # https://infosys.beckhoff.com/content/1033/tf5200_axis_parameter/117565323.html,
        # its use for the lift: https://infosys.beckhoff.com/content/1033/tf5200_lift_axis/223158923.html
        keep = 1.0 - PLANNING_MARGIN
        a_lift = max(z.a_max, profiles[axis].a_max)
        z_lim = ZLimits(z.v_max * keep, a_lift * keep, z.j_max * keep)
        try:
            plan, caps = plan_range(path, rng, profiles[axis], z_lim)
        except ProfileError:
            continue
        plans[rng.index] = plan
        for cap in caps:
            seg = segs[cap.k]
            segs[cap.k] = seg.limited(
                min(seg.v_lift_ov, cap.v_ov),
                min(seg.a_max, cap.a),
                min(seg.j_max, cap.j),
                min(seg.v_lift, cap.v),
            )
    return dataclasses.replace(path, segments=tuple(segs)), tuple(plans)


_WAITS = frozenset((ActionKind.M_WAIT, ActionKind.M00, ActionKind.DWELL, ActionKind.PROGRAM_END))


def _flush_only(path: PathProgram, k: int) -> bool:
    """Whether the path stops at boundary k for a #FLUSH and for nothing that waits."""
    b = path.boundaries[k]
    kinds = {a.kind for a in b.actions}
    return ActionKind.FLUSH in kinds and not kinds & _WAITS and not b.conditional_stop


def _stops_inside(path: PathProgram, rng: LiftRange, flush: bool) -> tuple[int, ...]:
    """The boundaries inside `rng` where the path stops: those that wait (`flush` False) or
    those that stop only for a #FLUSH (`flush` True). LIFT_START's own boundary is one where
    such a wait follows the LIFT_START there (`Z[LIFT_START …]` then `G04`): the range has
    begun when the path waits (as a wait before it lies before the range)."""
    if rng.k_end < 0:
        return ()
    inside = tuple(
        k
        for k in range(rng.k_start + 1, rng.k_end)
        if path.boundaries[k].stop and _flush_only(path, k) == flush
    )
    if rng.k_end > rng.k_start and _waits_after_start(path, rng, flush):
        return (rng.k_start, *inside)
    return inside


def _waits_after_start(path: PathProgram, rng: LiftRange, flush: bool) -> bool:
    """Whether the path stops at LIFT_START's boundary after the LIFT_START there: for a wait
    (`flush` False) or only for a #FLUSH (`flush` True)."""
    b = path.boundaries[rng.k_start]
    kinds: set[ActionKind] = set()
    begun = False
    for a in b.actions:
        if a.kind is ActionKind.LIFT_START:
            begun = a.lift_start is rng.start
        elif begun:
            kinds.add(a.kind)
    if kinds & (_WAITS - {ActionKind.PROGRAM_END}):
        return not flush
    return flush and ActionKind.FLUSH in kinds


def _conditional(path: PathProgram) -> dict[int, tuple[int, ...]]:
    out: dict[int, list[int]] = {}
    for b in path.boundaries:
        if not b.index & EVERY:
            pause()
        if b.conditional_stop:
            for a in b.actions:
                if a.kind is ActionKind.M_WAIT:
                    out.setdefault(a.m_number, []).append(b.index)
    return {m: tuple(ks) for m, ks in out.items()}


def _limits_reach(
    rng: LiftRange, changed: list[int], nominal: PathTable, ch: ChannelParams
) -> bool:
    """Whether segments the lifts' limits changed can shape the path inside `rng`: those in
    the range, and those after it that the path inside it can see (within its look-ahead
    and its braking distance from the fastest it can go there at 200 % override). Segments
    before the range cannot: the nominal run starts from the path's state at LIFT_START."""
    n = nominal.n
    end = rng.k_end if rng.k_end >= 0 else n
    last = min(end + max(1, ch.look_ahead_blocks) + 1, n)
    inside = [k for k in changed if rng.k_start <= k < last]
    if not inside:
        return False
    if any(k < end for k in inside):
        return True
    top = max(nominal.ceiling(k, MAX_OVERRIDE) for k in range(rng.k_start, last))
    runs = {nominal.run[k] for k in range(rng.k_start, last)}
    a_min = min(nominal.run_a[r] for r in runs)
    j_min = min(nominal.run_j[r] for r in runs)
    reach = brake_distance(top, 0.0, 0.0, a_min, j_min) + 1e-3  # m, and a mm to spare
    s_end = nominal.s[min(end, n)]
    return any(nominal.s[k] - s_end <= reach for k in inside)


def load_program(text: str, ch: ChannelParams, start: Vec) -> GeoProgram:
    """Decode and prepare `text` for a run from `start`, with pause points (pause.py)
    between its stages and in their loops."""
    result = decode(text, DecoderContext.from_channel(ch, start))
    blocks = list(result.blocks)  # freed a piece at a time below (pause.py)
    path = prepare(result.blocks, ch, start)
    nominal = build_table(path)
    ranges = find_ranges(path, ch)
    plans: tuple[RangePlan | None, ...] = (None,) * len(ranges)
    original = path.segments
    if ch.lift_method is LiftMethod.ADVANCED:
        path = _cap_for_lifts(path, ranges, ch)
    elif ch.lift_method is LiftMethod.LIFTING:
        path, plans = _couple_lifts(path, ranges, ch)
    changed = []
    for k, (a, b) in enumerate(zip(original, path.segments, strict=True)):
        if a != b:
            changed.append(k)
        if not k & EVERY:
            pause()
    differs = []
    for r in ranges:
        differs.append(_limits_reach(r, changed, nominal, ch))
        pause()
    first = result.blocks[0].line if result.blocks else 1
    warnings = tuple(e for e in result.errors if e.severity is Severity.WARNING)
    error = result.first_error
    del result
    release(cast(list[object], blocks))
    stops, flushes = [], []
    for r in ranges:
        stops.append(_stops_inside(path, r, False))
        flushes.append(_stops_inside(path, r, True))
        pause()
    table = build_table(path)
    conditional = _conditional(path)
    names = ch.axis_names  # a property that builds the tuple: once, not per range
    entry_dir = []
    for r in ranges:
        entry_dir.append(_direction_into(path, r.k_start, names.index(r.start.axis)))
        if not len(entry_dir) & EVERY:
            pause()
    return GeoProgram(
        path=path,
        ranges=ranges,
        error=error,
        warnings=warnings,
        first_line=first,
        stops=tuple(stops),
        flushes=tuple(flushes),
        z_index=ch.lift_axis_index,
        plans=plans,
        table=table,
        nominal=nominal,
        conditional=conditional,
        nominal_differs=tuple(differs),
        entry_dir=tuple(entry_dir),
        range_of={id(r.start): r.index for r in ranges},
        rises=_first_rises(ranges, plans, ch),
        lift_axes=tuple(dict.fromkeys(r.start.axis for r in ranges)),
    )


def same_start(a: Vec, b: Vec) -> bool:
    """Whether a program prepared for start `a` runs from `b` (PreparedPrograms.SAME_START_M)."""
    return within(a, b, PreparedPrograms.SAME_START_M)


class PreparedPrograms:
    """One NC program prepared for the start positions it runs from. Decoding and planning
    cost time in proportion to the program (≈ 40 µs per block here), so the program prepared
    for each of the last `capacity` start positions is kept and reused when the axes start
    within SAME_START_M of one: a repeated program then starts without decoding in the GEO
    cycle. Programs are immutable; a run's state lives in the interpolator and lift controller."""

    SAME_START_M = 1e-9

    def __init__(self, text: str, ch: ChannelParams, capacity: int = 2) -> None:
        self.text = text
        self.ch = ch
        self.capacity = capacity
        self._by_start: dict[Vec, GeoProgram] = {}
        self.loads = 0  # programs decoded and planned

    def prepared(self, start: Vec) -> GeoProgram | None:
        """The program prepared for a start within SAME_START_M of `start`, if there is one
        (nothing is decoded: a GEO cycle may ask)."""
        for key, prog in self._by_start.items():
            if same_start(key, start):
                return prog
        return None

    def from_start(self, start: Vec) -> GeoProgram:
        prog = self.prepared(start)
        if prog is not None:
            return prog
        prog = load_program(self.text, self.ch, start)
        self.loads += 1
        self.keep(start, prog)
        return prog

    def keep(self, start: Vec, prog: GeoProgram) -> None:
        """Keep `prog`, prepared for `start` (by `from_start`, or off the cycle)."""
        if len(self._by_start) >= self.capacity:
            del self._by_start[next(iter(self._by_start))]
        self._by_start[start] = prog
