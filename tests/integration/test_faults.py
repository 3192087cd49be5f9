"""Faults of the running daemon: a full disk under the trace, and SIGKILL + restart while a pyads
client stays connected (it gets errors meanwhile, never stale values, and after reopening its
connection, as pyads clients must since AdsLib does not reconnect a route, live values)."""

from __future__ import annotations

import signal
import time
from pathlib import Path

import pyads
import pytest

from tests.support.daemon import Daemon, write_config
from tests.support.wait import wait_for

pytestmark = pytest.mark.integration


def test_a_full_disk_stops_the_trace_not_the_loop(tmp_path: Path) -> None:
    d = Daemon(write_config(tmp_path, program={"repeat": True}), "--trace", "/dev/full")
    try:
        d.ready()
        rec = d.event("trace.stopped", 15)
        assert rec is not None and "space" in rec["reason"].lower()
        c1 = d.read_symbol("GEO.cycle", "<Q")
        assert wait_for(lambda: d.read_symbol("GEO.cycle", "<Q") > c1 + 100)  # the loop runs on
        assert d.read_exceeded() == 0 or d.proc.poll() is None
    finally:
        assert d.stop() == 0


def test_sigkill_and_restart_with_clients_connected(tmp_path: Path) -> None:
    cfg = write_config(tmp_path, program={"repeat": True})
    first = Daemon(cfg)
    port = first.ready()
    plc = pyads.Connection(first.net_id, 551, first.address)
    plc.open()
    plc.set_timeout(500)
    try:
        before = plc.read_by_name("GEO.cycle", pyads.PLCTYPE_ULINT)
        assert before > 0
        first.proc.send_signal(signal.SIGKILL)
        first.proc.wait(5)
        with pytest.raises(pyads.ADSError):  # nobody answers: an error, not the last value
            plc.read(0x121301, 0x30095, pyads.PLCTYPE_BOOL)
        # systemd's restart: same configuration, same port, same NetId
        write_config(tmp_path, program={"repeat": True}, ads={"port": port, "net_id": first.net_id})
        second = Daemon(cfg)
        try:
            assert second.ready() == port
            deadline = time.monotonic() + 10
            while True:  # AdsLib keeps a dead socket: pyads clients reopen their connection
                try:
                    after = plc.read_by_name("GEO.cycle", pyads.PLCTYPE_ULINT)
                    break
                except pyads.ADSError:
                    assert time.monotonic() < deadline, "the client never got through again"
                    plc.close()
                    plc.open()
                    plc.set_timeout(500)
                    time.sleep(0.1)
            # live, not stale
            assert wait_for(lambda: plc.read_by_name("GEO.cycle", pyads.PLCTYPE_ULINT) > after)
            assert plc.read(0x121301, 0x30095, pyads.PLCTYPE_BOOL) in (True, False)
            assert plc.read_state()[0] == 5
        finally:
            assert second.stop() == 0
    finally:
        plc.close()
        first.stop()
