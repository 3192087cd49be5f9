"""Path limits from axis limits: per segment (projected) and at block transitions (corner rule).

liftd guarantees that the *sampled* command positions of every axis stay within the axis
limits when differentiated by finite differences over the GEO cycle (|v|, |a|, |j|). Two budgets
make that provable:

* Inside a segment the path uses at most (1 − TRANSITION_SHARE) of each axis' acceleration and
  jerk, projected onto the segment. On an arc the centripetal part κv² takes ARC_CENTRIPETAL_SHARE
  of the acceleration and the jerk terms κ²v³ + 3κv|s̈| take half of the jerk budget
  (p⃛ = (s⃛ − κ²v³)·t + 3κv·s̈·n on a circle).
* At a block transition the per-axis velocity step V = v·|Δt_i| and acceleration step
  D = v²·|Δ(κn)_i| (the path acceleration is zero at transitions) enter the third finite
  difference with at most V/dt² + 0.75·D/dt and the second with at most V/dt (a quadratic
  B-spline kernel bounds them). The corner rule picks the highest v for which these stay within
  TRANSITION_SHARE of the axis limits. A sharp corner therefore becomes an (almost) exact stop,
  a tangential line→arc transition is slowed to about sqrt(ε·j·dt·R/0.75).

No path smoothing is emulated; the rule is conservative by construction, which is what the
trace checks (finite differences over every cycle) rely on.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from liftd.cnc.params import PLANNING_MARGIN, AxisParams, SlopeType
from liftd.cnc.path.geometry import ArcSeg, LineSeg, Segment, Vec
from liftd.cnc.path.velocity import depressed_cubic_root

TRANSITION_SHARE = 0.2  # ε: share of axis acceleration and jerk reserved for transitions
ARC_CENTRIPETAL_SHARE = 0.5
SAFETY = 0.999  # absorbs floating-point rounding at the budget edges
INF = float("inf")


@dataclass(frozen=True, slots=True)
class SegmentLimits:
    v_max: float  # path velocity limit from the axes (m/s)
    a_max: float  # tangential path acceleration limit (m/s²)
    j_max: float  # tangential path jerk limit (m/s³), inf for the STEP slope


def _jerk_limited(slope: SlopeType) -> bool:
    return slope is not SlopeType.STEP


def line_limits(seg: LineSeg, axes: tuple[AxisParams, ...], slope: SlopeType) -> SegmentLimits:
    keep = 1.0 - TRANSITION_SHARE
    v = a = j = INF
    for u, ax in zip(seg.unit, axes, strict=True):
        mag = abs(u)
        if mag <= 1e-15:
            continue
        v = min(v, ax.v_max * (1.0 - PLANNING_MARGIN) / mag)
        a = min(a, keep * ax.a_max / mag)
        j = min(j, keep * ax.j_max / mag)
    return SegmentLimits(v, a, j if _jerk_limited(slope) else INF)


def arc_limits(seg: ArcSeg, axes: tuple[AxisParams, ...], slope: SlopeType) -> SegmentLimits:
    keep = 1.0 - TRANSITION_SHARE
    plane = axes[:2]
    v_axis = min(ax.v_max for ax in plane) * (1.0 - PLANNING_MARGIN)
    a_axis = keep * min(ax.a_max for ax in plane)
    j_axis = keep * min(ax.j_max for ax in plane)
    r = seg.radius
    a_tan = (1.0 - ARC_CENTRIPETAL_SHARE) * a_axis
    v = min(v_axis, math.sqrt(ARC_CENTRIPETAL_SHARE * a_axis * r))
    if not _jerk_limited(slope) or j_axis == INF:
        return SegmentLimits(v, a_tan, INF)
    # κ²v³ + 3κv·a_tan ≤ j_axis/2  ⇔  v³ + 3·a_tan·R·v − (j_axis/2)·R² ≤ 0
    v_jerk = depressed_cubic_root(3.0 * a_tan * r, -0.5 * j_axis * r * r)
    return SegmentLimits(min(v, v_jerk), a_tan, 0.5 * j_axis)


def segment_limits(seg: Segment, axes: tuple[AxisParams, ...], slope: SlopeType) -> SegmentLimits:
    if isinstance(seg, LineSeg):
        return line_limits(seg, axes, slope)
    return arc_limits(seg, axes, slope)


def transition_velocity(
    t_in: Vec,
    k_in: Vec,
    t_out: Vec,
    k_out: Vec,
    axes: tuple[AxisParams, ...],
    dt: float,
    jerk_limited: bool,
) -> float:
    """Corner rule: highest path velocity at a transition (tangent t, curvature vector κn before
    and after) for which the sampled axis motion stays within the transition budget."""
    eps = TRANSITION_SHARE * SAFETY
    v = INF
    for i, ax in enumerate(axes):
        dt_i = abs(t_out[i] - t_in[i])
        dk_i = abs(k_out[i] - k_in[i])
        if dt_i > 0.0:
            v = min(v, eps * ax.a_max * dt / dt_i)
        if not jerk_limited or ax.j_max == INF:
            continue
        a_q = 0.75 * dk_i / dt
        b_q = dt_i / (dt * dt)
        c_q = eps * ax.j_max
        if a_q > 0.0:
            v = min(v, (-b_q + math.sqrt(b_q * b_q + 4.0 * a_q * c_q)) / (2.0 * a_q))
        elif b_q > 0.0:
            v = min(v, c_q / b_q)
    return v
