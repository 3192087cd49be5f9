"""The ADS server as pyads (Beckhoff's AdsLib inside) sees it: a real server on a free
loopback port, the real client, every access path a PLC programmer uses."""

from __future__ import annotations

import struct
import threading
import time
from collections.abc import Callable, Iterator

import pyads
import pytest

from liftd.cnc.snapshot import PlcSignal, PlcWrite
from tests.support.ads_harness import Harness
from tests.support.channel import make_channel
from tests.support.wait import wait_for

pytestmark = pytest.mark.integration


@pytest.fixture
def served() -> Iterator[tuple[Harness, pyads.Connection]]:
    with Harness(make_channel()) as h:
        plc = pyads.Connection(h.net_id, 551, h.address)
        plc.open()
        try:
            yield h, plc
        finally:
            plc.close()


def ads_code(fn: Callable[[], object]) -> int:
    with pytest.raises(pyads.ADSError) as err:
        fn()
    return int(err.value.err_code)


def test_read_by_index_group_and_offset(served: tuple[Harness, pyads.Connection]) -> None:
    h, plc = served
    assert plc.read(0x121301, 0x30095, pyads.PLCTYPE_BOOL) is False
    h.set(lift_active=True, lift_suppressed=True)
    assert plc.read(0x121301, 0x30095, pyads.PLCTYPE_BOOL) is True
    assert plc.read(0x121301, 0x30094, pyads.PLCTYPE_BOOL) is True
    assert plc.read(0x21301, 0x30095, pyads.PLCTYPE_BOOL) is True  # index based
    assert plc.read(0x121301, 0x15, pyads.PLCTYPE_LREAL) == 250_000.0
    assert plc.read(0x121401, 0x30095, pyads.PLCTYPE_STRING) == "lift_active"
    assert plc.read(0x121501, 0x30095, pyads.PLCTYPE_STRING) == "BOOLEAN"
    assert plc.read(0x121601, 0x30095, pyads.PLCTYPE_UDINT) == 1
    assert plc.read(0x121801, 0x30095, pyads.PLCTYPE_BOOL) is False
    assert plc.read_device_info()[0] == "liftd GEO" and plc.read_state() == (5, 0)


def test_by_name_lists_and_writes(served: tuple[Harness, pyads.Connection]) -> None:
    h, plc = served
    h.set(lift_active=True, positions=(0.1, 0.02, 0.0415))
    assert plc.read_by_name("GEO.ch1.Z.lift_active", pyads.PLCTYPE_BOOL) is True
    assert plc.read_by_name("gpAx[3].ipo_state.lift_active") is True  # type from 0xF009
    names = [
        "GEO.ch1.Z.lift_active",
        "GEO.ch1.Z.command_position",
        "GEO.ch1.path_velocity",
        "GEO.ch1.override",
        "GEO.cycle",
    ]
    assert plc.read_list_by_name(names) == {
        "GEO.ch1.Z.lift_active": True,
        "GEO.ch1.Z.command_position": 415_000,  # 0.1 µm
        "GEO.ch1.path_velocity": 250_000.0,  # µm/s
        "GEO.ch1.override": 1000,  # 0.1 %
        "GEO.cycle": 1,
    }
    plc.write_by_name("PLC.ch1.override", 1250, pyads.PLCTYPE_UINT)
    plc.write_list_by_name({"PLC.ch1.feed_hold": True, "PLC.ch1.start": True})
    assert h.writes == [
        PlcWrite(PlcSignal.OVERRIDE, 1.25),
        PlcWrite(PlcSignal.FEED_HOLD, 1.0),
        PlcWrite(PlcSignal.START, 1.0),
    ]
    symbols = plc.get_all_symbols()  # 0xF00F + 0xF00B upload
    assert {"GEO.ch1.Z.lift_active", "PLC.ch1.override"} <= {s.name for s in symbols}


def test_error_codes_as_pyads_reports_them(served: tuple[Harness, pyads.Connection]) -> None:
    h, plc = served
    assert ads_code(lambda: plc.read(0x121301, 0x30097, pyads.PLCTYPE_BOOL)) == 0x703
    assert ads_code(lambda: plc.read(0x121302, 0x30095, pyads.PLCTYPE_BOOL)) == 0x702
    assert ads_code(lambda: plc.read(0x121301, 0x15, pyads.PLCTYPE_UDINT)) == 0x705
    assert ads_code(lambda: plc.write(0x121301, 0x30095, True, pyads.PLCTYPE_BOOL)) == 0x704
    assert ads_code(lambda: plc.read_by_name("GEO.nothing", pyads.PLCTYPE_BOOL)) == 0x710
    h.view = None  # GEO task down
    assert plc.read_state() == (6, 0)
    assert ads_code(lambda: plc.read(0x121301, 0x30095, pyads.PLCTYPE_BOOL)) == 0x707


def test_ams_errors_for_foreign_ports_and_net_ids() -> None:
    with Harness(make_channel()) as h:
        other_port = pyads.Connection(h.net_id, 552, h.address)
        other_port.open()
        try:
            assert ads_code(other_port.read_state) == 0x6
        finally:
            other_port.close()
        foreign = pyads.Connection("10.99.99.99.1.1", 551, h.address)
        foreign.open()
        try:
            assert ads_code(foreign.read_state) == 0x7
        finally:
            foreign.close()


@pytest.mark.parametrize("by_name", [False, True])
def test_on_change_notifications(served: tuple[Harness, pyads.Connection], by_name: bool) -> None:
    h, plc = served
    got: list[bool] = []
    lock = threading.Lock()

    def callback(notification: object, name: str) -> None:
        _, _, value = plc.parse_notification(notification, pyads.PLCTYPE_BOOL)
        with lock:
            got.append(bool(value))

    attr = pyads.NotificationAttrib(1, trans_mode=pyads.ADSTRANS_SERVERONCHA, cycle_time=2)
    target = "GEO.ch1.Z.lift_active" if by_name else (0x121301, 0x30095)
    handles = plc.add_device_notification(target, attr, callback)  # type: ignore[arg-type]
    try:
        assert wait_for(lambda: got == [False])  # the value at subscription
        for value in (True, False, True):
            h.set(lift_active=value)
            assert wait_for(lambda v=value: bool(got) and got[-1] is v)  # type: ignore[misc]
            time.sleep(0.01)  # ≥ 2 notification cycles: on-change sends nothing new
        assert got == [False, True, False, True]
    finally:
        plc.del_device_notification(*handles)


def test_several_clients_at_once(served: tuple[Harness, pyads.Connection]) -> None:
    h, first = served
    others = [pyads.Connection(h.net_id, 551, h.address) for _ in range(3)]
    for c in others:
        c.open()  # several AMS ports of one process share the TCP connection (AdsLib)
    errors: list[BaseException] = []

    def hammer(conn: pyads.Connection) -> None:
        try:
            for _ in range(200):
                assert conn.read(0x121301, 0x10, pyads.PLCTYPE_UDINT) == 100_000
        except BaseException as exc:
            errors.append(exc)

    threads = [threading.Thread(target=hammer, args=(c,)) for c in [first, *others]]
    for t in threads:
        t.start()
    for t in threads:
        t.join(30)
    for c in others:
        c.close()
    assert not errors
    value = struct.unpack("<I", struct.pack("<I", 100_000))[0]
    assert first.read(0x121301, 0x10, pyads.PLCTYPE_UDINT) == value
