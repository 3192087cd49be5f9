"""Closed-form jerk-limited velocity changes: the inverse really inverts."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from liftd.cnc.path.velocity import (
    change_distance,
    change_time,
    lowest_reachable,
    reach_velocity,
)

speeds = st.floats(0.0, 3.0)
lengths = st.floats(1e-6, 2.0)
accs = st.floats(0.5, 50.0)
jerks = st.one_of(st.floats(10.0, 5000.0), st.just(math.inf))


def test_known_values() -> None:
    # 0 → 1 m/s with A = 10, J = 500: trapezoid, t = 1/10 + 10/500 = 0.12 s, d = 0.06 m
    assert change_time(0.0, 1.0, 10.0, 500.0) == pytest.approx(0.12)
    assert change_distance(0.0, 1.0, 10.0, 500.0) == pytest.approx(0.06)
    # small change: triangle, t = 2·sqrt(0.1/500)
    assert change_time(0.0, 0.1, 10.0, 500.0) == pytest.approx(2 * math.sqrt(0.1 / 500))
    assert change_distance(0.0, 1.0, 10.0, math.inf) == pytest.approx(0.05)


@given(speeds, st.floats(1e-6, 3.0), accs, jerks)
def test_reach_velocity_inverts_change_distance(
    v_end: float, dv: float, a: float, j: float
) -> None:
    length = change_distance(v_end + dv, v_end, a, j)
    got = reach_velocity(v_end, length, a, j) - v_end
    assert got == pytest.approx(dv, rel=1e-6, abs=1e-12)


@given(speeds, lengths, accs, jerks)
def test_lowest_reachable(v0: float, length: float, a: float, j: float) -> None:
    low = lowest_reachable(v0, length, a, j)
    assert 0.0 <= low <= v0
    assert change_distance(v0, low, a, j) <= length * (1 + 1e-9) + 1e-12
