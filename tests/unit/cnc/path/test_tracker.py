"""The tracker's choice of a target at the edge of rounding."""

from __future__ import annotations

import numpy as np

from liftd.cnc.geo_task import GeoTask
from liftd.cnc.params import LiftMethod
from liftd.cnc.path.plan import Plan
from liftd.cnc.path.tracker import Tracker
from liftd.cnc.ruckig1 import Ruckig1
from liftd.settings import load_settings
from tests.support.paths import REPO
from tests.support.programs import nesting_program
from tests.support.scenarios import wide_scenario


def test_a_brake_whose_projected_velocity_rounds_below_zero_targets_rest_without_a_refusal() -> (
    None
):
    """A state of the 40-part nesting job under bench_step's override schedule (cycle 23 310):
    braking toward boundary 258, the velocity after ramping the acceleration to 0 computes as
    -8.7e-18 m/s. Planned as a target, ruckig1 refused it (a path never moves backwards) and the
    tracker fell back to rest: the same profile, after a refusal that cost an exception in the
    cycle (26 of them in the 500-part job, up to 200 µs each)."""
    ch = load_settings(str(REPO / "config" / "liftd.toml")).channel
    task = GeoTask(ch, nesting_program(40))
    tracker = Tracker(task.interp.table, task.interp.prod.look_ahead)
    tracker.set_inputs(1.0, False)
    tracker.set_state(
        23.309, 1.898609635519832, 0.006802381519592213, -1.4753854026218067, 257, None
    )
    tracker.advance(23.310, 0.001)
    assert tracker.last_error == ""  # nothing was refused on the way
    assert tracker.errors == 0
    plan = tracker.plan
    assert plan is not None and plan.goal == 258 and plan.v_end == 0.0  # rest at the boundary
    assert tracker.v >= 0.0


def test_a_target_reached_from_a_kink_lands_on_the_next_one_without_a_position_step() -> None:
    """Path-based wide seed 410: inside a lift range over 0.2 mm polyline blocks the path crawls
    at ~5 mm/s, accelerating from kink to kink (each a run boundary, zero acceleration there).
    The target velocity at the next kink was the one reachable within the distance plus the
    slack tolerance (1 nm): ruckig accepted it and ended 1 nm past the kink, the tracker put
    the path back on it, and that 1 nm step, 1 m/s³ of path jerk at a 1 ms cycle, took the
    coupled Z (dz/ds ≈ 39) to 1.28 × its jerk limit. Every 4 cycles' finite-difference jerk of
    s stays within the highest jerk limit of the segments they span."""
    sc = wide_scenario(410, LiftMethod.LIFTING)
    task = GeoTask(sc.channel, sc.text)
    tb = task.interp.table
    tracker = Tracker(tb, task.interp.prod.look_ahead)
    tracker.set_inputs(1.0, False)
    tracker.set_state(0.0, tb.s[300], 0.0, 0.0, 300, None)
    dt = 0.001
    s, seg = [tracker.s], [tracker.seg]
    while tracker.seg < 330:
        tracker.advance(len(s) * dt, dt)
        s.append(tracker.s)
        seg.append(tracker.seg)
    assert tracker.errors == 0
    jerk = np.diff(np.array(s), 3) / dt**3
    limit = [
        max(tb.run_j[tb.run[k]] for k in range(seg[n], seg[n + 3] + 1)) for n in range(len(jerk))
    ]
    assert float(np.max(np.abs(jerk) / np.array(limit))) <= 1.0 + 1e-6


def test_a_profile_shorter_than_the_clocks_rounding_is_read_at_its_end() -> None:
    """Feeds seed 601: a brake at once ended 0.68 nm before a feed boundary at its cap, and
    the target profile from there lasts 1.8e-16 s, so t0 + dur rounds to t0. Read at that
    time as at its start, the step never reached the goal and planned it again, 100 000
    times in one cycle ("advance did not converge", 29 tracker errors). At its end time the
    plan is at its goal."""
    s, v, a = 0.3342277688276352, 0.09181006777942181, -7.016609515630989e-14
    s_goal, v_goal = 0.33422776950933675, 0.09181006777938826
    traj = Ruckig1().position(s, v, a, s_goal, v_goal, 0.108055, 8.0012, 400.06)
    t0 = 6.512695552902414
    plan = Plan(traj, t0, 10, 41, s_goal, v_goal)
    assert plan.dur > 0.0 and t0 + plan.dur == t0  # the case: shorter than t0's rounding
    assert plan.at(t0 + plan.dur) == (s_goal, v_goal, 0.0)
