"""The machine: every channel of the start-up list in one GEO cycle, each on its own (issue 18
item 1). Virtual clock, plain loops."""

from __future__ import annotations

import dataclasses

import pytest

from liftd.cnc.geo_task import GeoTask
from liftd.cnc.machine import ChannelProgram, Machine, check_channels
from liftd.cnc.plc import Schedule, SimPlc
from liftd.cnc.snapshot import ChannelState, GeoSnapshot
from liftd.sim.simulate import simulate, simulate_machine
from tests.support.channel import make_channel, make_second_channel

CUT = """N10 G01 X300 Y0 F6000
N20 M30
"""
# head 2 travels with its lift while head 1 cuts (W lifts, path-based)
LIFT = """N10 W[LIFT_START POS=1 POS_LIMIT=40]
N20 G01 U400 V40 F24000
N30 W[LIFT_END]
N40 M30
"""


def run(machine: Machine, cycles: int) -> list[list[GeoSnapshot]]:
    plcs = [SimPlc(0.02) for _ in machine.tasks]
    last: list[GeoSnapshot | None] = [None] * len(machine)
    out = []
    for k in range(1, cycles + 1):
        t = k * machine.cycle_time
        inputs = [plc.inputs(s, t, Schedule()) for plc, s in zip(plcs, last, strict=True)]
        snaps = machine.step(inputs, t)
        last = list(snaps)
        out.append(snaps)
    return out


def test_a_lift_in_channel_2_while_channel_1_cuts() -> None:
    machine = Machine(
        [ChannelProgram(make_channel(), CUT), ChannelProgram(make_second_channel(), LIFT)]
    )
    cycles = run(machine, 400)
    lifting = [c for c in cycles if c[1].lift_active]
    assert lifting, "channel 2 never lifted"
    for ch1, ch2 in lifting:
        assert ch1.state is ChannelState.ACTIVE and ch1.v_path > 0.0  # head 1 cuts on
        assert not ch1.lift_active and not ch1.lift_suppressed
        assert ch2.lift_axis == 2  # W, channel 2's third axis
        assert ch1.t == ch2.t  # one cycle, one time
    assert max(c[1].positions[2] for c in cycles) > 0.005  # W rose
    assert max(abs(c[0].positions[2]) for c in cycles) == 0.0  # Z did not move


def test_each_channel_runs_as_it_would_alone() -> None:
    """Channel order and the other channel change nothing: bit-identical snapshots."""
    ch1, ch2 = make_channel(), make_second_channel()
    machine = Machine([ChannelProgram(ch2, LIFT), ChannelProgram(ch1, CUT)])  # given out of order
    assert machine.channel_ids == (1, 2)
    cycles = run(machine, 600)
    for index, (ch, text) in enumerate(((ch1, CUT), (ch2, LIFT))):
        task, plc = GeoTask(ch, text), SimPlc(0.02)
        last = None
        for k, snaps in enumerate(cycles, start=1):
            t = k * 1e-3
            last = task.step(plc.inputs(last, t, Schedule()), t)
            assert last == snaps[index]


def test_simulate_machine_gives_each_channel_its_own_summary() -> None:
    ch1, ch2 = make_channel(), make_second_channel()
    both = simulate_machine([(ch1, CUT), (ch2, LIFT)], [Schedule(), Schedule()], 0.02, [None, None])
    for (ch, text), result in zip(((ch1, CUT), (ch2, LIFT)), both, strict=True):
        alone = simulate(ch, text, Schedule(), 0.02)
        assert result.finished
        assert dataclasses.replace(result.summary, step_cpu_us=alone.summary.step_cpu_us) == (
            alone.summary
        )
    assert len(both[1].summary.lifts) == 1 and not both[0].summary.lifts


def test_an_idle_channel_without_a_program() -> None:
    results = simulate_machine(
        [(make_channel(), CUT), (make_second_channel(), "")],
        [Schedule(), Schedule()],
        0.02,
        [None, None],
    )
    assert results[0].finished and results[0].summary.cycles > 100
    assert results[1].summary.cycles == 0


def test_machine_rules() -> None:
    ch1 = make_channel()
    with pytest.raises(ValueError, match="logical axis 3"):  # channel 2's U is Z
        check_channels([ch1, make_second_channel(first_axis=3)])
    with pytest.raises(ValueError, match="twice"):
        check_channels([ch1, dataclasses.replace(make_second_channel(), channel_id=1)])
    with pytest.raises(ValueError, match="same GEO cycle"):
        check_channels([ch1, dataclasses.replace(make_second_channel(), cycle_time=2e-3)])
    with pytest.raises(ValueError):
        check_channels([])
    machine = Machine([ChannelProgram(ch1, CUT), ChannelProgram(make_second_channel(), LIFT)])
    assert machine.index_of(2) == 1
    with pytest.raises(ValueError):
        machine.replace(0, GeoTask(make_second_channel(), ""))
