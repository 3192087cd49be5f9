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

from dataclasses import dataclass

from ruckig import Trajectory

from liftd.cnc.lift.profile import LiftProfiles, state_at
from liftd.cnc.lift.ranges import LiftRange
from liftd.cnc.path.program import ActionKind, PathProgram

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
    dz_ds_max: float  # max |dz/ds| (for the path limits in the range)

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


def _peak_speed(traj: Trajectory | None, span: float) -> float:
    """Largest |v| of a 1-D piecewise-constant-jerk profile over [0, span], exactly: at a phase
    boundary or where the acceleration crosses zero inside a phase."""
    if traj is None or span <= 0.0:
        return 0.0
    prof = traj.profiles[0][0]
    if prof.brake.duration > 0.0:  # a braking pre-phase (start state beyond the limits): sample
        return max(abs(state_at(traj, span * k / 64)[1]) for k in range(65))
    peak, t0 = float(abs(prof.v[0])), 0.0
    for phase, j, a, v in zip(prof.t, prof.j, prof.a, prof.v, strict=False):
        if t0 >= span:
            break
        d = min(phase, span - t0)
        if d <= 0.0:  # an empty phase (e.g. no constant-acceleration phase)
            continue
        peak = max(peak, abs(v + a * d + 0.5 * j * d * d))
        if j != 0.0 and 0.0 < -a / j < d:
            t_x = -a / j
            peak = max(peak, abs(v + a * t_x + 0.5 * j * t_x * t_x))
        t0 += d
    return peak


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
        return CoupledProfile(s0, s1, z0, target, 0.0, None, 0.0, None, 0.0)
    length = s1 - s0
    straight = prof.to_rest(z0, 0.0, 0.0, target) if abs(target - z0) > 1e-12 else None
    t_min = straight.duration if straight is not None else 0.0
    t_plan = max(t_feed, t_min)
    if length <= 0.0:
        return CoupledProfile(s0, s1, z0, target, 0.0, None, 0.0, None, INF)
    if direct:
        speed = _peak_speed(straight, t_min)
        return CoupledProfile(s0, s1, z0, target, t_plan, None, 0.0, straight,
                              speed * t_plan / length)  # fmt: skip
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
    speed = max(_peak_speed(rise, min(t_switch, rise.duration)),
                _peak_speed(fall, fall.duration if fall is not None else 0.0))  # fmt: skip
    return CoupledProfile(s0, s1, z0, target, t_plan, rise if t_switch > 0.0 else None,
                          t_switch, fall, speed * t_plan / length)  # fmt: skip


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

    @property
    def dz_ds_max(self) -> float:
        return max((p.dz_ds_max for p in self.parts), default=0.0)


@dataclass(frozen=True, slots=True)
class SegmentCap:
    """What a lift range asks of one path segment inside it."""

    k: int
    v_cap: float  # path velocity at 100 % override so that Z keeps its plan (inf: no cap)
    dz_ds: float  # max |dz/ds| of the part: path acceleration and jerk scale into Z with it


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
    path: PathProgram, rng: LiftRange, prof: LiftProfiles
) -> tuple[RangePlan, tuple[SegmentCap, ...]]:
    """Plan z(s) of one range with path motion. Every part but the last ends at the maximum
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
        caps.extend(SegmentCap(k, v_cap, part.dz_ds_max) for k in range(k_a, k_b))
        z = target
    return RangePlan(tuple(parts), overflow), tuple(caps)
