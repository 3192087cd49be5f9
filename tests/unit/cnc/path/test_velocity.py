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
    reach_velocity_any_above,
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


def test_rest_reachable_is_not_a_low_cap_reachable() -> None:
    """Why the window's end needs `reach_velocity_any_above`: from the velocity at which rest
    is just reachable within 1 mm (A 8.27, J 413.4, wide seed 146's limits), a cap of 40 mm/s
    is not (braking to a third of a velocity takes longer than braking to rest)."""
    a, j, length = 8.27, 413.4, 1e-3
    v0 = reach_velocity(0.0, length, a, j)
    assert change_distance(v0, 0.0, a, j) == pytest.approx(length)
    assert change_distance(v0, 0.04, a, j) > length * 1.01
    assert reach_velocity_any_above(0.0, length, a, j) < v0


@given(speeds, lengths, accs, jerks)
def test_every_higher_end_is_reachable_from_reach_velocity_any_above(
    v_end: float, length: float, a: float, j: float
) -> None:
    """From reach_velocity_any_above(e, L) every end velocity from e up to it is reachable
    within L (zero acceleration at both ends), and it is the least reach_velocity over them
    (a scan of 400 end velocities; where the change is within 1e-6 of the velocity, the
    subtraction of two velocities leaves too few digits for the distance, and only the first
    and the last claim are checked)."""
    top = reach_velocity_any_above(v_end, length, a, j)
    assert top <= reach_velocity(v_end, length, a, j) * (1.0 + 1e-12) + 1e-15
    ends = [v_end + (top - v_end) * k / 400 for k in range(401)]
    if top - v_end > 1e-6 * top:
        assert all(change_distance(top, e, a, j) <= length * (1.0 + 1e-6) for e in ends)
    least = min(reach_velocity(e, length, a, j) for e in ends)
    assert top <= least * (1.0 + 1e-9) + 1e-15
    assert top >= least * (1.0 - 2e-3)  # the scan's resolution
