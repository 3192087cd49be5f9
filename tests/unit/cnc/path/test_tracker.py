"""The tracker's choice of a target at the edge of rounding."""

from __future__ import annotations

from liftd.cnc.geo_task import GeoTask
from liftd.cnc.path.tracker import Tracker
from liftd.settings import load_settings
from tests.support.paths import REPO
from tests.support.programs import nesting_program


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
