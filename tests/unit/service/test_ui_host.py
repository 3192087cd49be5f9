"""The live view inside the daemon: a page's write is the ADS write of PLC.chN.* (same record in
the GEO loop's input ring, same refusals), and the access policy decides who may control."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator

import pytest

from liftd.ads.wire import net_id_bytes
from liftd.cnc.snapshot import PlcSignal, PlcWrite
from liftd.runtime.records import unpack_input
from liftd.service.daemon import Daemon
from liftd.service.ui_host import UiHost
from liftd.settings import load_settings
from liftd.ui.web import Refused
from tests.support.paths import REPO


@pytest.fixture
def daemon() -> Iterator[Daemon]:
    d = Daemon(load_settings(str(REPO / "config" / "liftd.toml")), None, None, None)
    try:
        yield d
    finally:
        d.shared.close()


def host(d: Daemon) -> UiHost:
    assert d.ui is not None  # the shipped configuration enables the view
    return d.ui


def test_a_page_write_is_the_ads_write(daemon: Daemon) -> None:
    ui = host(daemon)
    ui._write("PLC.ch1.override", 450)
    ui._write("plc.ch1.feed_hold", True)  # names are case-insensitive, as over ADS
    ui._write("PLC.ch1.start", True)
    got = []
    while (raw := daemon.shared.inputs.get()) is not None:
        got.append(unpack_input(raw))
    assert got == [PlcWrite(PlcSignal.OVERRIDE, 0.45), PlcWrite(PlcSignal.FEED_HOLD, 1.0),
                   PlcWrite(PlcSignal.START, 1.0)]  # fmt: skip
    assert daemon.provider.levels[(0, PlcSignal.OVERRIDE)] == 450  # read back as written


@pytest.mark.parametrize(
    ("symbol", "value", "fragment"),
    [
        ("PLC.ch1.override", 2001, "0x706"), ("PLC.ch1.override", True, "0x706"),
        ("PLC.ch1.feed_hold", 1, "0x706"), ("PLC.ch9.override", 10, "0x710"),
        ("GEO.ch1.override", 10, "only PLC"),
    ],
)  # fmt: skip
def test_refused_writes_reach_nothing(daemon: Daemon, symbol: str, value: bool | int,
                                      fragment: str) -> None:  # fmt: skip
    with pytest.raises(Refused) as exc:
        host(daemon)._write(symbol, value)
    assert fragment in str(exc.value)
    assert daemon.shared.inputs.get() is None


def test_the_access_policy_decides_who_controls(daemon: Daemon) -> None:
    ui = host(daemon)
    assert ui._policy("127.0.0.1") == ""
    assert "allow_ips" in ui._policy("192.168.1.7")
    daemon.server.config = dataclasses.replace(
        daemon.server.config, write_net_ids=frozenset({net_id_bytes("10.0.0.1.1.1")}))  # fmt: skip
    assert "write_net_ids" in ui._policy("127.0.0.1")
