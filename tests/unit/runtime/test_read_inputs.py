"""What one GEO cycle reads of the PLC's writes (issue 41): at most INPUTS_PER_CYCLE off the
input ring, levels collapsing to the last one, commands in order and never more than BACKLOG
waiting per channel; the rest waits in the ring (whose full state is the daemon's 0x708)."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from liftd.cnc.snapshot import PlcSignal, PlcWrite
from liftd.runtime.geo_loop import BACKLOG, INPUTS_PER_CYCLE, GeoLoop, _Events
from liftd.runtime.loop_config import ChannelConfig, LoopConfig
from liftd.runtime.records import EventReader, pack_input
from liftd.runtime.shared import Shared
from tests.support.channel import make_channel
from tests.support.paths import REPO


@pytest.fixture
def loop() -> Iterator[GeoLoop]:
    ch = make_channel()
    shared = Shared(len(ch.axes))
    text = (REPO / "config" / "programs" / "demo.nc").read_text()
    cfg = LoopConfig(channels=(ChannelConfig(ch, text, "demo", autostart=False),))
    geo = GeoLoop(shared, cfg, _Events(shared.events), -1)
    try:
        yield geo
    finally:
        geo.preparer.close()
        shared.close()


def events(loop: GeoLoop) -> list[tuple[float, str, float]]:
    return [(ev.t, ev.text, ev.value) for ev in EventReader().feed(loop.shared.events.take())]


def test_a_burst_of_level_writes_is_read_a_bounded_number_a_cycle(loop: GeoLoop) -> None:
    n = 100
    for k in range(n):
        assert loop.shared.inputs.put(pack_input(PlcWrite(PlcSignal.OVERRIDE, (500 + k) / 1000)))
    cycles = []
    while loop.read_inputs(len(cycles) + 1.0):
        got = events(loop)
        assert len(got) <= INPUTS_PER_CYCLE
        cycles.append(got)
        loop.plcs[0].take()
    assert len(cycles) == -(-n // INPUTS_PER_CYCLE)
    values = [round(v * 1000) for c in cycles for _, _, v in c]
    assert values == list(range(500, 500 + n))  # every write, in order
    assert loop.plcs[0].override == (500 + n - 1) / 1000  # the last one in effect


def test_commands_wait_in_the_ring_beyond_the_backlog(loop: GeoLoop) -> None:
    plc = loop.plcs[0]
    signals = [PlcSignal.START, PlcSignal.STOP] * 10
    for sig in signals:
        loop.shared.inputs.put(pack_input(PlcWrite(sig, 1.0)))
    delivered = []
    for cycle in range(100):
        loop.read_inputs(cycle + 1.0)
        assert plc.backlog <= BACKLOG
        plc.take()
        cmd = plc.inputs(None, cycle + 1.0).command
        if cmd.value:
            delivered.append(cmd.name)
    assert delivered == [s.name for s in signals]  # none lost, none reordered
