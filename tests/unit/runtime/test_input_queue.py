"""PLC writes over ADS reach the GEO loop through a bounded queue: the writer never waits, a
full queue answers ADS 0x708 (device busy) and nothing queued is lost or reordered."""

from __future__ import annotations

import struct

import pytest

from liftd.ads.errors import AdsError
from liftd.cnc.snapshot import PlcSignal, PlcWrite
from liftd.runtime.records import unpack_input
from liftd.runtime.shared import INPUT_CAPACITY
from liftd.service.daemon import Daemon
from liftd.settings import load_settings
from tests.support.paths import REPO


def test_a_full_input_queue_answers_0x708_and_keeps_what_it_holds() -> None:
    daemon = Daemon(load_settings(str(REPO / "config" / "liftd.toml")), None, None, None)
    try:
        sym = daemon.provider.find_symbol("PLC.ch1.override")

        def write(per_mille: int) -> None:
            daemon.provider.write(sym.index_group, sym.index_offset, struct.pack("<H", per_mille))

        for i in range(INPUT_CAPACITY):  # the loop is not draining (not started)
            write(i)
        with pytest.raises(AdsError) as err:
            write(1999)
        assert err.value.code == 0x708
        drained = []
        while (raw := daemon.shared.inputs.get()) is not None:  # what the loop does per cycle
            drained.append(unpack_input(raw))
        assert {w.signal for w in drained} == {PlcSignal.OVERRIDE}
        assert [round(w.value * 1000) for w in drained] == list(range(INPUT_CAPACITY))  # in order
        write(1500)  # drained: accepted again
        assert unpack_input(daemon.shared.inputs.get() or b"") == PlcWrite(PlcSignal.OVERRIDE, 1.5)
    finally:
        daemon.shared.close()
