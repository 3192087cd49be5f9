"""Path limits from axis limits: per segment (projected) and at block transitions.

Inside a segment the path uses at most (1 − TRANSITION_SHARE) of each axis' acceleration and
jerk, projected onto the segment; on an arc the centripetal part κv² takes
ARC_CENTRIPETAL_SHARE of the acceleration and the jerk terms κ²v³ + 3κv|s̈| take half of the
jerk budget (p⃛ = (s⃛ − κ²v³)·t + 3κv·s̈·n on a circle). The share kept back is liftd's own margin
for the sampled motion around a transition (README, "How liftd behaves where the vendor text
leaves room").

At a block transition the path velocity is limited as the CNC's block-transition dynamics say
(`transition`): an axis' velocity steps by v·|Δt_i| within a cycle at a kink (its acceleration
jumps by v·|Δt_i|/dt), and its acceleration steps by v²·|Δ(κn)_i| where the curvature changes.
The jump each axis may take is its transition allowance (`allowed_jump`):

* at a kink, P-AXIS-00013 a_trans_weight (getriebe[i].dynamik.a_trans_weight, 0.1 %): the
  jump ≤ a_max · a_trans_weight / 1000; 0 (the default) weights a_max with the factor cycle
  time / ramp time (dt / tr, tr = a_max / j_max: the jump stays within the axis jerk), 1000
  keeps the full acceleration and the jerk exceeds its limit
  https://infosys.beckhoff.com/content/1033/tf5200_axis_parameter/117648395.html
  https://infosys.beckhoff.com/content/1033/dynamic/15425545355.html
* at a tangential transition with a curvature jump (line ↔ arc, arc ↔ arc), only when P-CHAN-00009
  corr_v_trans_jerk is set (default 0: no slowdown), P-AXIS-00154 r_trans_weight (0.1 %,
  default 1000): the jump ≤ a_max · r_trans_weight / 1000, 0 = dt / tr; under P-CHAN-00117
  mode_trans_jerk 0 it is at least what P-AXIS-00013 allows
  https://infosys.beckhoff.com/content/1033/tf5200_axis_parameter/117667595.html
  https://infosys.beckhoff.com/content/1033/tf5200_channel_parameter/149316875.html
  https://infosys.beckhoff.com/content/1033/tf5200_channel_parameter/149319947.html
* under mode_trans_jerk 2 the jerks P-AXIS-00339 j_trans_c0 (kinks) and P-AXIS-00340
  j_trans_c1 (tangential) instead: the jump ≤ j_trans · dt, j_trans limited to a_max / dt
  (0: the axis jerk)
  https://infosys.beckhoff.com/content/1033/tf5200_axis_parameter/131314059.html
  https://infosys.beckhoff.com/content/1033/tf5200_axis_parameter/131315979.html
* `#TRANSVELMIN ON [v]` raises the velocity at kinks to at least v (never above the blocks'
  own limits), unless corr_v_trans_jerk is set, which takes priority
  https://infosys.beckhoff.com/content/1033/tf5200_programming_manual/207486091.html

The weights act with the non-linear (jerk-limited) slope; with the STEP slope a kink may step
an axis' acceleration by its a_max. Every kink is a run boundary: the path acceleration is zero
there. (A kink small enough that the path's own acceleration, turned with the tangent, takes at
most half of the allowance could carry it through, `SMOOTH_KINKS`: built and switched off, see
there.)
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


@dataclass(frozen=True, slots=True)
class Transition:
    v_cap: float  # highest path velocity at the transition (inf: no limit from it)
    smooth: bool  # the path acceleration may pass through (not a run boundary by itself)
    kink: bool  # the tangent jumps
    v_min: float = 0.0  # #TRANSVELMIN in effect at a kink (the cap is at least this)


TANGENT_TOL = 1e-9  # |Δ direction cosine| at or below which a transition is tangential
# Whether a small kink may carry the path acceleration (`Transition.smooth`). Off: with it, a
# feed hold inside an Advanced lift range over a polyline of 0.2 mm blocks (rounding kinks of
# 5e-4) let the path pass LIFT_END with Z 14 µm above POS (bench_lift_safety --wide seeds 340,
# 572), a lift-side interaction not found in issue 36's time; every kink is a run boundary, as
# before it (CAM polylines are slow: issue 36's report).
SMOOTH_KINKS = False


def allowed_jump(ax: AxisParams, dt: float, kink: bool, jerk_limited: bool, mode: int) -> float:
    """The jump of the axis' acceleration (m/s²) the CNC allows within a cycle at a block
    transition (module docstring)."""
    if not jerk_limited or ax.j_max == INF:
        return ax.a_max
    if mode == 2:
        j = ax.j_trans_c0 if kink else ax.j_trans_c1
        j = ax.j_max if j <= 0.0 else j
        return min(j * dt, ax.a_max)
    ramp = dt * ax.j_max / ax.a_max  # cycle time / ramp time

    def fraction(weight: float) -> float:
        return weight if weight > 0.0 else ramp

    share = fraction(ax.a_trans_weight)
    if not kink:
        share = fraction(ax.r_trans_weight) if mode != 0 else max(fraction(ax.r_trans_weight),
                                                                   share)  # fmt: skip
    return min(share, 1.0) * ax.a_max


def transition(
    t_in: Vec,
    k_in: Vec,
    t_out: Vec,
    k_out: Vec,
    axes: tuple[AxisParams, ...],
    dt: float,
    jerk_limited: bool,
    a_carry: float,
    corr_v_trans_jerk: bool = False,
    mode: int = 0,
    v_min: float = 0.0,
) -> Transition:
    """The block transition between a segment ending with tangent t_in and curvature vector
    κn k_in and one starting with t_out, k_out: its velocity cap and whether the path
    acceleration (up to `a_carry`) may pass through it. `v_min`: #TRANSVELMIN."""
    kink = False
    for i in range(len(axes)):
        if abs(t_out[i] - t_in[i]) > TANGENT_TOL:
            kink = True
    smooth = True
    v = INF
    for i, ax in enumerate(axes):
        d_t = abs(t_out[i] - t_in[i]) if kink else 0.0
        d_k = abs(k_out[i] - k_in[i])
        if not kink and not corr_v_trans_jerk:
            continue  # no slowdown at a tangential transition (P-CHAN-00009 off)
        budget = allowed_jump(ax, dt, kink, jerk_limited, mode) * SAFETY
        carry = a_carry * d_t
        if not SMOOTH_KINKS or carry > 0.5 * budget:
            smooth = False
        else:
            budget -= carry
        # jump = v·d_t/dt + v²·d_k ≤ budget
        lin = d_t / dt
        if d_k > 0.0:
            v = min(v, (-lin + math.sqrt(lin * lin + 4.0 * d_k * budget)) / (2.0 * d_k))
        elif lin > 0.0:
            v = min(v, budget / lin)
    if kink and v_min > 0.0 and not corr_v_trans_jerk:
        v = max(v, v_min)
    return Transition(v, smooth, kink, v_min if kink else 0.0)


def transition_allowance(
    axes: tuple[AxisParams, ...], dt: float, jerk_limited: bool, corr_v_trans_jerk: bool = False,
    mode: int = 0,
) -> tuple[tuple[float, float], ...]:  # fmt: skip
    """Per axis, the |a| and |j| ratios (to a_max, j_max) the sampled motion may reach over a
    block transition: a segment's own share plus the largest jump the transitions may take (a
    kink's allowance, or at a tangential transition without P-CHAN-00009 the curvature jump of
    two arcs turning opposite ways at their centripetal limit). #TRANSVELMIN is not bounded."""
    keep = 1.0 - TRANSITION_SHARE
    out: list[tuple[float, float]] = []
    for ax in axes:
        kink = allowed_jump(ax, dt, True, jerk_limited, mode)
        if corr_v_trans_jerk:
            tangential = allowed_jump(ax, dt, False, jerk_limited, mode)
        else:
            tangential = 2.0 * ARC_CENTRIPETAL_SHARE * keep * ax.a_max
        jump = max(kink, tangential)
        j_ratio = keep + jump / (dt * ax.j_max) if ax.j_max != INF else 0.0
        out.append((keep + jump / ax.a_max, j_ratio))
    return tuple(out)
