"""Closed-form jerk-limited velocity changes along a path (1-D), used by look-ahead planning.

A velocity change from v0 to v1 that starts and ends with zero acceleration, time-optimal
under acceleration limit A and jerk limit J, takes
    t = 2·sqrt(Δ/J)        if Δ = |v1 − v0| ≤ A²/J   (triangular acceleration)
    t = Δ/A + A/J          otherwise                 (trapezoidal acceleration)
and, the acceleration profile being symmetric, covers the distance (v0 + v1)/2 · t.
J = inf gives the acceleration-limited case (STEP slope).
"""

from __future__ import annotations

import math

INF = float("inf")


def change_time(v0: float, v1: float, a_max: float, j_max: float) -> float:
    dv = abs(v1 - v0)
    if j_max == INF:
        return dv / a_max
    if dv * j_max <= a_max * a_max:
        return 2.0 * math.sqrt(dv / j_max)
    return dv / a_max + a_max / j_max


def change_distance(v0: float, v1: float, a_max: float, j_max: float) -> float:
    """Distance of the time-optimal velocity change v0 → v1 (zero acceleration at both ends)."""
    return 0.5 * (v0 + v1) * change_time(v0, v1, a_max, j_max)


def depressed_cubic_root(p: float, q: float) -> float:
    """The real root of y³ + p·y + q = 0 for p ≥ 0, without Cardano's cancellation:
    y = −2·sqrt(p/3)·sinh(asinh(3q/(2p)·sqrt(3/p)) / 3), polished by one Newton step."""
    if p <= 0.0 or p * math.sqrt(p) <= 1e-9 * abs(q):  # p negligible (or 0): y ≈ cbrt(−q)
        y = -math.copysign(abs(q) ** (1.0 / 3.0), q)
    else:
        r = math.sqrt(p / 3.0)
        y = -2.0 * r * math.sinh(math.asinh(1.5 * q / (p * r)) / 3.0)
    f = y * y * y + p * y + q
    df = 3.0 * y * y + p
    return y - f / df if df > 0.0 else y


def reach_velocity(v_end: float, length: float, a_max: float, j_max: float) -> float:
    """Largest v ≥ v_end from which v_end can be reached within `length` (or, by symmetry, the
    largest velocity reachable from v_end within `length`). Exact inverse of change_distance."""
    if length <= 0.0:
        return v_end
    b = v_end
    if j_max != INF:
        # Triangular case: (2b + y²)·y = L·sqrt(J) with y = sqrt(Δ): a depressed cubic
        # y³ + p·y + q = 0, p = 2b ≥ 0, one real root (Cardano).
        y = depressed_cubic_root(2.0 * b, -length * math.sqrt(j_max))
        dv = y * y
        if dv * j_max <= a_max * a_max:
            return b + dv
        c = a_max * a_max / j_max
    else:
        c = 0.0
    # Trapezoidal case: Δ² + Δ·(2b + A²/J) + (2b·A²/J − 2·L·A) = 0
    lin = 2.0 * b + c
    const = 2.0 * b * c - 2.0 * length * a_max
    if const >= 0.0:
        return b
    return b - 2.0 * const / (lin + math.sqrt(lin * lin - 4.0 * const))  # stable root form


def reach_velocity_any_above(v_end: float, length: float, a_max: float, j_max: float) -> float:
    """Largest v ≥ … from which every velocity ≥ v_end can be reached within `length` (zero
    acceleration at both ends): the least reach_velocity(e, length) over e ≥ v_end. With a jerk
    limit reach_velocity is not monotonic in its end velocity: it falls from e = 0 to a low e
    and rises after it (from v, braking to v/3 takes longer than braking to rest; past the
    acceleration limit the turn is at A²/2J), so the velocity from which rest is reachable may
    not reach a cap a little above rest. Unimodal, with the turn at e* = (L·√J / 4√2)^(2/3)
    (triangular: Δ = 2e*) or A²/2J (trapezoidal); checked against a scan of e for random
    limits and lengths."""
    if j_max == INF or length <= 0.0:
        return reach_velocity(v_end, length, a_max, j_max)
    turn = (length * math.sqrt(j_max) / (4.0 * math.sqrt(2.0))) ** (2.0 / 3.0)
    if 2.0 * turn * j_max > a_max * a_max:
        turn = 0.5 * a_max * a_max / j_max
    return reach_velocity(max(v_end, turn), length, a_max, j_max)


