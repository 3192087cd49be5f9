"""Access control of the running daemon, configured in liftd.toml: refused peers and NetIds get
what the config says and are logged with peer and NetId, rate-limited; read-only NetIds cannot
write; the shipped configuration is reachable from loopback only."""

from __future__ import annotations

import struct
import time
import tomllib
from pathlib import Path

import pytest

from liftd.ads import wire
from liftd.ads.client import RawClient
from liftd.ads.wire import net_id_bytes
from liftd.settings.model import AdsSection
from tests.support.daemon import Daemon, write_config
from tests.support.paths import REPO
from tests.support.wait import wait_for

pytestmark = pytest.mark.integration
LIFT = struct.pack("<III", 0x121301, 0x30095, 1)
PLC = "10.1.2.3.1.1"
VIEWER = "10.5.5.5.1.1"
STRANGER = bytes([10, 9, 9, 9, 1, 1])


def events(d: Daemon, name: str) -> list[dict[str, object]]:
    return [rec for rec in d.logs if rec.get("event") == name]


def write_override(c: RawClient, value: int) -> int:
    """As pyads' write_by_name: a handle by name (0xF003), then a write by handle (0xF005)."""
    name = b"PLC.ch1.override\0"
    reply = c.request(9, struct.pack("<IIII", 0xF003, 0, 4, len(name)) + name)
    code, raw = wire.decode_read_response(reply.payload)
    assert code == 0, hex(code)
    write = struct.pack("<III", 0xF005, struct.unpack("<I", raw)[0], 2) + struct.pack("<H", value)
    return wire.decode_result(c.request(3, write).payload)


def test_peers_outside_the_allowed_ranges_are_closed_and_logged_once_per_second(
    tmp_path: Path,
) -> None:
    d = Daemon(write_config(tmp_path, ads={"allow_ips": ["10.0.0.0/8"]}))
    try:
        port = d.ready()
        for _ in range(5):
            c = RawClient(port, net_id_bytes(d.net_id))
            assert c.closed_by_server()
            c.close()
        time.sleep(0.3)
        refused = events(d, "ads.connection_refused")
        assert len(refused) == 1  # five refusals, one line: rate-limited per peer address
        assert refused[0]["reason"] == "peer IP not allowed"
        assert str(refused[0]["peer"]).startswith("127.0.0.1:")
        time.sleep(1.0)
        c = RawClient(port, net_id_bytes(d.net_id))
        assert c.closed_by_server()
        c.close()
        assert d.event("ads.connection_refused") is not None
        time.sleep(0.3)
        later = events(d, "ads.connection_refused")
        assert len(later) == 2 and later[1]["suppressed"] == 4  # what was held back is counted
    finally:
        assert d.stop() == 0


def test_netids_and_write_rights_as_configured(tmp_path: Path) -> None:
    ads = {"allow_net_ids": [PLC, VIEWER], "write_net_ids": [PLC], "reject": "error"}
    d = Daemon(write_config(tmp_path, ads=ads))
    try:
        port = d.ready()
        target = net_id_bytes(d.net_id)
        stranger = RawClient(port, target, source=STRANGER)
        assert wire.decode_read_response(stranger.request(2, LIFT).payload) == (0x723, b"")
        stranger.close()
        time.sleep(0.3)
        (rec,) = events(d, "ads.source_refused")
        assert "10.9.9.9.1.1" in str(rec["detail"]) and str(rec["peer"]).startswith("127.0.0.1")
        viewer = RawClient(port, target, source=net_id_bytes(VIEWER))
        assert write_override(viewer, 500) == 0x704
        assert viewer.read(0x121301, 0x30095, 1) == (0, b"\x00")  # reading is fine
        viewer.close()
        plc = RawClient(port, target, source=net_id_bytes(PLC))
        assert write_override(plc, 500) == 0
        assert wait_for(
            lambda: plc.read_by_name("GEO.ch1.override_requested", 2) == (0, struct.pack("<H", 500))
        )
        plc.close()
    finally:
        assert d.stop() == 0


def test_the_shipped_configuration_listens_on_loopback_only() -> None:
    shipped = tomllib.loads((REPO / "config" / "liftd.toml").read_text())["ads"]
    ads = AdsSection(**shipped)
    assert ads.host == "127.0.0.1"
    assert set(ads.allow_ips) == {"127.0.0.0/8", "::1/128"}
