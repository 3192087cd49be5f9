"""Logging never blocks serving (issue 16 item 5): the daemon's stdout and stderr are pipes
nobody reads (4 KiB each, full after a few lines), a peer opens and closes 3 000 connections
from 200 loopback addresses, and a pyads read is still answered within 100 ms; the lines that
did not fit are counted in GEO.ads.log_dropped."""

from __future__ import annotations

import fcntl
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pyads
import pytest

from tests.support.daemon import Notify, write_config
from tests.support.paths import REPO

# wall-clock latencies asserted: run alone, after the parallel part of `make test`
pytestmark = [pytest.mark.integration, pytest.mark.timing]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def small_pipe() -> tuple[int, int]:
    r, w = os.pipe()
    fcntl.fcntl(w, fcntl.F_SETPIPE_SZ, 4096)
    return r, w


def test_unread_log_pipe_blocks_no_request(tmp_path: Path) -> None:
    port = free_port()
    cfg = write_config(
        tmp_path,
        program={"repeat": True},
        ads={"port": port},
        log={"format": "json", "queue_lines": 100},
    )
    notify = Notify(tmp_path)
    (out_r, out_w), (err_r, err_w) = small_pipe(), small_pipe()
    env = {**os.environ, "NOTIFY_SOCKET": notify.path}
    proc = subprocess.Popen(
        [sys.executable, "-m", "liftd", "run", "-c", str(cfg)],
        stdout=out_w,
        stderr=err_w,
        env=env,
        cwd=REPO,
    )
    os.close(out_w)
    os.close(err_w)
    try:
        end = time.monotonic() + 20
        while "READY=1" not in "".join(notify.drain()) and time.monotonic() < end:
            assert proc.poll() is None, "the daemon exited"
            time.sleep(0.02)
        for i in range(3000):
            with socket.socket() as s:
                s.bind((f"127.0.0.{2 + i % 200}", 0))
                s.connect(("127.0.0.1", port))
        net_id = next(
            line.split('"')[1] for line in cfg.read_text().splitlines() if line.startswith("net_id")
        )
        plc = pyads.Connection(net_id, 551, f"127.0.0.1:{port}")
        plc.open()
        try:
            end = time.monotonic() + 15  # the daemon has worked through the 3 000 connections
            while plc.read_by_name("GEO.ads.connections", pyads.PLCTYPE_UDINT) > 1:
                assert time.monotonic() < end
                time.sleep(0.05)
            took = []
            for _ in range(5):
                t0 = time.monotonic()
                plc.read(0x121301, 0x30095, pyads.PLCTYPE_BOOL)
                took.append(time.monotonic() - t0)
            assert sorted(took)[2] < 0.1, took  # the median: one shared-CPU hiccup is no block
            dropped = plc.read_by_name("GEO.ads.log_dropped", pyads.PLCTYPE_ULINT)
        finally:
            plc.close()
        assert dropped > 0  # the pipe was full: lines were dropped, not waited for
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(20) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        os.close(out_r)
        os.close(err_r)
        notify.close()
