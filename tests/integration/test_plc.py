"""`liftd plc`, the simulated PLC, against a running daemon: it sees every lift the GEO loop
makes, its schedule writes reach the loop, and it fails loudly when it cannot read."""

from __future__ import annotations

import csv
import json
import re
import signal
import socket
import subprocess
import sys
from pathlib import Path

import pyads
import pytest

from tests.support.daemon import Daemon, write_config
from tests.support.wait import wait_for

# wall-clock latencies asserted: run alone, after the parallel part of `make test`
pytestmark = [pytest.mark.integration, pytest.mark.timing]

TWO_LIFTS = """%two
N10 G90 G17 G94
N20 G00 X0 Y0 Z1
N30 Z[LIFT_START POS=1 POS_LIMIT=30]
N40 G01 X100 Y0 F24000
N50 Z[LIFT_END]
N60 G01 X110 F3000
N70 Z[LIFT_START POS=1 POS_LIMIT=30]
N80 G01 X10 Y10 F24000
N90 Z[LIFT_END]
N100 M30
"""


def plc(cfg: Path, *args: str, timeout: float = 30) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "liftd", "plc", "-c", str(cfg), *args],
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )


def healthcheck(cfg: Path, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "liftd", "healthcheck", "-c", str(cfg), *args],
        capture_output=True,
        text=True,
        timeout=30,
        check=False,
    )


def rising_edges_s(rows: list[dict[str, str]], column: str) -> list[float]:
    edges, last = [], "0"
    for row in rows:
        if row[column] == "1" and last == "0":
            edges.append(float(row["t"]))
        last = row[column]
    return edges


def test_plc_sees_every_lift_and_its_writes_reach_the_loop(tmp_path: Path) -> None:
    program = tmp_path / "two.nc"
    program.write_text(TWO_LIFTS)
    cfg = write_config(tmp_path, program_file=str(program), program={"autostart": False})
    trace = tmp_path / "run.csv"
    d = Daemon(cfg, "--trace", str(trace))
    try:
        port = d.ready()
        r = plc(
            cfg,
            "--host",
            f"127.0.0.1:{port}",
            "--start",
            "--override",
            "0:50",
            "--duration",
            "3",
            "--json",
        )
        assert r.returncode == 0, r.stderr
        # a hold that outlasts the PLC: released when it exits, as it found it
        held = plc(
            cfg, "--host", f"127.0.0.1:{port}", "--feedhold", "0:100", "--duration", "0.3", "--json"
        )
        assert held.returncode == 0, held.stderr
        after = plc(cfg, "--host", f"127.0.0.1:{port}", "--duration", "0.1", "--json")
        assert after.returncode == 0, after.stderr
        # an operator's hold: a schedule leaves it alone until its own first step
        conn = pyads.Connection(d.net_id, 551, d.address)
        conn.open()
        try:
            conn.write_by_name("PLC.ch1.feed_hold", True, pyads.PLCTYPE_BOOL)
            later = plc(
                cfg,
                "--host",
                f"127.0.0.1:{port}",
                "--feedhold",
                "5:1",
                "--override",
                "5:80",
                "--duration",
                "0.3",
                "--json",
            )
            assert later.returncode == 0, later.stderr
            assert conn.read_by_name("PLC.ch1.feed_hold") is True
            conn.write_by_name("PLC.ch1.feed_hold", False, pyads.PLCTYPE_BOOL)
            # stopped by a supervisor's SIGTERM inside its hold: released as on Ctrl-C
            proc = subprocess.Popen(
                [
                    sys.executable,
                    "-m",
                    "liftd",
                    "plc",
                    "-c",
                    str(cfg),
                    "--host",
                    f"127.0.0.1:{port}",
                    "--feedhold",
                    "0:100",
                    "--json",
                ],
                stdout=subprocess.DEVNULL,
            )
            try:
                assert wait_for(lambda: conn.read_by_name("PLC.ch1.feed_hold") is True, 10)
                proc.send_signal(signal.SIGTERM)
                assert proc.wait(10) == 0
            finally:
                proc.kill()
            assert conn.read_by_name("PLC.ch1.feed_hold") is False
        finally:
            conn.close()
    finally:
        assert d.stop() == 0
    records = [json.loads(line) for line in r.stdout.splitlines()]
    writes = [(rec["write"], rec["value"]) for rec in records if "write" in rec]
    # the schedule, then at exit the override as the PLC found it (100 %)
    assert writes == [("PLC.ch1.override", 500), ("PLC.ch1.start", 1), ("PLC.ch1.override", 1000)]
    hold = [json.loads(line) for line in held.stdout.splitlines()]
    assert [(rec["write"], rec["value"]) for rec in hold if "write" in rec] == [
        ("PLC.ch1.feed_hold", 1),
        ("PLC.ch1.feed_hold", 0),
    ]
    assert [rec["to"] for rec in hold if rec.get("object") == "feed_hold"][:2] == [0, 1]
    assert [
        rec["to"]
        for rec in map(json.loads, after.stdout.splitlines())
        if rec.get("object") == "feed_hold"
    ] == [0]
    quiet = [json.loads(line) for line in later.stdout.splitlines()]
    assert not [rec for rec in quiet if "write" in rec]  # nothing before its first step
    assert [rec["to"] for rec in quiet if rec.get("object") == "feed_hold"] == [1]
    seen = [rec for rec in records if rec.get("object") == "Z.lift_active"]
    ups = [rec["t"] for rec in seen if rec["to"] == 1]
    assert [rec["to"] for rec in seen] == [0, 1, 0, 1, 0]
    states = [rec["to"] for rec in records if rec.get("object") == "state"]
    assert states[0] == 3 and 4 in states and states[-1] == 3  # READY → ACTIVE → READY
    with trace.open() as f:
        rows = list(csv.DictReader(f))
    trace_ups = rising_edges_s(rows, "lift_active")
    assert len(trace_ups) == 2
    # the PLC samples every 10 ms: the gap between the lifts agrees within two PLC cycles
    assert abs((ups[1] - ups[0]) - (trace_ups[1] - trace_ups[0])) < 0.025
    active = [row for row in rows if row["state"] == "4"]
    assert active and all(row["override"] == "0.500000" for row in active)


