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
