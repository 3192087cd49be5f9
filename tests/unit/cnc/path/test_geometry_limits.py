"""Segment geometry, projected limits and the block-transition dynamics (P-AXIS-00013,
P-AXIS-00154, P-CHAN-00009, P-CHAN-00117, P-AXIS-00339/00340, #TRANSVELMIN)."""

from __future__ import annotations

import dataclasses
import math

import pytest

from liftd.cnc.params import AxisParams, SlopeType
from liftd.cnc.path.geometry import ArcSeg, LineSeg, arc_sweep, center_from_radius
from liftd.cnc.path.limits import (
    SAFETY,
    TRANSITION_SHARE,
    arc_limits,
    line_limits,
    transition,
)
from tests.support.channel import make_channel


def test_line_position_tangent_length() -> None:
    seg = LineSeg.make((0.0, 0.0, 0.0), (0.3, 0.4, 0.0))
    assert seg.length == pytest.approx(0.5)
    assert seg.position(0.25) == pytest.approx((0.15, 0.2, 0.0))
    assert seg.tangent(0.1) == pytest.approx((0.6, 0.8, 0.0))


def test_arc_position_end_and_curvature() -> None:
    seg = ArcSeg.make((1.0, 0.0, 0.5), (0.0, 1.0, 0.5), (0.0, 0.0), math.pi / 2)
    assert seg.length == pytest.approx(math.pi / 2)
    assert seg.position(seg.length / 2) == pytest.approx((math.sqrt(0.5), math.sqrt(0.5), 0.5))
    assert seg.position(seg.length) == (0.0, 1.0, 0.5)
    assert seg.tangent(0.0) == pytest.approx((0.0, 1.0, 0.0))
    assert seg.normal_curvature(0.0) == pytest.approx((-1.0, 0.0, 0.0))
    (x0, x1), (y0, y1) = seg.axis_extent()
    assert (x0, x1, y0, y1) == pytest.approx((0.0, 1.0, 0.0, 1.0))


def test_full_circle_and_radius_centre() -> None:
    assert arc_sweep((1.0, 0.0), (1.0, 0.0), (0.0, 0.0), ccw=False) == pytest.approx(-2 * math.pi)
    # CCW short arc (R > 0) from (0,0) to (1,1): centre (0,1), sweep +90°
    c = center_from_radius((0.0, 0.0), (1.0, 1.0), 1.0, ccw=True)
    assert c == pytest.approx((0.0, 1.0))
    assert arc_sweep((0.0, 0.0), (1.0, 1.0), c, ccw=True) == pytest.approx(math.pi / 2)
    # R < 0: the long way round, centre on the other side
    c_long = center_from_radius((0.0, 0.0), (1.0, 1.0), -1.0, ccw=True)
    assert c_long == pytest.approx((1.0, 0.0))
    assert arc_sweep((0.0, 0.0), (1.0, 1.0), c_long, ccw=True) == pytest.approx(1.5 * math.pi)
    assert center_from_radius((0.0, 0.0), (3.0, 0.0), 1.0, ccw=True) is None


def test_line_limits_are_projected_with_the_transition_reserve() -> None:
    ch = make_channel()
    seg = LineSeg.make((0.0, 0.0, 0.0), (0.0, 1.0, 0.0))  # along Y
    lim = line_limits(seg, ch.axes, SlopeType.TRAPEZ)
    y = ch.axis("Y")
    assert lim.v_max == pytest.approx(y.v_max)
    assert lim.a_max == pytest.approx((1 - TRANSITION_SHARE) * y.a_max)
    diag = LineSeg.make((0.0, 0.0, 0.0), (1.0, 1.0, 0.0))
    lim_d = line_limits(diag, ch.axes, SlopeType.STEP)
    assert lim_d.v_max == pytest.approx(ch.axis("X").v_max * math.sqrt(2), rel=1e-5)
    assert math.isinf(lim_d.j_max)


def test_arc_limits_respect_centripetal_and_jerk_budgets() -> None:
    ch = make_channel()
    r = 0.01
    arc = ArcSeg.make((r, 0.0, 0.0), (r, 0.0, 0.0), (0.0, 0.0), 2 * math.pi)
    lim = arc_limits(arc, ch.axes, SlopeType.TRAPEZ)
    a_axis = (1 - TRANSITION_SHARE) * min(ax.a_max for ax in ch.axes[:2])
    j_axis = (1 - TRANSITION_SHARE) * min(ax.j_max for ax in ch.axes[:2])
    v = lim.v_max
    assert v * v / r <= 0.5 * a_axis * (1 + 1e-9)
    assert v**3 / r**2 + 3 * v * lim.a_max / r <= 0.5 * j_axis * (1 + 1e-9)
    assert lim.a_max + v * v / r <= a_axis * (1 + 1e-9)


def _axes(**kw: float) -> tuple[AxisParams, ...]:
    return tuple(dataclasses.replace(ax, **kw) for ax in make_channel().axes)


