"""The cycle checker (tests/support/cycle_check.py) reads the lift axis from the channel: a
scenario whose axes are listed Z first is as good as the one with Z third, and a Z pushed
beyond its software limit or a lift range's POS_LIMIT is found on whichever axis it is."""

from __future__ import annotations

import dataclasses

import pytest

from liftd.cnc.params import LiftMethod
from liftd.cnc.snapshot import GeoSnapshot
from tests.support.closed_loop import run_task
from tests.support.cycle_check import violations
from tests.support.scenarios import Scenario, describe, scenario


def z_first(sc: Scenario) -> Scenario:
    x, y, z = sc.channel.axes
    return dataclasses.replace(sc, channel=dataclasses.replace(sc.channel, axes=(z, x, y)))


def raised(snaps: list[GeoSnapshot], axis: int, by: float, t0: float) -> list[GeoSnapshot]:
    out = []
    for s in snaps:
        p = list(s.positions)
        if s.t >= t0:
            p[axis] += by
        out.append(s._replace(positions=tuple(p)))
    return out


@pytest.mark.parametrize("seed", [0, 1])
def test_a_channel_with_the_lift_axis_first_is_checked_on_it(seed: int) -> None:
    sc = z_first(scenario(seed))
    assert sc.channel.lift_axis_index == 0
    task, snaps = run_task(sc.channel, sc.text, sc.schedule)
    assert violations(sc, snaps, task.lift.records) == [], describe(sc)
    # Z held 1 mm above its positive software limit from mid-run on (a step: v, a, j too)
    z_top = sc.channel.axes[0].sw_limit_pos
    bad = raised(snaps, 0, z_top + 1e-3 - min(s.positions[0] for s in snaps), snaps[-1].t / 2)
    found = violations(sc, bad, task.lift.records)
    assert "software limit" in found and any(f.startswith("Z |v|") for f in found), found


def test_a_lift_above_pos_limit_is_found_on_its_axis() -> None:
    sc = z_first(scenario(3))
    task, snaps = run_task(sc.channel, sc.text, sc.schedule)
    rec = task.lift.records[0]
    spec = rec.range.start
    over = max(spec.pos_limit, spec.target, rec.z_start) + 1e-4 - spec.pos_limit
    bad = [
        s._replace(positions=(s.positions[0] + over, *s.positions[1:]))
        if rec.t_start <= s.t <= rec.t_end
        else s
        for s in snaps
    ]
    found = violations(sc, bad, task.lift.records)
    assert f"POS_LIMIT exceeded in lift line {spec.line}" in found, found


@pytest.mark.parametrize("seed", [174, 197])
def test_the_lift_axis_as_a_path_axis_may_take_a_transition_s_jump(seed: int) -> None:
    """Before its first range Z moves with the path; it arrives at the range's kink at the
    transition's cap and stops as the range starts: a block transition not wholly inside a
    range, judged as a path axis (issue 36). The same jerk inside a range is still found."""
    sc = scenario(seed, LiftMethod.LIFTING)
    task, snaps = run_task(sc.channel, sc.text, sc.schedule)
    assert violations(sc, snaps, task.lift.records) == [], describe(sc)
    rec = task.lift.records[0]
    mid = (rec.t_start + rec.t_end) / 2  # a 0.1 mm step of Z inside the range
    k = sc.channel.lift_axis_index
    assert any(
        "|j| ratio" in v for v in violations(sc, raised(snaps, k, 1e-4, mid), task.lift.records)
    )