def test_plc_exits_non_zero_when_the_daemon_is_unreachable_or_a_read_fails(
    tmp_path: Path,
) -> None:
    cfg = write_config(tmp_path)
    with socket.socket() as s:  # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        free = s.getsockname()[1]
    r = plc(cfg, "--host", f"127.0.0.1:{free}", "--duration", "1", "--timeout-ms", "300")
    assert r.returncode == 3
    assert "cannot reach liftd at 127.0.0.1:" in r.stderr and "liftd run" in r.stderr
    d = Daemon(cfg)
    try:
        port = d.ready()
        r = plc(cfg, "--host", f"127.0.0.1:{port}", "--axis", "Q", "--duration", "1")
        assert r.returncode == 2  # a bad argument, as a channel the machine lacks
        assert "--axis Q: channel 1 of the configuration (-c) has the axes X, Y, Z" in r.stderr
        bad = plc(cfg, "--override", "0:500")
        assert bad.returncode == 2 and "PERCENT" in bad.stderr
        health = healthcheck(cfg, "--port", str(port))
        assert health.returncode == 0 and health.stdout.startswith("healthy: RUN")
    finally:
        assert d.stop() == 0
    down = healthcheck(cfg, "--port", str(port))
    assert down.returncode == 1 and "no ADS answer" in down.stderr


ADSLIB_LINE = re.compile(r"\b(Info|Warning|Error|Verbose): ")


def test_liftd_plc_prints_no_adslib_noise(tmp_path: Path) -> None:
    """AdsLib logs "Info: connection closed by remote" and "Warning: Socket(): connect failed"
    to stderr from C++; `liftd plc` switches that off, so the terminal holds liftd's lines."""
    cfg = write_config(tmp_path, program={"repeat": True})
    unreachable = plc(cfg, "--host", "127.0.0.1:1", "--duration", "1")
    assert unreachable.returncode == 3
    assert unreachable.stderr.startswith("liftd plc: cannot reach")
    assert not ADSLIB_LINE.search(unreachable.stderr + unreachable.stdout)
    d = Daemon(cfg)
    try:
        d.ready()
        normal = plc(cfg, "--host", d.address, "--net-id", d.net_id, "--duration", "0.5")
    finally:
        assert d.stop() == 0
    assert normal.returncode == 0, normal.stderr
    assert normal.stderr == "" and not ADSLIB_LINE.search(normal.stdout)


def test_with_m_ack_plc_liftd_plc_acknowledges_each_m_function(tmp_path: Path) -> None:
    """`[plc] m_ack = "plc"`: the channel waits at M04/M08 until the PLC acknowledges;
    `liftd plc` does it after `m_ack_delay_ms` and shows m_pending (before, it only watched,
    and the channel waited for ever)."""
    program = tmp_path / "m.nc"
    program.write_text("N10 G01 X10 F6000\nN20 M4\nN30 G01 X20\nN40 M8\nN50 G01 X30\nN60 M30\n")
    cfg = write_config(
        tmp_path,
        program_file=str(program),
        program={"autostart": False},
        plc={"m_ack": "plc", "m_ack_delay_ms": 50},
    )
    d = Daemon(cfg)
    try:
        port = d.ready()
        r = plc(cfg, "--host", f"127.0.0.1:{port}", "--start", "--duration", "3", "--json")
        assert r.returncode == 0, r.stderr
    finally:
        assert d.stop() == 0
    records = [json.loads(line) for line in r.stdout.splitlines()]
    acks = [rec for rec in records if rec.get("write") == "PLC.ch1.m_ack"]
    pending = [rec for rec in records if rec.get("object") == "m_pending"]
    assert [rec["to"] for rec in pending] == [-1, 4, -1, 8, -1]
    assert len(acks) == 2
    for ack, seen in zip(acks, pending[1::2], strict=True):  # each after the delay, once
        assert 0.05 - 0.011 <= ack["t"] - seen["t"] <= 0.2, (ack, seen)
    states = [rec["to"] for rec in records if rec.get("object") == "state"]
    assert states[-1] == 3  # the program ran to its end
