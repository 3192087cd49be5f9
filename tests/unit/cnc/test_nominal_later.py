"""The nominal run of a lift range (path_delay_s) takes its step of an event's cycle one cycle
later (`Interpolator.nominal_step`): an override write during a range re-plans the path, and
its nominal run's re-plan was up to 40 % of that cycle with cold caches. The same calls in the
same order, one cycle later, so every cycle and every lift record is what it was with the
step in the event's cycle, also where the range ends or the next one starts right after."""

from __future__ import annotations

from liftd.cnc.geo_task import GeoTask
from liftd.cnc.lift.controller import LiftRecord
from liftd.cnc.plc import Schedule, SimPlc
from liftd.cnc.snapshot import ChannelState, GeoSnapshot
from liftd.settings import load_settings
from tests.support.paths import REPO
from tests.support.programs import nesting_program

CH = load_settings(str(REPO / "config" / "liftd.toml")).channel
DEMO = (REPO / "config" / "programs" / "demo.nc").read_text()


def _run(
    text: str, schedule: Schedule, at_once: bool
) -> tuple[list[GeoSnapshot], list[LiftRecord], int, int]:
    """Snapshots, lift records, and the nominal run's ruckig solves in the cycles of override
    writes that re-planned the path and in the cycles after them; `at_once`: its step made
    in the event's cycle, as before."""
    task = GeoTask(CH, text)
    plc, last, dt = SimPlc(0.02), None, CH.cycle_time
    snaps: list[GeoSnapshot] = []
    in_write = after_write = 0
    wrote = False
    for k in range(1, 2_000_000):
        ip = task.interp
        ip.nominal_later = not at_once
        inputs = plc.inputs(last, k * dt, schedule)
        write = last is not None and inputs.override != last.override_requested
        sh = ip._shadow
        calls = sh.calc.calls if sh is not None else 0
        restarts = ip.restarts
        last = task.step(inputs, k * dt)
        solves = sh.calc.calls - calls if sh is not None and task.interp is ip else 0
        # a write the path re-planned for (one the lift's override rule cut to the override
        # in effect re-plans only the nominal run, which is then the cycle's one re-plan)
        write = write and ip.restarts != restarts
        if write:
            in_write += solves
        elif wrote:
            after_write += solves
        wrote = write
        snaps.append(last)
        if last.state is not ChannelState.ACTIVE and k > 1:
            return snaps, list(task.lift.records), in_write, after_write
    raise AssertionError("the program did not end")


def _writes(every: float, count: int) -> Schedule:
    steps = (0.6, 0.8, 1.0, 1.5, 2.0, 1.2)
    return Schedule(
        override=tuple((every * (k + 1) - 0.0004, steps[k % len(steps)]) for k in range(count))
    )


def _records(records: list[LiftRecord]) -> list[tuple[object, ...]]:
    return [
        (r.t_start, r.t_end, r.departure, r.nominal_time, r.path_delay, r.waits) for r in records
    ]


def test_an_override_write_in_a_range_leaves_the_nominal_run_to_the_next_cycle() -> None:
    schedule = _writes(0.02, 700)  # a write every 20 ms: in every phase of every lift
    later, later_recs, in_write, after_write = _run(DEMO, schedule, at_once=False)
    at_once, at_once_recs, in_write_before, _ = _run(DEMO, schedule, at_once=True)
    assert later == at_once
    assert _records(later_recs) == _records(at_once_recs)
    assert all(r.nominal_time > 0.0 for r in later_recs if r.range.k_end > r.range.k_start)
    assert in_write_before > 10  # the nominal run re-planned in the writes' cycles …
    assert in_write == 0  # … and now in the cycles after them
    assert after_write >= in_write_before


def test_ranges_back_to_back_with_writes_and_holds_report_the_same_delays() -> None:
    # 12 parts: each lift ends and the next starts within a few cycles of writes and holds
    steps = (0.6, 0.8, 1.0, 1.5, 2.0, 0.0, 1.2)
    override = tuple((0.013 + 0.137 * k, steps[k % len(steps)]) for k in range(200))
    holds = tuple((0.9 + 1.3 * k, 0.9 + 1.3 * k + 0.05) for k in range(20))
    schedule = Schedule(override=override, feed_hold=holds)
    text = nesting_program(12)
    later, later_recs, _, _ = _run(text, schedule, at_once=False)
    at_once, at_once_recs, _, _ = _run(text, schedule, at_once=True)
    assert later == at_once
    assert len(later_recs) == 11
    assert _records(later_recs) == _records(at_once_recs)
