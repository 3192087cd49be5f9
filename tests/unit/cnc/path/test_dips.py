"""Issue 36, fourth round: no dip below a low target (known deviation 2 of docs/geo-core.md),
and the motion check's reading of an event planned while the path decelerates (deviation 4:
wide seeds 119 and 138)."""

from __future__ import annotations

import pytest

from liftd.cnc.geo_task import GeoTask
from liftd.cnc.path.profiles import REACH_ROUND, lowest_velocity
from liftd.cnc.path.tracker import Tracker
from liftd.cnc.path.velocity import projected_velocity, reach_from
from liftd.cnc.ruckig1 import Phases, Ruckig1
from tests.support.cam_cases import cam_scenario
from tests.support.cam_runs import check
from tests.support.feed_cases import short_drop_scenario
from tests.support.scenarios import describe, scenario, wide_scenario

A_MAX, J_MAX = 8.333333333333172, 416.6666666666586  # wide seed 57's run limits


def test_lowest_velocity_is_the_profiles_minimum() -> None:
    """The profile wide seed 57 re-planned at 10.960 s when the window moved on: from 46.4
    mm/s and −1.76 m/s² to 5.71 mm/s 0.36985 mm ahead, where the exact brake needs 0.7 nm
    more. Ruckig's answer brakes to 0.81 mm/s and comes back (24.4 ms, where the brake in
    hand took 16.4); `lowest_velocity` finds that minimum from the profile's pieces."""
    traj = Ruckig1().position(0.0, 0.0464002, -1.7604, 0.00036985, 0.0057086, 1.0, A_MAX, J_MAX)
    dense = min(traj.at_time(traj.duration * i / 20_000)[1][0] for i in range(20_001))
    low = lowest_velocity(Phases(traj))
    assert low == pytest.approx(dense, rel=1e-6, abs=1e-12)
    assert low < 0.001  # the dip itself: below 1 mm/s on the way to 5.71


def test_lowest_velocity_of_a_profile_without_a_dip_is_its_end() -> None:
    traj = Ruckig1().position(0.0, 0.0464002, -1.7604, 0.00036985, 0.0057086 * 0.999, 1.0,
                              A_MAX, J_MAX)  # fmt: skip
    assert lowest_velocity(Phases(traj)) == pytest.approx(0.0057086 * 0.999, rel=1e-9)


def test_a_re_plan_for_a_window_that_moved_on_keeps_the_brake_in_hand() -> None:
    """Wide seed 35 (look-ahead 120, 0.2 mm blocks): braking from 38 toward 1.94 mm/s at
    boundary 267, the window moved on and the re-plan from inside the brake found the exact
    brake a few nm too long; ruckig braked to 0.90 mm/s and came back (a dip no rule
    explains, 3.5 ms later at the boundary). The brake in hand, which reaches 267 at its cap,
    is kept. (The run's other findings, 85–361 mm/s where the rules allow 92–381, are the
    24th constraint counted as a stop, known deviation 1: the check finds them since the fifth
    round, part C.)"""
    sc = wide_scenario(35)
    _, hard, slow, errors = check(sc)
    assert hard == [] and errors == 0, (hard, describe(sc))
    assert not [f for f in slow if f.startswith(("dip", "boundary 267 "))], (slow, describe(sc))


@pytest.mark.parametrize("seed", [119, 138])
def test_an_event_planned_while_decelerating_ramps_the_deceleration_out_first(seed: int) -> None:
    """Wide seed 119: override 0 → 100 % released the path at 42.2 mm/s and −5.93 m/s²
    (jerk 417 m/s³); ramping that deceleration out alone takes 42.2 mm/s off, so the path went
    down to 0.0098 mm/s and on. Wide seed 138: 200 → 150 → 200 % within 8 ms left it at 95.4
    mm/s and −1.77 m/s², whose ramp alone ends at 91.6: boundary 79 at 92.07. The check read
    both events' forward pass from the velocity at the event, as if the path could hold it
    (expected 42.6 and 98.0 mm/s); it now starts where the deceleration is ramped out.
    (Seed 138 also held 81.96 and 65.43 mm/s above its new ceilings of 75 and 50 for ~2.5 ms
    after 200 → 150 % and 150 → 100 % before it braked on: known deviation 10 of
    docs/geo-core.md, fixed by `Brakes.brake_first`.)"""
    sc = wide_scenario(seed)
    _, hard, slow, errors = check(sc)
    assert hard == [] and errors == 0, (hard, describe(sc))
    assert slow == [], (slow, describe(sc))