def lowest_reachable(v_start: float, length: float, a_max: float, j_max: float) -> float:
    """Smallest velocity reachable from v_start (zero acceleration) within `length`. Stopping
    counts as reachable when it needs at most length·(1 + 1e-6) (rounding of the closed forms);
    near 0 the distance is not monotonic in the end velocity, so 0 is tested first."""
    if change_distance(v_start, 0.0, a_max, j_max) <= length * (1.0 + 1e-6):
        return 0.0
    lo, hi = 0.0, v_start  # change_distance(v_start, hi) = 0 ≤ length
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if change_distance(v_start, mid, a_max, j_max) <= length:
            hi = mid
        else:
            lo = mid
    return hi


# -- states with acceleration (the tracker's slack checks) --------------------------------------
def projected_velocity(v: float, a: float, j_max: float) -> float:
    """Velocity after the acceleration is ramped to 0 at full jerk (v + a·|a|/2J)."""
    if j_max == INF:
        return v
    return v + a * abs(a) / (2.0 * j_max)


def ramp_distance(v: float, a: float, j_max: float) -> float:
    """Distance covered while the acceleration is ramped from a to 0 at full jerk."""
    if j_max == INF or a == 0.0:
        return 0.0
    t = abs(a) / j_max
    j = -j_max if a > 0.0 else j_max
    return v * t + 0.5 * a * t * t + j * t * t * t / 6.0


def ramp_crossing(v: float, a: float, v1: float, j_max: float) -> float:
    """Distance until the velocity, braking from (v, a) while the acceleration is ramped to 0
    at full jerk, first falls to v1 (v > v1 ≥ projected_velocity(v, a)); the whole ramp if it
    does not."""
    if j_max == INF or a >= 0.0:
        return 0.0
    disc = a * a - 2.0 * j_max * (v - v1)
    if disc < 0.0:
        return ramp_distance(v, a, j_max)
    t = (-a - math.sqrt(disc)) / j_max
    return v * t + 0.5 * a * t * t + j_max * t * t * t / 6.0


def _brake_peak(a: float, drop: float, a_max: float, j_max: float) -> tuple[float, float]:
    """The deepest deceleration a_p of the time-optimal brake from acceleration a by a velocity
    drop of `drop` (jerk −J, hold −A, jerk +J), and how long it holds −A (0 where it does
    not reach it). Not for a brake that is a mere ramp of a to 0 (`_ramps_only`)."""
    a_p = -math.sqrt(max(0.5 * a * a + j_max * drop, 0.0))
    if a_p >= -a_max:
        return a_p, 0.0
    return -a_max, max((drop + (a * a - 2.0 * a_max * a_max) / (2.0 * j_max)) / a_max, 0.0)


def _ramps_only(a: float, drop: float, j_max: float) -> bool:
    """|a_p| would be below |a|: ramping the deceleration to 0 alone undershoots the end."""
    return a < 0.0 and 0.5 * a * a + j_max * drop < a * a


def brake_distance(v: float, a: float, v1: float, a_max: float, j_max: float) -> float:
    """Least distance in which the velocity comes down from (v, a) to v1 with zero acceleration
    there (time-optimal jerk-limited brake: jerk −J, hold −A, jerk +J). Only meaningful when
    projected_velocity(v, a) > v1; if the current deceleration already overshoots v1 (undershoot
    by ramping it to 0), the ramp distance."""
    if j_max == INF:
        return max(0.0, (v * v - v1 * v1) / (2.0 * a_max)) if v > v1 else 0.0
    drop = v - v1  # > a·|a|/2J by the precondition when braking is needed
    if _ramps_only(a, drop, j_max):
        return ramp_distance(v, a, j_max)
    a_p, t2 = _brake_peak(a, drop, a_max, j_max)
    t1 = (a - a_p) / j_max
    t3 = -a_p / j_max
    d1 = v * t1 + 0.5 * a * t1 * t1 - j_max * t1 * t1 * t1 / 6.0
    v_1 = v + (a * a - a_p * a_p) / (2.0 * j_max)
    d2 = v_1 * t2 + 0.5 * a_p * t2 * t2
    v_2 = v_1 + a_p * t2
    d3 = v_2 * t3 + 0.5 * a_p * t3 * t3 + j_max * t3 * t3 * t3 / 6.0
    return d1 + d2 + d3


