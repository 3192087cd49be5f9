"""Segment geometry, projected limits and the corner rule."""

from __future__ import annotations

import math

import pytest

from liftd.cnc.params import SlopeType
from liftd.cnc.path.geometry import ArcSeg, LineSeg, arc_sweep, center_from_radius
from liftd.cnc.path.limits import (
    TRANSITION_SHARE,
    arc_limits,
    line_limits,
    transition_velocity,
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


def test_corner_rule() -> None:
    ch = make_channel()
    dt = 1e-3
    zero = (0.0, 0.0, 0.0)
    x, y = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)
    assert math.isinf(transition_velocity(x, zero, x, zero, ch.axes, dt, True))  # tangential
    v90 = transition_velocity(x, zero, y, zero, ch.axes, dt, True)
    j_min = min(ax.j_max for ax in ch.axes[:2])
    # V/dt² ≤ ε·j per axis with |Δt| = 1: v ≤ ε·j·dt² (a fraction of a mm/s: an exact stop)
    assert v90 == pytest.approx(TRANSITION_SHARE * 0.999 * j_min * dt * dt, rel=1e-9)
    # tangential line → arc (R = 10 mm): only the curvature jump limits, 0.75·v²/R/dt ≤ ε·j
    k = (0.0, 100.0, 0.0)
    v_arc = transition_velocity(x, zero, x, k, ch.axes, dt, True)
    assert v_arc == pytest.approx(math.sqrt(TRANSITION_SHARE * 0.999 * j_min * dt / 75.0))