def test_a_brake_for_a_corner_inside_an_event_ramp_starts_the_forward_pass_again() -> None:
    """CAM seed 687 (look-ahead 8): override 196 → 78 % at 135 mm/s and −6.44 m/s², whose
    ramp alone ends at 72.9 mm/s 2.2 mm on; the path brakes harder, to a corner's 0.28 mm/s
    1.49 mm on, and reaches boundary 5 at 48.7 mm/s, all it can from the corner. Read from the
    ramp's end, the check expected the ceiling, 59.0."""
    sc = cam_scenario(687)
    _, hard, slow, errors = check(sc)
    assert hard == [] and errors == 0, (hard, describe(sc))
    assert slow == [], (slow, describe(sc))


def test_after_an_override_drop_the_dip_stays_where_no_brake_is_in_hand() -> None:
    """Wide seed 767 (Advanced Lifting): the override drop 200 → 120 % at 1.900 s, 7.6 ms
    before LIFT_END, is planned from a brake to 0.49 mm/s there; ruckig's profile dips to
    0.36 and arrives 1.2 ms later than the brake before the drop. A lower target that did not
    dip (tried) arrived at the earlier time, and Z, descending, landed 0.2 ms after the path
    passed LIFT_END (6.9e-18 m from POS, still moving): no profile is kept after an event."""
    sc = wide_scenario(767)
    _, hard, _, errors = check(sc)
    assert hard == [] and errors == 0, (hard, describe(sc))


def test_a_brake_from_a_cruise_at_the_ceiling_does_not_dip_below_its_target() -> None:
    """Wide seed 54 (known deviation 2's remainder, planned from a cruise): at 11.4945 s the
    path cruised at its ceiling of 75 mm/s with a last 0.005 m/s² of acceleration (its
    projected velocity the ceiling itself, ruckig's v_max) and re-planned for a kink of
    9.485 mm/s 1.012 mm on, 23 µm more than the exact brake needs. Ruckig missed the profile
    that holds v_max and brakes late and returned one through 8.236 mm/s, 26.86 ms long;
    v_max a rounding higher gives the late brake, 23.72 ms, no dip."""
    sc = wide_scenario(54)
    task = GeoTask(sc.channel, sc.text)
    tracker = Tracker(task.interp.table, task.interp.prod.look_ahead)
    s, v, a = 1.0998018729074313, 0.07499997505712246, 0.004886464101179655
    s_c, target, v_max = 1.1008143138262327, 0.00948501935134853, 0.07500000000000001
    a_max, j_max = 9.572885628540265, 478.64428142701325
    v_p = projected_velocity(v, a, j_max)
    assert v_p == v_max  # the degenerate case: the acceleration ramps out onto v_max
    tracker.st.t = 11.4945
    tracker.tg.settle(s, v, a, v_p, s_c, target, target, v_max, a_max, j_max, 665, 785, target,
                    None, None, False)  # fmt: skip
    plan = tracker.plan
    assert plan is not None and plan.goal == 665 and plan.v_end == target
    assert lowest_velocity(Phases(plan.traj)) >= target * (1.0 - 1e-9)
    assert plan.dur < 0.0240  # the late brake: 23.72 ms, where the dip took 26.86
    assert tracker.errors == 0


# (scenario, seed, state at the event: s, v, a, boundary position, target, v_max, a_max,
# j_max; boundary, window end, the brake's and the dip's durations in ms)
EVENT_BRAKES = {
    "narrow 635": (
        scenario, 635, 1.741,
        (0.29701186316280764, 0.19624875671843034, -1.7800726853855589, 0.3006748343268898,
         0.004818920356235057, 0.19624875671843034, 8.027647653633219, 401.3823826816609),
        3, 4, 39.903, 44.265,
    ),
    "cam 956": (
        cam_scenario, 956, 1.0135,
        (1.458618427197006, 0.046279229520873794, -1.112906671309145, 1.459006586279627,
         0.0026785826071593914, 0.046279229520873794, 8.903004756345235, 445.15023781726165),
        2, 9, 17.607, 21.650,
    ),
}  # fmt: skip


