"""The closed forms of cnc/path/velocity.py, which decide every braking margin of the look-ahead,
against ruckig's time-optimal velocity changes (an independent solver): a change from v0 to v1
at zero acceleration takes `change_time` and covers `change_distance`; a brake from (v, a) to v1
covers `brake_distance`, and its velocity is down to a cap for good after `brake_crossing`;
`reach_velocity` inverts `change_distance`; `lowest_reachable_from`
finds a velocity the path can brake to within the length, and none much lower."""

from __future__ import annotations

from hypothesis import assume, given
from hypothesis import strategies as st
from ruckig import ControlInterface, InputParameter, Result, Ruckig, Trajectory

from liftd.cnc.path.velocity import (
    brake_crossing,
    brake_distance,
    change_distance,
    change_time,
    lowest_reachable_from,
    projected_velocity,
    reach_velocity,
)

REL = 1e-6  # relative agreement of the closed forms with ruckig
speeds = st.floats(0.0, 3.0)  # m/s
a_maxes = st.floats(0.2, 20.0)  # m/s²
j_maxes = st.floats(5.0, 2000.0)  # m/s³


def ruckig_velocity(v0: float, a0: float, v1: float, a_max: float, j_max: float) -> Trajectory:
    """Ruckig's time-optimal change from (v0, a0) to (v1, 0), from position 0."""
    inp = InputParameter(1)
    inp.control_interface = ControlInterface.Velocity
    inp.current_position, inp.current_velocity, inp.current_acceleration = [0.0], [v0], [a0]
    inp.target_velocity, inp.target_acceleration = [v1], [0.0]
    inp.max_velocity = [max(v0, v1, 1e-9) * 2.0]
    inp.max_acceleration, inp.max_jerk = [max(a_max, abs(a0))], [j_max]
    traj = Trajectory(1)
    assert Ruckig(1).calculate(inp, traj) == Result.Working
    return traj


def ruckig_change(
    v0: float, a0: float, v1: float, a_max: float, j_max: float
) -> tuple[float, float]:
    """(duration, distance) of ruckig's time-optimal change from (v0, a0) to (v1, 0)."""
    traj = ruckig_velocity(v0, a0, v1, a_max, j_max)
    pos, _, _ = traj.at_time(traj.duration)
    return traj.duration, pos[0]


def close(got: float, want: float, scale: float) -> bool:
    return abs(got - want) <= REL * max(abs(want), scale) + 1e-12


@given(speeds, speeds, a_maxes, j_maxes)
def test_change_time_and_distance_are_ruckigs(
    v0: float, v1: float, a_max: float, j_max: float
) -> None:
    t, d = ruckig_change(v0, 0.0, v1, a_max, j_max)
    assert close(change_time(v0, v1, a_max, j_max), t, 1e-3)
    assert close(change_distance(v0, v1, a_max, j_max), d, 1e-6)


@given(speeds, st.floats(0.0, 1.0), speeds, a_maxes, j_maxes)
def test_brake_distance_is_ruckigs_brake(
    v: float, a_share: float, v1_share: float, a_max: float, j_max: float
) -> None:
    """From (v, a) with |a| ≤ a_max, down to v1 below the projected velocity; where the
    current deceleration would overshoot v1 while it is ramped out, the closed form is that
    ramp (its precondition), which ruckig does not take: left out."""
    a = (2.0 * a_share - 1.0) * a_max
    v1 = v1_share * max(v - 1e-3, 0.0)
    assume(projected_velocity(v, a, j_max) > v1 + 1e-6)
    assume(a >= 0.0 or 0.5 * a * a + j_max * (v - v1) >= a * a)
    _, d = ruckig_change(v, a, v1, a_max, j_max)
    assert close(brake_distance(v, a, v1, a_max, j_max), d, 1e-6)


@given(speeds, st.floats(0.0, 1.0), speeds, st.floats(0.0, 1.0), a_maxes, j_maxes)
def test_brake_crossing_is_where_ruckigs_brake_gets_below_the_cap(
    v: float, a_share: float, v1_share: float, cap_share: float, a_max: float, j_max: float
) -> None:
    """The brake of `brake_distance` (same preconditions) read off ruckig's profile: after its
    peak the velocity only falls, so the last moment above the cap is found by bisection, and
    the distance covered until then is `brake_crossing`'s."""
    a = (2.0 * a_share - 1.0) * a_max
    v1 = v1_share * max(v - 1e-3, 0.0)
    v_p = projected_velocity(v, a, j_max)
    assume(v_p > v1 + 1e-6)
    assume(a >= 0.0 or 0.5 * a * a + j_max * (v - v1) >= a * a)
    top = v + a * a / (2.0 * j_max) if a > 0.0 else v
    cap = v1 + cap_share * (top - v1)
    traj = ruckig_velocity(v, a, v1, a_max, j_max)
    want = 0.0  # never above the cap
    if cap < top:
        lo, hi = min(max(a, 0.0) / j_max, traj.duration), traj.duration  # falling from its peak
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if traj.at_time(mid)[1][0] > cap else (lo, mid)
        want = traj.at_time(hi)[0][0]
    got = brake_crossing(v, a, v1, cap, a_max, j_max)
    assert close(got, want, 1e-6), (got, want)


@given(speeds, st.floats(1e-4, 5.0), a_maxes, j_maxes)
def test_reach_velocity_inverts_the_change(
    v_end: float, length: float, a_max: float, j_max: float
) -> None:
    """The highest velocity from which ruckig's time-optimal brake to v_end covers `length`."""
    v = reach_velocity(v_end, length, a_max, j_max)
    assert v >= v_end
    _, d = ruckig_change(v, 0.0, v_end, a_max, j_max)
    assert close(d, length, 1e-6)


@given(st.floats(0.05, 3.0), st.floats(-1.0, 1.0), st.floats(0.02, 0.98), a_maxes, j_maxes)
def test_lowest_reachable_from_is_reachable_and_nothing_much_lower(
    v: float, a_share: float, share: float, a_max: float, j_max: float
) -> None:
    """Within a share of the distance to rest: the velocity found is reached within the length
    (ruckig's brake to it), 0.01 % below it is not."""
    a = a_share * a_max
    length = share * brake_distance(v, a, 0.0, a_max, j_max)
    w = lowest_reachable_from(v, a, length, a_max, j_max)
    assume(0.0 < w < projected_velocity(v, a, j_max) - 1e-6)  # a brake, not rest or a ramp
    lower = w * (1.0 - 1e-4)
    assume(a >= 0.0 or 0.5 * a * a + j_max * (v - w) >= a * a)
    _, d = ruckig_change(v, a, w, a_max, j_max)
    assert d <= length * (1.0 + REL) + 1e-12  # reachable …
    _, d_lower = ruckig_change(v, a, lower, a_max, j_max)
    assert d_lower > length  # … and a lower one is not
