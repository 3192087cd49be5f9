"""A repeated program (`[program] repeat`, or START after program end) starts from where the
last run ended, without decoding and planning it again inside the GEO cycle when a prepared
program for that start exists, and runs exactly as a fresh task started there."""

from __future__ import annotations

import itertools

from liftd.cnc.geo_task import GeoTask
from liftd.cnc.params import LiftMethod
from liftd.cnc.plc import Schedule, SimPlc
from liftd.cnc.snapshot import ChannelState, Command, GeoInputs, GeoSnapshot
from tests.support.channel import make_channel
from tests.support.paths import REPO
from tests.support.programs import nesting_program

DEMO = (REPO / "config" / "programs" / "demo.nc").read_text()
START = GeoInputs(command=Command.START)


def run_once(task: GeoTask, k0: int, dt: float) -> tuple[int, list[GeoSnapshot]]:
    """Step from cycle k0 + 1 until the program ends; START in the first cycle."""
    plc, out, k = SimPlc(0.02), [], k0
    last: GeoSnapshot | None = None
    while True:
        k += 1
        inputs = START if k == k0 + 1 else plc.inputs(last, k * dt, Schedule())
        last = task.step(inputs, k * dt)
        out.append(last)
        if last.state is not ChannelState.ACTIVE and k > k0 + 1:
            return k, out


def assert_same_run(got: list[GeoSnapshot], want: list[GeoSnapshot]) -> None:
    assert len(got) == len(want)
    for g, w in zip(got, want, strict=True):  # the same run, cycle for cycle
        assert g._replace(cycle=0, events=()) == w._replace(cycle=0, events=()), g.t


def test_a_repeat_from_the_prepared_end_position_loads_nothing_and_equals_a_fresh_start() -> None:
    """Runs 2 and 3 start on a state built ahead (before the loop, and in the cycles after
    the previous START, while what that START replaced is released a few objects a cycle):
    each is the run a fresh task started there makes, bit for bit."""
    nesting = nesting_program(12)  # 11 lift records and a long queue to release in a run
    for method, text, lifts in (
        (LiftMethod.ADVANCED, DEMO, 5),
        (LiftMethod.LIFTING, DEMO, 5),
        (LiftMethod.ADVANCED, nesting, 11),
    ):
        ch = make_channel(method, lift_min_dist=0.005)
        dt = ch.cycle_time
        task = GeoTask(ch, text, autostart=False)
        task.prepare_next_run()  # what the loop does before it starts cycling
        assert task.programs.loads == 2
        built = task.next_runs.ahead
        k, first = run_once(task, 0, dt)
        assert (
            task.next_runs.ahead is built
        )  # run 2's state, built before the loop, was kept for it
        end = first[-1]
        assert end.state is ChannelState.READY
        assert (
            max(abs(a - b) for a, b in zip(end.positions, task.prog.path.end_position, strict=True))
            <= 1e-9
        )
        for run in (2, 3):
            assert task.next_run_ready, (method, run)  # START only swaps it in
            k0 = k
            k, again = run_once(task, k0, dt)
            assert task.programs.loads == 2, method  # the repeat decoded nothing in the cycle
            assert again[-1].state is ChannelState.READY and task.runs == run
            fresh = GeoTask(ch, text, autostart=False, start_position=end.positions)
            _, expected = run_once(fresh, k0, dt)
            assert_same_run(again, expected)
            assert sum(1 for s in again for e in s.events if e.name == "lift.start") == lifts


def test_a_start_from_elsewhere_prepares_the_program_for_that_position() -> None:
    ch = make_channel()
    task = GeoTask(ch, DEMO, autostart=False)
    k, first = run_once(task, 0, ch.cycle_time)
    assert task.programs.loads == 1
    _, second = run_once(task, k, ch.cycle_time)  # not prepared: decoded at START
    assert task.programs.loads == 2 and second[-1].state is ChannelState.READY
    _, third = run_once(task, k + len(second), ch.cycle_time)
    assert task.programs.loads == 2  # prepared by the second run's START
    assert len(third) == len(second)  # the same run again, an other time base (rounding only)
    # the tracker decides at sub-cycle instants against slack margins: rounding of the later
    # time base may shift a decision by ulps, which shows as nanometres, never more
    assert (
        max(
            abs(a - b)
            for s3, s2 in zip(third, second, strict=True)
            for a, b in zip(s3.positions, s2.positions, strict=True)
        )
        < 1e-8
    )


def test_a_task_created_mid_run_starts_its_path_in_its_first_cycle() -> None:
    """After a SIGHUP reload the loop builds a new task at t ≫ 0 and starts it at once: the
    path must start in that cycle, not at t = 0 (which ran seconds of path in one cycle)."""
    ch = make_channel()
    task = GeoTask(ch, DEMO, autostart=False, start_position=(0.02, 0.02, 0.05))
    _, snaps = run_once(task, 14_110, ch.cycle_time)
    first = snaps[0].positions
    assert max(abs(a - b) for a, b in zip(first, (0.02, 0.02, 0.05), strict=True)) < 1e-6
    steps = [
        max(abs(a - b) for a, b in zip(p.positions, q.positions, strict=True))
        for p, q in itertools.pairwise(snaps)
    ]
    assert max(steps) <= max(ax.v_max for ax in ch.axes) * ch.cycle_time * (1 + 1e-9)
