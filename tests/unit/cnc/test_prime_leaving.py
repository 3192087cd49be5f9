"""The cycle in which a wait ends (an M acknowledge, the end of a dwell, Z landed at LIFT_END)
takes the profile the path leaves its stop with from a quiet cycle of the wait
(`Interpolator.prime_leaving`): that choice does not depend on when the path leaves, so a run
that throws the primed profile away before every cycle is the same run, cycle for cycle, also
where override steps, feed holds and conditional M functions acknowledged during the wait come
between the priming and the resume."""

from __future__ import annotations

import dataclasses

import pytest

from liftd.cnc.geo_task import GeoTask
from liftd.cnc.params import ChannelParams, MSync
from liftd.cnc.plc import Schedule, SimPlc
from liftd.cnc.snapshot import ChannelState, GeoSnapshot
from liftd.settings import load_settings
from tests.support.channel import make_channel
from tests.support.paths import REPO
from tests.support.programs import nesting_program

DEMO = (REPO / "config" / "programs" / "demo.nc").read_text()
CH = load_settings(str(REPO / "config" / "liftd.toml")).channel

# the waits of M functions of each acknowledged sync and of a dwell; the PLC acknowledges the
# conditional M6 (MVS_SNS) during the dwell, which changes the stops ahead of the resting path:
# the profile primed before it is made again
WAITS = """N10 G90 G01 X0 Y0 Z1 F12000
N20 M4
N30 G01 X40 F12000
N35 M6
N40 G04 X0.05
N50 X80
N60 X120 M8
N70 Z[LIFT_START POS=20 POS_LIMIT=40]
N80 X123 F30000
N90 Z[LIFT_END]
N100 X160
N110 M4 X200 F6000
N120 M5
N130 M30
"""


def _channel() -> ChannelParams:
    ch = make_channel()
    return dataclasses.replace(ch, m_synch=(*ch.m_synch, (6, MSync.MVS_SNS)))


def _run(
    ch: ChannelParams, text: str, schedule: Schedule, forget: bool
) -> tuple[list[GeoSnapshot], list[int]]:
    """Every snapshot to the program's end, and the path's ruckig solves in each cycle in which
    the path left a stop it rested at, with the cycle after it (a wait that ends at a cycle's
    time, as a dwell may, leaves in that cycle and plans in the next one); `forget`: the primed
    profile thrown away before each cycle."""
    task = GeoTask(ch, text)
    plc, last, dt = SimPlc(0.02), None, ch.cycle_time
    snaps: list[GeoSnapshot] = []
    resume_solves: list[int] = []
    leaving = -1
    for k in range(1, 2_000_000):
        ip = task.interp
        if forget:
            ip._leaving = None
        rested = ip.stopped_at is not None and task.state is ChannelState.ACTIVE
        calls = ip.prod.calc.calls
        last = task.step(plc.inputs(last, k * dt, schedule), k * dt)
        snaps.append(last)
        primed = task.interp._leaving
        # primed with its pieces read: the resume's first state is evaluated natively too
        assert primed is None or primed.plan.ev.phases is not None
        if leaving >= 0:  # the cycle after the one the path left in (a wait that ended on
            resume_solves.append(leaving + ip.prod.calc.calls - calls)  # the grid: its first)
            leaving = -1
        elif rested and task.interp is ip and ip.stopped_at is None and k > 1:
            leaving = ip.prod.calc.calls - calls
        if last.state is not ChannelState.ACTIVE and k > 1:
            return snaps, resume_solves
    raise AssertionError("the program did not end")


def test_a_wait_ends_without_a_profile_solve_the_wait_made() -> None:
    ch = _channel()
    primed_snaps, primed = _run(ch, WAITS, Schedule(), forget=False)
    unprimed_snaps, unprimed = _run(ch, WAITS, Schedule(), forget=True)
    assert primed_snaps == unprimed_snaps
    assert len(primed) == 4  # M4, the dwell (M6 acknowledged during it), M8, M4
    assert min(unprimed) >= 1  # each resume's cycle solved its profile itself
    assert [u - p for p, u in zip(primed, unprimed, strict=True)] == [1] * 4  # now one fewer


def test_a_path_waiting_for_z_at_lift_end_leaves_with_the_primed_profile() -> None:
    # a range without path motion: the path rests at LIFT_END until Z is at POS, 50 mm up
    text = "G01 X10 Y10 Z1 F6000\nZ[LIFT_START POS=51 POS_LIMIT=60]\nZ[LIFT_END]\nG01 X20\nM30\n"
    primed_snaps, primed = _run(make_channel(), text, Schedule(), forget=False)
    unprimed_snaps, unprimed = _run(make_channel(), text, Schedule(), forget=True)
    assert primed_snaps == unprimed_snaps
    assert [s.positions[2] for s in primed_snaps if s.lift_active][-1] == pytest.approx(0.051)
    assert len(primed) == 1 and primed[0] == unprimed[0] - 1


def test_the_demo_acknowledges_its_m_functions_with_the_primed_profile() -> None:
    primed_snaps, primed = _run(CH, DEMO, Schedule(), forget=False)
    unprimed_snaps, unprimed = _run(CH, DEMO, Schedule(), forget=True)
    assert primed_snaps == unprimed_snaps
    assert len(primed) == 5  # the demo's five M04 pierces
    assert [u - p for p, u in zip(primed, unprimed, strict=True)] == [1] * 5


def test_events_during_a_wait_change_no_cycle_of_the_run() -> None:
    # override steps and holds that land while the path waits at M04 (the PLC acknowledges
    # 20 ms after the wait began): the profile primed before them is not the one to leave with
    steps = (0.6, 0.8, 1.0, 1.5, 2.0, 0.0, 1.2)
    override = tuple((0.013 * (k + 1) + 0.29 * k, steps[k % len(steps)]) for k in range(60))
    holds = tuple((0.5 + 0.61 * k, 0.5 + 0.61 * k + 0.011) for k in range(25))
    schedule = Schedule(override=override, feed_hold=holds)
    text = nesting_program(12)
    primed, primed_solves = _run(CH, text, schedule, forget=False)
    unprimed, unprimed_solves = _run(CH, text, schedule, forget=True)
    assert primed == unprimed
    assert sum(primed_solves) < sum(unprimed_solves)  # the primed profiles were used