X, Y, ZERO = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 0.0)
DT = 1e-3


def test_a_kink_steps_each_axis_acceleration_by_its_transition_allowance() -> None:
    """P-AXIS-00013: 0 weights a_max with cycle time / ramp time (the step stays within the
    axis jerk: v·|Δt|/dt ≤ j·dt), 1000 keeps the full acceleration (v·|Δt|/dt ≤ a_max)."""
    axes = make_channel().axes
    tangent = transition(X, ZERO, X, ZERO, axes, DT, True, 8.0)
    assert math.isinf(tangent.v_cap) and tangent.smooth and not tangent.kink
    corner = transition(X, ZERO, Y, ZERO, axes, DT, True, 8.0)
    assert corner.kink and not corner.smooth  # a run boundary: zero path acceleration
    assert corner.v_cap == pytest.approx(SAFETY * 500.0 * DT * DT)  # 0.5 mm/s: almost a stop
    full = transition(X, ZERO, Y, ZERO, _axes(a_trans_weight=1.0), DT, True, 8.0)
    assert full.v_cap == pytest.approx(SAFETY * 10.0 * DT)
    half = transition(X, ZERO, Y, ZERO, _axes(a_trans_weight=0.5), DT, True, 8.0)
    assert half.v_cap == pytest.approx(0.5 * full.v_cap)
    # the STEP slope: the weights act with the non-linear slope only; a_max steps
    assert transition(X, ZERO, Y, ZERO, axes, DT, False, 8.0).v_cap == pytest.approx(full.v_cap)


def test_every_kink_is_a_run_boundary() -> None:
    """SMOOTH_KINKS is off (limits.py: a lift landed late with it): even a 0.2° kink asks for
    zero path acceleration, with the whole allowance for its velocity step."""
    axes = make_channel().axes
    turn = math.radians(0.2)
    small = transition(X, ZERO, (math.cos(turn), math.sin(turn), 0.0), ZERO, axes, DT, True, 8.0)
    assert small.kink and not small.smooth
    assert small.v_cap == pytest.approx(SAFETY * 0.5 * DT / math.sin(turn), rel=1e-3)


def test_a_tangential_curvature_jump_slows_the_path_only_with_p_chan_00009() -> None:
    axes = make_channel().axes
    k = (0.0, 100.0, 0.0)  # line → arc of R 10 mm
    assert math.isinf(transition(X, ZERO, X, k, axes, DT, True, 8.0).v_cap)
    on = transition(X, ZERO, X, k, axes, DT, True, 8.0, corr_v_trans_jerk=True)
    assert on.v_cap == pytest.approx(math.sqrt(SAFETY * 10.0 / 100.0))  # r_trans_weight 1000
    jerk = _axes(r_trans_weight=0.0)
    mode1 = transition(X, ZERO, X, k, jerk, DT, True, 8.0, corr_v_trans_jerk=True, mode=1)
    assert mode1.v_cap == pytest.approx(math.sqrt(SAFETY * 500.0 * DT / 100.0))
    # mode 0: P-AXIS-00154 is at least P-AXIS-00013's weight
    both = _axes(r_trans_weight=0.0, a_trans_weight=0.4)
    mode0 = transition(X, ZERO, X, k, both, DT, True, 8.0, corr_v_trans_jerk=True, mode=0)
    assert mode0.v_cap == pytest.approx(math.sqrt(SAFETY * 4.0 / 100.0))


def test_mode_2_takes_the_transition_jerks_limited_to_a_max_over_the_cycle() -> None:
    c0 = transition(X, ZERO, Y, ZERO, _axes(j_trans_c0=2000.0), DT, True, 8.0, mode=2)
    assert c0.v_cap == pytest.approx(SAFETY * 2000.0 * DT * DT)
    unset = transition(X, ZERO, Y, ZERO, _axes(), DT, True, 8.0, mode=2)
    assert unset.v_cap == pytest.approx(SAFETY * 500.0 * DT * DT)  # 0: the axis jerk
    huge = transition(X, ZERO, Y, ZERO, _axes(j_trans_c0=1e9), DT, True, 8.0, mode=2)
    assert huge.v_cap == pytest.approx(SAFETY * 10.0 * DT)  # at most a_max / dt


def test_transvelmin_raises_a_kink_but_not_over_jerk_limitation() -> None:
    axes = make_channel().axes
    assert transition(X, ZERO, Y, ZERO, axes, DT, True, 8.0, v_min=0.05).v_cap == 0.05
    assert transition(X, ZERO, X, ZERO, axes, DT, True, 8.0, v_min=0.05).v_cap == math.inf
    jerk = transition(X, ZERO, Y, ZERO, axes, DT, True, 8.0, corr_v_trans_jerk=True, v_min=0.05)
    assert jerk.v_cap == pytest.approx(SAFETY * 500.0 * DT * DT)
