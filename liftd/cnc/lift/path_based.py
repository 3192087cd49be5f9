"""Path-based Lifting (the conventional method): z = f(s), planned in path preparation.

Vendor text §2.2 (DE authoritative, DESIGN.md §4): the lift motion is planned as an independent
motion in path preparation and coupled to the path, so the same path position always gives the
same Z; at constant path velocity Z rises and lowers jerk-limited at its planning acceleration
a_max × P-AXIS-00442/1000; feed hold stops Z, override scales it (acceleration × override²).

liftd's model (choices where the text is silent):

* Planning acceleration a_plan = a_max · P-AXIS-00442/1000 (the vendor's formula; 1000, the
  default, plans with a_max; 0 = monitoring off also plans with a_max), jerk j_max of the axis.
* The plan Zp(τ) of a part is the max-clearance profile at a constant "path time"
  T_plan = L / F_ref, F_ref the fastest programmed feed of the part (G00: the axis limit), so
  that at programmed feed Z never runs faster than planned: greedy rise toward POS_LIMIT,
  switch, time-optimal descent to POS. If Z needs longer than T_plan, T_plan is stretched and
  the feed of the part reduced to L / T_plan in path preparation (the override scales it).
* z(s) = Zp((s − s_a) · T_plan / L): one linear map per part keeps z(s) smooth where the
  programmed feed changes between blocks; Z is at rest at both ends of every part.
* z̈ = Zp''·r² + (dz/ds)·s̈ with r = ṡ·T_plan/L. Inside the range the path acceleration and
  jerk are limited to a_max/max|dz/ds| and j_max/max|dz/ds| of Z, so at programmed feed
  (r ≤ 1) the total stays within a_plan + a_max = a_max·(1 + P-AXIS-00442/1000), the error
  level of the IPO acceleration monitor ("the total stays within the overload range", vendor
  §2.2.1). An override above 100 % scales the first term with r² and is *not* limited: the
  monitor reports it (the method's known weakness). Z's velocity (dz/ds)·ṡ is kept within
  v_max at any override by a path velocity cap v_max/max|dz/ds| in the range (Z is coupled like
  a path axis; the vendor text is silent on velocity).
* More than LOOK_AHEAD internal blocks between START and END (vendor §2.2.3 special case 1):
  the range is cut every LOOK_AHEAD blocks into parts; every part but the last ends at
  POS_LIMIT ("LIFT_END to the programmed height, then LIFT_START"), so Z lifts early over the
  first part, holds, and lowers over the last part only, which may be short (path slowed).
  #FLUSH cuts the same way (special case 2: Z is at POS_LIMIT at the flush point).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ruckig import Trajectory

from liftd.cnc.lift.profile import LiftProfiles, state_at
from liftd.cnc.lift.ranges import LiftRange
from liftd.cnc.path.program import ActionKind, PathProgram, PathSegment

LOOK_AHEAD = 20  # CNC-internal blocks between lift start and end (vendor §2.2.1)
INF = float("inf")


@dataclass(frozen=True, slots=True)
class CoupledProfile:
    """Z as a function of the path position over [s0, s1]: Zp(τ) with τ = (s − s0)/(s1 − s0) ·
    t_plan; Zp follows `rise` until t_switch (holding its end, POS_LIMIT, if reached), then
    `fall` to the target."""

    s0: float
    s1: float
    z0: float
    z1: float
    t_plan: float  # plan time of the part (s)
    rise: Trajectory | None
    t_switch: float
    fall: Trajectory | None

    def state(self, s: float) -> tuple[float, float, float]:
        """(z, dz/ds, d²z/ds²) at path position s."""
        if s <= self.s0:
            return self.z0, 0.0, 0.0
        if s >= self.s1 or self.t_plan <= 0.0:
            return self.z1, 0.0, 0.0
        rate = self.t_plan / (self.s1 - self.s0)  # dτ/ds
        tau = (s - self.s0) * rate
        if tau < self.t_switch and self.rise is not None:
            p, v, a = state_at(self.rise, tau)
        elif self.fall is not None:
            p, v, a = state_at(self.fall, tau - self.t_switch)
        else:
            return self.z1, 0.0, 0.0
        return p, v * rate, a * rate * rate

    def bounds(self, s_a: float, s_b: float) -> tuple[float, float, float]:
        """max |dz/ds|, |d²z/ds²|, |d³z/ds³| over the path positions [s_a, s_b], exactly."""
        if self.t_plan <= 0.0 or s_b <= self.s0 or s_a >= self.s1:
            return 0.0, 0.0, 0.0
        rate = self.t_plan / (self.s1 - self.s0)  # dτ/ds
        ta = max(s_a - self.s0, 0.0) * rate
        tb = (min(s_b, self.s1) - self.s0) * rate
        v = a = j = 0.0
        if self.rise is not None and ta < self.t_switch:
            v, a, j = _extremes(self.rise, ta, min(tb, self.t_switch))
        if self.fall is not None and tb > self.t_switch:
            v2, a2, j2 = _extremes(self.fall, max(ta - self.t_switch, 0.0), tb - self.t_switch)
            v, a, j = max(v, v2), max(a, a2), max(j, j2)
        return v * rate, a * rate * rate, j * rate * rate * rate


def _phases(traj: Trajectory) -> list[tuple[float, float, float, float]]:
    """(duration, jerk, acceleration and velocity at its start) of each phase of a 1-D
    profile, a braking pre-phase (a start state beyond the limits) first."""
    prof = traj.profiles[0][0]
    out: list[tuple[float, float, float, float]] = []
    brake = prof.brake
    if brake.duration > 0.0:
        for k in range(2):
            if brake.t[k] > 0.0:
                out.append((brake.t[k], brake.j[k], brake.a[k], brake.v[k]))
    for d, j, a, v in zip(prof.t, prof.j, prof.a, prof.v, strict=False):
        out.append((d, j, a, v))
    return out


def _extremes(traj: Trajectory, t0: float, t1: float) -> tuple[float, float, float]:
    """max |v|, |a|, |j| of a 1-D piecewise-constant-jerk profile over its times [t0, t1]
    (at rest after its end), exactly: per phase a is linear and v quadratic in time, so their
    extremes lie at the ends of the piece or (v) where a crosses zero."""
    vm = am = jm = 0.0
    start = 0.0
    for d, j, a, v in _phases(traj):
        lo, hi = max(t0, start), min(t1, start + d)
        if hi >= lo and d > 0.0:
            for u in (lo - start, hi - start):
                vm = max(vm, abs(v + a * u + 0.5 * j * u * u))
                am = max(am, abs(a + j * u))
            if j != 0.0 and lo - start < -a / j < hi - start:
                u = -a / j
                vm = max(vm, abs(v + a * u + 0.5 * j * u * u))
            if hi > lo:
                jm = max(jm, abs(j))
        start += d
        if start >= t1:
            break
    return vm, am, jm


def plan_part(
    prof: LiftProfiles, s0: float, s1: float, z0: float, target: float, limit: float,
    t_feed: float, direct: bool = False,
) -> CoupledProfile:  # fmt: skip
    """One coupled part: from z0 at s0 to target at s1 (at rest at both), as high as `limit`
    allows within the plan time max(t_feed, Z's time-optimal move); `direct`: straight to the
    target at the start of the part, then hold (suppressed lift, POS beyond POS_LIMIT).
    Raises ProfileError if ruckig refuses a profile."""
    top = max(limit, z0, target)
    if abs(target - z0) <= 1e-12 and (direct or top - z0 <= 1e-12):
        return CoupledProfile(s0, s1, z0, target, 0.0, None, 0.0, None)
    length = s1 - s0
    straight = prof.to_rest(z0, 0.0, 0.0, target) if abs(target - z0) > 1e-12 else None
    t_min = straight.duration if straight is not None else 0.0
    t_plan = max(t_feed, t_min)
    if length <= 0.0:
        return CoupledProfile(s0, s1, z0, target, 0.0, None, 0.0, None)
    if direct:
        return CoupledProfile(s0, s1, z0, target, t_plan, None, 0.0, straight)
    rise = prof.to_rest(z0, 0.0, 0.0, top)
    # rest-to-rest profiles are symmetric: back down the same height takes as long as the rise
    down = None if straight is None else prof.to_rest(top, 0.0, 0.0, target)
    t_down = rise.duration if down is None else down.duration
    fall: Trajectory | None
    if rise.duration + t_down <= t_plan:  # reaches POS_LIMIT and holds
        fall = down if down is not None else prof.to_rest(top, 0.0, 0.0, target)
        t_switch = t_plan - t_down
    else:  # switch during the rise: τ + t_min(rise(τ) → target) = t_plan, regula falsi
        lo, f_lo, fall = 0.0, t_min - t_plan, straight
        hi = rise.duration
        f_hi = hi + t_down - t_plan
        side = 0
        for _ in range(60):
            if f_lo > -1e-10 or hi - lo < 1e-10:  # 0.1 ns of plan time
                break
            mid = (lo * f_hi - hi * f_lo) / (f_hi - f_lo)
            if not lo < mid < hi:
                mid = 0.5 * (lo + hi)
            p, v, a = state_at(rise, mid)
            trial = prof.to_rest(p, v, a, target)
            f_mid = mid + trial.duration - t_plan
            if f_mid <= 0.0:
                lo, f_lo, fall = mid, f_mid, trial
                f_hi = f_hi * 0.5 if side == -1 else f_hi
                side = -1
            else:
                hi, f_hi = mid, f_mid
                f_lo = f_lo * 0.5 if side == 1 else f_lo
                side = 1
        t_switch = lo
    return CoupledProfile(s0, s1, z0, target, t_plan, rise if t_switch > 0.0 else None,
                          t_switch, fall)  # fmt: skip


@dataclass(frozen=True, slots=True)
class RangePlan:
    """The coupled parts of one lift range, in path order (1 part, or rise/hold/lower)."""

    parts: tuple[CoupledProfile, ...]
    premature: bool  # more than LOOK_AHEAD blocks: lifted early, lowered late

    def state(self, s: float) -> tuple[float, float, float]:
        """(z, dz/ds, d²z/ds²) at path position s."""
        for part in self.parts:
            if s <= part.s1:
                return part.state(s)
        return self.parts[-1].z1, 0.0, 0.0

    @property
    def s_end(self) -> float:
        return self.parts[-1].s1


@dataclass(frozen=True, slots=True)
class ZLimits:
    """The lift axis's limits the coupled Z keeps at 100 % override (with the planning
    margin): velocity at any override, acceleration and jerk."""

    v_max: float
    a_max: float
    j_max: float


@dataclass(frozen=True, slots=True)
class SegmentCap:
    """What a lift range asks of one path segment inside it (inf: nothing)."""

    k: int
    v_ov: float  # path velocity at 100 % override (the override scales it)
    a: float  # path acceleration
    j: float  # path jerk
    v: float  # path velocity at any override: Z within v_max


RHO_STEPS = 24  # golden-section steps of `segment_cap`: the velocity within 1e-5 of its range
RHO_GAP = 1e-6  # keeps the searched velocities strictly inside the feasible range
GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0


def segment_cap(part: CoupledProfile, k: int, seg: PathSegment, v_cap: float,
                z: ZLimits) -> SegmentCap:  # fmt: skip
    """The path limits on segment k that keep the coupled Z within its acceleration and jerk
    at 100 % override, whatever the path does there (vendor §2.2.1: "Innerhalb des
    LIFT-Bereichs wird die zulässige Beschleunigung auf der Bahn so bestimmt, dass die
    maximal zulässige Beschleunigung der Liftachse nicht überschritten wird"; issue 37 item 3).

    With C1, C2, C3 the largest |dz/ds|, |d²z/ds²|, |d³z/ds³| over the segment and a path
    velocity V, acceleration A and jerk J: |z̈| = |z''·ṡ² + z'·s̈| ≤ C2·V² + C1·A ≤ a_max, and
    |z⃛| = |z'''·ṡ³ + 3·z''·ṡ·s̈ + z'·s⃛| ≤ C3·V³ + 3·C2·V·A + C1·J ≤ j_max (the middle term
    gets at most half of what C3·V³ leaves, as the path budgets it on arcs). Z's plan uses
    its full acceleration and jerk at the programmed feed (§2.2.1, "Dynamikplanung"), which
    leaves the path nothing to accelerate with where Z moves: there the feed is reduced to
    the velocity that minimises the segment's time L/V + V/A + A/J (cruise, one ramp pair;
    a golden-section search). Only an override above 100 % takes Z beyond its limits (the
    overload band of P-AXIS-00442, vendor §2.2.1 and §2.5); braking for a feed hold or a lower
    override stays within them."""
    c1, c2, c3 = part.bounds(seg.s0, seg.s0 + seg.length)
    if c1 <= 0.0:
        return SegmentCap(k, v_cap, INF, INF, INF)  # Z at rest on this segment
    feed = min(seg.feed, v_cap)
    jerk = seg.j_max != INF
    # the velocities that leave the path some acceleration (and jerk): below both roots
    top = feed
    if c2 > 0.0:
        top = min(top, math.sqrt(z.a_max / c2) * (1.0 - RHO_GAP))
    if jerk and c3 > 0.0:
        top = min(top, (z.j_max / c3) ** (1.0 / 3.0) * (1.0 - RHO_GAP))
    # golden-section search of the segment's time estimate over (0, top]: its cruise falls
    # and its ramps grow with V, one minimum
    lo, hi = top * RHO_GAP, top
    x1, x2 = hi - GOLDEN * (hi - lo), lo + GOLDEN * (hi - lo)
    t1, t2 = _segment_time(x1, seg, c1, c2, c3, z), _segment_time(x2, seg, c1, c2, c3, z)
    for _ in range(RHO_STEPS):
        if t1 <= t2:
            hi, x2, t2 = x2, x1, t1
            x1 = hi - GOLDEN * (hi - lo)
            t1 = _segment_time(x1, seg, c1, c2, c3, z)
        else:
            lo, x1, t1 = x1, x2, t2
            x2 = lo + GOLDEN * (hi - lo)
            t2 = _segment_time(x2, seg, c1, c2, c3, z)
    v = x1 if t1 <= t2 else x2
    if _segment_time(top, seg, c1, c2, c3, z) <= min(t1, t2):
        v = top
    a, j = _path_budget(v, jerk, c1, c2, c3, z)
    v_ov = v_cap if v >= feed else v
    return SegmentCap(k, v_ov, a, j, z.v_max / c1)


def _path_budget(v: float, jerk: bool, c1: float, c2: float, c3: float,
                 z: ZLimits) -> tuple[float, float]:  # fmt: skip
    """The path acceleration and jerk Z leaves at path velocity v (`segment_cap`)."""
    a = (z.a_max - c2 * v * v) / c1
    if not jerk:
        return a, INF
    rest = z.j_max - c3 * v * v * v
    if c2 > 0.0:
        a = min(a, 0.5 * rest / (3.0 * c2 * v))
    return a, (rest - 3.0 * c2 * v * a) / c1


def _segment_time(v: float, seg: PathSegment, c1: float, c2: float, c3: float,
                  z: ZLimits) -> float:  # fmt: skip
    """The estimate `segment_cap` minimises: cruise over the segment at v, one ramp pair."""
    a, j = _path_budget(v, seg.j_max != INF, c1, c2, c3, z)
    if a <= 0.0 or j <= 0.0:
        return INF
    a, j = min(a, seg.a_max), min(j, seg.j_max)
    return seg.length / v + v / a + (a / j if j != INF else 0.0)


def lift_chunks(path: PathProgram, rng: LiftRange) -> tuple[list[tuple[int, int]], bool]:
    """Split a range into parts of at most LOOK_AHEAD CNC-internal blocks (a motion block is one,
    every M function output one more) and at #FLUSH. Returns the (k_a, k_b) boundary pairs and
    whether the look-ahead overflowed (premature lifting)."""
    k_last = rng.k_end if rng.k_end >= 0 else len(path.segments)
    out: list[tuple[int, int]] = []
    k_a, count, overflow = rng.k_start, 0, False
    for k in range(rng.k_start, k_last):
        pending = 1
        if k > rng.k_start:
            actions = path.boundaries[k].actions
            if k > k_a and any(a.kind is ActionKind.FLUSH for a in actions):
                out.append((k_a, k))  # implicit LIFT_END + LIFT_START (vendor §2.2.3 case 2)
                k_a, count = k, 0
            pending += sum(a.kind is ActionKind.M_OUTPUT for a in actions)
        if k > k_a and count + pending > LOOK_AHEAD:
            out.append((k_a, k))  # inserted LIFT_END + LIFT_START (vendor §2.2.3 case 1)
            k_a, count, overflow = k, 0, True
        count += pending
    out.append((k_a, k_last))
    return out, overflow


def plan_range(
    path: PathProgram, rng: LiftRange, prof: LiftProfiles, z_lim: ZLimits
) -> tuple[RangePlan, tuple[SegmentCap, ...]]:
    """Plan z(s) of one range with path motion, and the limits of its segments that keep Z
    within `z_lim` (`segment_cap`). Every part but the last ends at the maximum
    height (vendor: "LIFT_END for the programmed height, then LIFT_START"); a range left open
    by a program error rises to POS_LIMIT over the path that remains. The plan assumes each part
    runs at its fastest programmed feed, so at programmed feed Z never moves faster than
    planned. Raises ProfileError if ruckig refuses a profile."""
    spec = rng.start
    chunks, overflow = lift_chunks(path, rng)
    top = max(spec.pos_limit, spec.z_start, spec.target)
    parts: list[CoupledProfile] = []
    caps: list[SegmentCap] = []
    z = spec.z_start
    for i, (k_a, k_b) in enumerate(chunks):
        last = i == len(chunks) - 1 and rng.k_end >= 0
        target = spec.target if last or rng.direct else top
        s0, s1 = path.boundaries[k_a].s, path.boundaries[k_b].s
        f_ref = max(seg.feed for seg in path.segments[k_a:k_b])
        t_feed = (s1 - s0) / f_ref
        part = plan_part(prof, s0, s1, z, target, spec.pos_limit, t_feed, rng.direct)
        parts.append(part)
        stretched = part.t_plan > t_feed * (1.0 + 1e-9)
        v_cap = (s1 - s0) / part.t_plan if stretched else INF
        caps.extend(segment_cap(part, k, path.segments[k], v_cap, z_lim) for k in range(k_a, k_b))
        z = target
    return RangePlan(tuple(parts), overflow), tuple(caps)