def brake_crossing(v: float, a: float, v1: float, cap: float, a_max: float, j_max: float) -> float:
    """Distance along the brake of `brake_distance` (from (v, a) down to v1, zero acceleration
    there) until its velocity is at or below `cap` for good (v1 ≤ cap): 0 where it never is
    above it, the whole brake where it gets there only at its end. Only meaningful where
    projected_velocity(v, a) > v1 and the brake is not a mere ramp that overshoots v1 (then
    `ramp_crossing`). The closed form of what the tracker read off ruckig's profile of that
    brake (`Brakes._first_keeps`: a solve per bisection step, 31 in a cycle)."""
    if v <= cap and (a <= 0.0 or v + a * a / (2.0 * j_max) <= cap):
        return 0.0  # never above it
    if j_max == INF:
        return max(0.0, (v * v - cap * cap) / (2.0 * a_max))
    drop = v - v1
    if _ramps_only(a, drop, j_max):
        return ramp_crossing(v, a, cap, j_max)
    a_p, t2 = _brake_peak(a, drop, a_max, j_max)
    t1 = (a - a_p) / j_max
    t3 = -a_p / j_max
    v_1 = v + (a * a - a_p * a_p) / (2.0 * j_max)
    if v_1 <= cap:
        # in the first piece (jerk −J): v + a t − J t²/2 = cap, the later root (falling)
        t = (a + math.sqrt(max(a * a + 2.0 * j_max * (v - cap), 0.0))) / j_max
        t = min(max(t, 0.0), t1)
        return v * t + 0.5 * a * t * t - j_max * t * t * t / 6.0
    d1 = v * t1 + 0.5 * a * t1 * t1 - j_max * t1 * t1 * t1 / 6.0
    v_2 = v_1 + a_p * t2
    if v_2 <= cap:
        t = (cap - v_1) / a_p  # the hold at −A
        return d1 + v_1 * t + 0.5 * a_p * t * t
    d2 = v_1 * t2 + 0.5 * a_p * t2 * t2
    # the last piece (jerk +J): v_2 + a_p t + J t²/2 = cap, the earlier root
    disc = a_p * a_p - 2.0 * j_max * (v_2 - cap)
    t = t3 if disc < 0.0 else min(max((-a_p - math.sqrt(disc)) / j_max, 0.0), t3)
    return d1 + d2 + v_2 * t + 0.5 * a_p * t * t + j_max * t * t * t / 6.0


def brake_reach(v: float, a: float, a_max: float, j_max: float) -> float:
    """The farthest the path can need to get from (v, a) to any one velocity below it with zero
    acceleration (an upper bound of brake_distance over the end velocity). Braking to rest is
    not the farthest: with a jerk limit the distance rises from v1 = 0 to v1 = min(v/3,
    A²/2J) (from zero acceleration; ramping a positive acceleration to 0 first adds its
    ramp), so a cap there is farther away than rest (issue 36: a feed drop F12000 → F6000
    entered the tracker's horizon only once the path could no longer get down to it, and it
    stopped instead). Checked against a fine scan of end velocities for random states."""
    if j_max == INF:
        return brake_distance(v, a, 0.0, a_max, j_max)
    base, ramp = v, 0.0
    if a > 0.0:
        base, ramp = projected_velocity(v, a, j_max), ramp_distance(v, a, j_max)
    hump = min(base / 3.0, a_max * a_max / (2.0 * j_max))
    d = ramp + max(brake_distance(base, 0.0, 0.0, a_max, j_max),
                   brake_distance(base, 0.0, hump, a_max, j_max))  # fmt: skip
    if a < 0.0:
        d = max(d, ramp_distance(v, a, j_max))
    return d


def _speed_up(v: float, a: float, a1: float, hold: float, j_max: float) -> tuple[float, float]:
    """(distance, end velocity) of raising the acceleration from a to a1 (jerk +J), holding it
    for `hold` and ramping it to 0 (jerk −J)."""
    t1 = (a1 - a) / j_max
    d = v * t1 + 0.5 * a * t1 * t1 + j_max * t1 * t1 * t1 / 6.0
    v1 = v + a * t1 + 0.5 * j_max * t1 * t1
    d += v1 * hold + 0.5 * a1 * hold * hold
    v2 = v1 + a1 * hold
    t3 = a1 / j_max
    d += v2 * t3 + 0.5 * a1 * t3 * t3 - j_max * t3 * t3 * t3 / 6.0
    return d, v2 + 0.5 * a1 * a1 / j_max


