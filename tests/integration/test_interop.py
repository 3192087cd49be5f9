"""Independent clients against one running `liftd run`, the whole session captured on loopback
and read back by Wireshark's AMS dissector (tshark): Node ads-client in default mode (router
port connect + PLC-runtime setup, symbol access) and raw mode, pyads (AdsLib) by address, by
name, lists, symbol upload, notifications and UDP discovery, and the exact requests of the Rust
`ads` crate replayed byte for byte (crates.io is not reachable here to build the crate itself).

`.ci/run` installs the tools (npm ci of tests/interop/node, Debian's tshark); a missing tool
fails these tests under CI (where `.ci/run` installed it) and skips them elsewhere.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import socket
import struct
import subprocess
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pyads
import pyads.pyads_ex
import pytest

from liftd.ads import wire
from liftd.ads.client import RawClient
from liftd.ads.wire import net_id_bytes
from tests.support.daemon import Daemon, write_config
from tests.support.paths import REPO

pytestmark = pytest.mark.integration
NODE_DIR = REPO / "tests" / "interop" / "node"
LIFT = "GEO.ch1.Z.lift_active"


def tool(name: str) -> str:
    path = shutil.which(name)
    if path is None:
        if os.environ.get("CI"):
            pytest.fail(f"{name} is missing: `.ci/run` installs it")
        pytest.skip(f"{name} is missing: `.ci/run` installs it (as root)")
    return path


def need_node_client() -> None:
    """The Node ads-client of tests/interop/node, installed by `.ci/run` (npm ci): skipped
    without it, failed under CI=1."""
    if not (NODE_DIR / "node_modules" / "ads-client").is_dir():
        missing = "tests/interop/node/node_modules is missing: `.ci/run` runs npm ci"
        if os.environ.get("CI"):
            pytest.fail(missing)
        pytest.skip(missing)


def free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class Session:
    def __init__(self, tmp: Path) -> None:
        self.udp_port = free_udp_port()
        cfg = write_config(
            tmp, program={"repeat": True}, ads={"udp_discovery": True, "udp_port": self.udp_port}
        )
        self.pcap = tmp / "session.pcapng"
        tshark = tool("tshark")  # before the daemon: a failure here left it running
        self.daemon = Daemon(cfg)
        self.port = self.daemon.ready()
        self.net_id = self.daemon.net_id
        self.capture = subprocess.Popen(
            [
                tshark,
                "-i",
                "lo",
                "-f",
                f"tcp port {self.port} or udp port {self.udp_port}",
                "-w",
                str(self.pcap),
                "-q",
            ],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
        assert self.capture.stderr is not None
        for line in self.capture.stderr:  # capturing starts with this line
            if "Capturing on" in line:
                break
        else:
            self.daemon.stop()
            pytest.fail("tshark did not start capturing")

    def node(self, mode: str, *extra: str) -> dict[str, Any]:
        node = tool("node")
        need_node_client()
        run = subprocess.run(
            [node, "session.mjs", mode, str(self.port), self.net_id, *extra],
            cwd=NODE_DIR,
            capture_output=True,
            text=True,
            timeout=60,
            check=False,
        )
        result: dict[str, Any] = json.loads(run.stdout.strip().splitlines()[-1])
        assert run.returncode == 0 and "error" not in result, (result, run.stderr)
        return result

    def stop_capture(self) -> None:
        if self.capture.poll() is None:
            time.sleep(0.3)  # the last frames reach the capture buffer
            self.capture.send_signal(signal.SIGINT)
            self.capture.wait(15)


@pytest.fixture(scope="module")
def session(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Session]:
    s = Session(tmp_path_factory.mktemp("interop"))
    try:
        yield s
    finally:
        s.stop_capture()
        assert s.daemon.stop() == 0


def test_node_ads_client_default_mode_by_symbol(session: Session) -> None:
    r = session.node("default")
    assert r["version"] == "2.1.0"
    # the router assigned the client liftd's NetId and a port of its own (port connect 0x1000)
    assert r["connection"]["localAmsNetId"] == session.net_id
    assert r["connection"]["localAdsPort"] >= 32768
    assert isinstance(r["lift_active"], bool) and isinstance(r["lift_suppressed"], bool)
    assert r["override_after"] == 750 and r["write_read_only"] == 0x704
    assert r["data_type"] == {"name": "BOOL", "size": 1, "adsDataType": 33}
    assert r["symbol"] == {
        "type": "BOOL",
        "size": 1,
        "indexGroup": 0x121301,
        "indexOffset": 0x30095,
    }
    assert 1000 in r["subscribed"]["PLC.ch1.override"]
    assert all(r["subscribed"][k] for k in (LIFT, "GEO.ch1.Z.lift_suppressed"))
    assert r["symbol_count"] > 30 and r["data_type_count"] >= 24


def test_node_ads_client_raw_mode(session: Session) -> None:
    r = session.node("raw")
    assert r["connection"] == {"localAmsNetId": "127.0.0.3.1.1", "localAdsPort": 32750}
    assert r["device"]["deviceName"] == "liftd GEO" and r["state"]["adsState"] == 5
    assert r["handle"] == {"size": 1, "dataType": "BOOL"}  # the extended 0xF003 reply
    assert r["handle_multi"] == [1, 1, 0x710]
    assert r["sum_read"][2] == 0x703 and r["raw_by_path"] == 1000 and r["subscribe_raw"]
    # no size given: ads-client asks 0xFFFFFFFF and gets the BOOL's one byte per sample
    assert r["subscribe_unknown_size"][0] == 1


def test_pyads_session_and_udp_discovery(session: Session, monkeypatch: pytest.MonkeyPatch) -> None:
    plc = pyads.Connection(session.net_id, 551, session.daemon.address)
    plc.open()
    try:
        assert plc.read_state() == (5, 0) and plc.read_device_info()[0] == "liftd GEO"
        assert plc.read(0x121301, 0x30095, pyads.PLCTYPE_BOOL) in (True, False)
        assert plc.read_by_name(LIFT) in (True, False)  # type from 0xF009
        values = plc.read_list_by_name([LIFT, "GEO.ch1.Z.lift_suppressed", "GEO.cycle"])
        assert values["GEO.cycle"] > 0
        plc.write_by_name("PLC.ch1.override", 1000, pyads.PLCTYPE_UINT)
        symbols = plc.get_all_symbols()  # 0xF00F + 0xF00B
        assert any(s.name == LIFT for s in symbols)
        seen: list[object] = []
        attr = pyads.NotificationAttrib(1, trans_mode=pyads.ADSTRANS_SERVERONCHA)
        handles = plc.add_device_notification(LIFT, attr, lambda n, name: seen.append(n))
        end = time.monotonic() + 3
        while not seen and time.monotonic() < end:
            time.sleep(0.01)
        plc.del_device_notification(*handles)
        assert seen
    finally:
        plc.close()
    monkeypatch.setattr(pyads.pyads_ex, "PORT_REMOTE_UDP", session.udp_port)
    assert pyads.pyads_ex.adsGetNetIdForPLC("127.0.0.1") == session.net_id


def test_rust_ads_crate_requests_replayed(session: Session) -> None:
    """The requests of birkenfeld/ads-rs 0.5 (`src/symbol.rs`, `src/client.rs`), with its own
    strict expectations: read_exact lengths, type-entry version 1, offset 0."""
    c = RawClient(session.port, net_id_bytes(session.net_id))
    try:
        code, info = c.read(0xF00F, 0, 64)  # get_symbol_info: exactly 64 bytes
        assert code == 0 and len(info) == 64
        sym_len, type_len = (
            struct.unpack_from("<I", info, 4)[0],
            struct.unpack_from("<I", info, 12)[0],
        )
        code, types = c.read(0xF00E, 0, type_len)
        assert code == 0 and len(types) == type_len
        pos = 0
        while pos < len(types):  # decode_type_info
            size, version, _, _, _, offset = struct.unpack_from("<IIIIII", types, pos)
            assert version == 1 and offset == 0
            pos += size
        code, symbols = c.read(0xF00B, 0, sym_len)
        assert code == 0 and len(symbols) == sym_len
        # get_location / get_size: 0xF007 with the name without NUL, 12 bytes back
        reply = c.request(9, struct.pack("<IIII", 0xF007, 0, 12, len(LIFT)) + LIFT.encode())
        assert wire.decode_read_response(reply.payload) == (
            0,
            struct.pack("<III", 0x121301, 0x30095, 1),
        )
        # read_multi: 0xF083, n × (result, length) then blocks padded to the asked sizes
        subs = struct.pack("<III", 0x121301, 0x30095, 1) + struct.pack("<III", 0x121301, 0x15, 8)
        reply = c.request(9, struct.pack("<IIII", 0xF083, 2, 16 + 9, len(subs)) + subs)
        code, data = wire.decode_read_response(reply.payload)
        assert code == 0 and len(data) == 25 and struct.unpack_from("<4I", data)[::2] == (0, 0)
        # add_notification_multi (40-byte entries) and delete_notification_multi
        note = struct.pack("<IIIIII16s", 0x121301, 0x30095, 1, 4, 0, 100_000, bytes(16))
        reply = c.request(9, struct.pack("<IIII", 0xF085, 1, 8, len(note)) + note)
        code, data = wire.decode_read_response(reply.payload)
        result, handle = struct.unpack("<II", data)
        assert code == 0 and result == 0 and handle > 0
        reply = c.request(9, struct.pack("<IIII", 0xF086, 1, 4, 4) + struct.pack("<I", handle))
        assert wire.decode_read_response(reply.payload) == (0, bytes(4))
    finally:
        c.close()


def test_wireshark_dissects_the_whole_session_without_malformed_frames(session: Session) -> None:
    need_node_client()  # the session it dissects is mostly the Node client's
    session.stop_capture()
    tshark = tool("tshark")

    def frames(display_filter: str) -> int:
        run = subprocess.run(
            [
                tshark,
                "-r",
                str(session.pcap),
                "-d",
                f"tcp.port=={session.port},ams",
                "-Y",
                display_filter,
                "-T",
                "fields",
                "-e",
                "frame.number",
            ],
            capture_output=True,
            text=True,
            timeout=120,
            check=True,
        )
        return len(run.stdout.split())

    assert frames("ams") > 100  # the dissector saw the session (router frames included)
    assert frames("ams.cmdid == 8") > 0  # device notifications
    assert frames("udp") >= 2  # discovery request and reply
    assert frames("_ws.malformed || _ws.expert.severity == error") == 0
