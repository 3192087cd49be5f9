"""A lift start's cycle takes the work the GEO task did for it in the two cycles before
(`LiftAhead.prime`): the first rising cycle's ruckig solve and the lower bound of the path's
arrival at the lift's horizon. Both are memos of pure functions, so a run that throws them away
before every cycle is the same run, cycle for cycle, also where override steps and feed holds
discard the committed future the memos were computed on."""

from __future__ import annotations

from liftd.cnc.geo_task import GeoTask
from liftd.cnc.plc import Schedule, SimPlc
from liftd.cnc.snapshot import ChannelState, GeoSnapshot
from liftd.settings import load_settings
from tests.support.paths import REPO
from tests.support.programs import nesting_program

DEMO = (REPO / "config" / "programs" / "demo.nc").read_text()
CH = load_settings(str(REPO / "config" / "liftd.toml")).channel


def _run(text: str, schedule: Schedule, forget: bool) -> tuple[list[GeoSnapshot], list[int]]:
    """Every snapshot to the program's end, and the lift generator's ruckig solves in each
    cycle in which a lift started; `forget`: the memos thrown away before each cycle."""
    task = GeoTask(CH, text)
    plc, last, dt = SimPlc(0.02), None, CH.cycle_time
    gen = task.lift.generator(CH.lift_axis)
    snaps: list[GeoSnapshot] = []
    start_solves: list[int] = []
    for k in range(1, 2_000_000):
        if forget:
            gen.first = None
            task.interp._loose_key = (-1, -1)
        calls = gen.prof.calls
        last = task.step(plc.inputs(last, k * dt, schedule), k * dt)
        snaps.append(last)
        if any(e.name == "lift.start" and not e.text for e in last.events):
            start_solves.append(gen.prof.calls - calls)
        if last.state is not ChannelState.ACTIVE and k > 1:
            return snaps, start_solves
    raise AssertionError("the program did not end")


def test_a_lift_start_cycle_solves_nothing_the_cycles_before_it_solved() -> None:
    _, primed = _run(DEMO, Schedule(), forget=False)
    _, unprimed = _run(DEMO, Schedule(), forget=True)
    assert len(primed) == 4  # the demo's lifts that are not suppressed
    assert primed == [0, 0, 0, 0]
    assert unprimed == [1, 1, 1, 1]  # the first rising cycle's descent, solved in the cycle


def test_the_memos_change_no_cycle_of_a_run_with_override_steps_and_feed_holds() -> None:
    steps = (0.6, 0.8, 1.0, 1.5, 2.0, 0.0, 1.2)
    override = tuple((0.37 * (k + 1), steps[k % len(steps)]) for k in range(120))
    schedule = Schedule(override=override, feed_hold=((5.0, 5.5), (11.0, 11.2)))
    text = nesting_program(12)
    primed, primed_solves = _run(text, schedule, forget=False)
    unprimed, unprimed_solves = _run(text, schedule, forget=True)
    assert len(primed_solves) == 11  # one lift between each two of the 12 parts
    assert sum(primed_solves) < sum(unprimed_solves)  # the memos were used
    assert primed == unprimed