def reach_from(v: float, a: float, length: float, a_max: float, j_max: float) -> float:
    """The highest velocity the path can have, with zero acceleration, `length` ahead of (v, a)
    (accelerating all the way; the caller bounds it by the ceiling). From a > 0 the fastest
    way keeps raising the acceleration (jerk +J, up to A and held there) before ramping it to 0
    (jerk −J), which ends faster than ramping it to 0 first (issue 36: 1 mm after a corner,
    62 mm/s where 68 were reachable); from a ≤ 0 it ramps to 0 first. Only meaningful when
    ramping the acceleration to 0 fits within `length`."""
    if a <= 0.0 or j_max == INF:
        rest = max(length - ramp_distance(v, a, j_max), 0.0)
        return reach_velocity(projected_velocity(v, a, j_max), rest, a_max, j_max)
    top = max(a_max, a)
    d0, v_top = _speed_up(v, a, top, 0.0, j_max)
    if d0 <= length:  # up to the acceleration limit, held there: a quadratic in the hold
        v1 = v_top - 0.5 * top * top / j_max
        # d(hold) = d0 + (v1 + top·t3)·hold + top·hold²/2 (the ramp down starts faster)
        lin = v1 + top * top / j_max
        rest = length - d0
        hold = 2.0 * rest / (lin + math.sqrt(lin * lin + 2.0 * top * rest))
        return _speed_up(v, a, top, hold, j_max)[1]
    lo, hi = a, top  # the peak acceleration: lo fits (the ramp alone), hi does not
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        if _speed_up(v, a, mid, 0.0, j_max)[0] <= length:
            lo = mid
        else:
            hi = mid
    return _speed_up(v, a, lo, 0.0, j_max)[1]


def _hump(v: float, a: float, a_max: float, j_max: float) -> float:
    """The end velocity in [0, v_p] the brake from (v, a) needs the longest distance for
    (brake_distance rises from 0 to it and falls after it; golden-section search, bounded)."""
    lo, hi = 0.0, projected_velocity(v, a, j_max)
    g = 0.6180339887498949
    x1, x2 = hi - g * (hi - lo), lo + g * (hi - lo)
    f1, f2 = brake_distance(v, a, x1, a_max, j_max), brake_distance(v, a, x2, a_max, j_max)
    for _ in range(30):
        if f1 < f2:
            lo, x1, f1 = x1, x2, f2
            x2 = lo + g * (hi - lo)
            f2 = brake_distance(v, a, x2, a_max, j_max)
        else:
            hi, x2, f2 = x2, x1, f1
            x1 = hi - g * (hi - lo)
            f1 = brake_distance(v, a, x1, a_max, j_max)
    return 0.5 * (lo + hi)


def nearest_reachable(
    v: float, a: float, length: float, top: float, a_max: float, j_max: float, above: bool
) -> float:
    """Where `top` itself cannot be reached with zero acceleration within `length` from (v, a):
    the lowest velocity ≥ top that can (`above`: a feed cap the path cannot get down to, passed
    as slowly as it can), or the highest one ≤ top (a hard cap: below it, at worst at rest).
    With a jerk limit brake_distance rises from v1 = 0 to a hump and falls after it, so the
    reachable end velocities are [0, x1] ∪ [x2, v_p]: these are x2 and x1 (bisections)."""
    v_p = projected_velocity(v, a, j_max)
    h = _hump(v, a, a_max, j_max) if j_max != INF else 0.0
    if above or brake_distance(v, a, 0.0, a_max, j_max) > length:
        return _edge(v, a, length, max(top, h), v_p, a_max, j_max)  # the falling side
    return _edge(v, a, length, min(top, h), 0.0, a_max, j_max)  # the rising side


def _edge(
    v: float, a: float, length: float, far: float, near: float, a_max: float, j_max: float
) -> float:
    """The end velocity between `far` (its brake needs more than `length`) and `near` (within
    it) where the brake from (v, a) needs exactly `length`: brake_distance is monotonic
    between them (50 bisection steps); the last one within."""
    for _ in range(50):
        mid = 0.5 * (far + near)
        if brake_distance(v, a, mid, a_max, j_max) <= length:
            near = mid
        else:
            far = mid
    return near


def lowest_reachable_from(v: float, a: float, length: float, a_max: float, j_max: float) -> float:
    """Smallest velocity (≥ 0) that can be reached from (v, a) with zero acceleration within
    `length` (bisection on brake_distance; the projected velocity if no braking fits)."""
    v_p = projected_velocity(v, a, j_max)
    if v_p <= 0.0 or brake_distance(v, a, 0.0, a_max, j_max) <= length:
        return 0.0
    return _edge(v, a, length, 0.0, v_p, a_max, j_max)  # brake to v_p: the ramp only