@pytest.mark.parametrize("case", sorted(EVENT_BRAKES))
def test_an_event_inside_the_exact_brake_plans_that_brake(case: str) -> None:
    """Known deviation 2's remainder (sixth round, part E). Narrow seed 635: override 100 →
    77 % at 1.741 s while the path braked from 196 mm/s to a corner of 4.82 mm/s 3.663 mm
    on; the event's re-plan is on the exact brake (it needs the distance within 3e-17 m),
    ruckig's position profile found it a rounding too long and braked to 3.09 mm/s and back,
    4.4 ms later. CAM seed 956: 191 → 139 %, 46.3 → 2.68 mm/s, through 1.15, 4.0 ms later.
    The brake itself is planned: no dip, and the arrival the lift planned with before the
    event (the same brake) does not move. Since the thirteenth round also outside an event,
    where `_unpin` finds no profile without the dip (feeds seed 381)."""
    make, seed, t, state, b, w, brake, dip = EVENT_BRAKES[case]
    s, v, a, s_c, target, v_max, a_max, j_max = state
    sc = make(seed)
    task = GeoTask(sc.channel, sc.text)
    tracker = Tracker(task.interp.table, task.interp.prod.look_ahead)
    tracker.st.t = t
    v_p = projected_velocity(v, a, j_max)
    # ruckig's own profile to the target: the dip (no brake in hand)
    assert tracker.tg.pf.try_target(s, v, a, s_c, target, v_max, a_max, j_max, b, w)
    plan = tracker.plan
    assert plan is not None and plan.dur * 1e3 == pytest.approx(dip, abs=1e-3)
    assert lowest_velocity(Phases(plan.traj)) < 0.7 * target
    args = (s, v, a, v_p, s_c, target, target, v_max, a_max, j_max, b, w, target, None, None)
    for event in (True, False):
        tracker.tg.settle(*args, event)
        plan = tracker.plan
        assert plan is not None and plan.goal == b and plan.v_end == target and plan.p_end == s_c
        assert plan.dur * 1e3 == pytest.approx(brake, abs=1e-3)
        assert lowest_velocity(Phases(plan.traj)) >= target * (1.0 - 1e-9)
        s_end, v_end, a_end = plan.at(t + plan.dur)
        assert s_end == pytest.approx(s_c, abs=1e-12)
        assert v_end == pytest.approx(target, rel=1e-9)
        assert a_end == pytest.approx(0.0, abs=1e-9)
    assert tracker.errors == 0
    _, hard, slow, errors = check(sc)
    assert hard == [] and errors == 0, (hard, describe(sc))
    assert not [f for f in slow if f.startswith("dip")], (slow, describe(sc))


def test_the_lowest_velocity_of_a_profile_that_brakes_into_its_limits_first() -> None:
    """From 150 mm/s and −1 m/s² with v_max 100 mm/s, ruckig brakes into its limits first with
    a brake of one piece; the second piece's velocity, never written, reads 0, and the
    lowest velocity read 0 where the profile never goes below its target of 10 mm/s (a review
    found: 242 of 266 profiles of `Brakes.brake_into` refused as dips that were none)."""
    traj = Ruckig1().position(0.0, 0.15, -1.0, 0.01, 0.01, 0.1, 8.0, 400.0)
    ph = Phases(traj)
    assert ph.b_dur > 0.0 and ph.b_t0 == ph.b_dur  # a brake of one piece
    sampled = min(float(traj.at_time(traj.duration * k / 2000)[1][0]) for k in range(2001))
    assert lowest_velocity(ph) == pytest.approx(sampled, rel=1e-6)
    assert lowest_velocity(ph) >= 0.01 * (1.0 - 1e-9)


# ruckig at the edge of the reachable: from inside a brake (a short_drop run, F3000, override
# 100 → 10 % 1.7 mm before the F6000 block, look-ahead 30, 2 ms) at that block's end, toward
# the highest velocity the path can have at the run boundary 0.2 mm on (`reach_from`)
EDGE = (0.005400010186751738, 0.017083394243701498, -2.381802542654486, 0.0056000311856493545,
        0.018109574882210364, 0.1, 8.00884880470934, 400.44244023546696)  # fmt: skip


def test_ruckig_at_the_edge_of_the_reachable_returns_a_profile_that_dips() -> None:
    """The state and target the tracker re-planned with: ruckig's profile to exactly the
    highest reachable velocity brakes on to 3.61 mm/s and comes back (20.4 ms); a target
    `REACH_ROUND` lower gives the profile that ramps the deceleration out to 10.0 and speeds
    up at once (14.9 ms). Why `Profiles._unreach` tries it."""
    s, v, a, s_c, target, v_max, a_max, j_max = EDGE
    v_p = projected_velocity(v, a, j_max)
    assert target == pytest.approx(reach_from(v, a, s_c - s, a_max, j_max), rel=1e-12)
    r = Ruckig1()
    edge = r.position(s, v, a, s_c, target, v_max, a_max, j_max)
    below = r.position(s, v, a, s_c, target * (1.0 - REACH_ROUND), v_max, a_max, j_max)
    assert lowest_velocity(Phases(edge)) < 0.5 * v_p
    assert lowest_velocity(Phases(below)) >= v_p * (1.0 - 1e-9)
    assert below.duration < 0.8 * edge.duration


def test_a_speed_up_after_a_brake_s_ramp_out_does_not_dip() -> None:
    """That run: the path passed the boundary 0.2 mm on at 18.1 mm/s after a dip to 4.2
    (found by the motion check), where it ramps out to 10.0 mm/s and speeds up at once now."""
    _, hard, slow, errors = check(short_drop_scenario(3000, 6, 1.7, 0.1, 30, 2e-3))
    assert (hard, slow, errors) == ([], [], 0)
