"""The two-head configuration as shipped (config/liftd-2ch.toml) under `liftd run`: pyads
reads both channels' lift_active at their own index groups, a PLC write reaches only its
channel, `liftd plc --channel 2` follows channel 2's lift axis, and --trace writes one file
per channel (issue 18 items 1 and 4)."""

from __future__ import annotations

import csv
import json
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pyads
import pytest

from tests.support.daemon import Daemon
from tests.support.paths import REPO
from tests.support.settings import copy_two_head_machine, edit

pytestmark = pytest.mark.integration

SHIPPED = REPO / "config" / "liftd-2ch.toml"
# (index group, index offset) of lift_active: channel 1 Z (logical axis 3), channel 2 W (6)
CH1_Z = (0x121301, 0x00030095)
CH2_W = (0x121302, 0x00060095)


def two_channel_config(tmp: Path, net_id: str) -> Path:
    """The shipped two-head liftd.toml with its files found from tmp, on a free port, without
    the RT settings tests cannot have on a shared VM."""
    text = SHIPPED.read_text()
    config = REPO / "config"
    text = re.sub(r'startup_list = "([^"]+)"', lambda m: f'startup_list = "{config / m[1]}"', text)
    text = re.sub(
        r'(file|program) = "(programs/[^"]+)"', lambda m: f'{m[1]} = "{config / m[2]}"', text
    )
    text = text.replace("port = 48898", "port = 0").replace('"127.0.0.1.1.1"', f'"{net_id}"')
    text += (
        "\n[rt]\nsched_fifo_priority = 0\nhold_cpu_dma_latency = false\nlock_memory = false\n"
        '\n[log]\nformat = "json"\n'
    )
    path = tmp / "liftd-2ch.toml"
    path.write_text(text)
    return path


def test_pyads_reads_both_channels_at_their_index_groups(tmp_path: Path) -> None:
    cfg = two_channel_config(tmp_path, "127.0.0.1.61.1")
    trace = tmp_path / "run.csv"
    d = Daemon(cfg, "--trace", str(trace))
    try:
        d.ready()
        plc = pyads.Connection(d.net_id, 551, d.address)
        plc.open()
        try:
            seen: set[tuple[bool, bool]] = set()
            deadline = time.monotonic() + 25  # both heads lift within their first parts
            while time.monotonic() < deadline and not (
                any(a for a, _ in seen) and any(b for _, b in seen)
            ):
                seen.add(
                    (plc.read(*CH1_Z, pyads.PLCTYPE_BOOL), plc.read(*CH2_W, pyads.PLCTYPE_BOOL))
                )
                time.sleep(0.005)
            assert any(a for a, _ in seen) and any(b for _, b in seen), seen
            assert plc.read_by_name("GEO.ch2.W.lift_active") in (True, False)
            with pytest.raises(pyads.ADSError) as err:  # channel 2 has no logical axis 3
                plc.read(0x121302, 0x00030095, pyads.PLCTYPE_BOOL)
            assert err.value.err_code == 0x703
            plc.write_by_name("PLC.ch2.override", 500, pyads.PLCTYPE_UINT)
            deadline = time.monotonic() + 5
            while plc.read_by_name("GEO.ch2.override_requested") != 500:
                assert time.monotonic() < deadline
                time.sleep(0.01)
            assert plc.read_by_name("GEO.ch1.override_requested") == 1000
            assert plc.read_by_name("GEO.ch2.state") in (3, 4, 5)
        finally:
            plc.close()
        run = subprocess.run(
            [
                sys.executable,
                "-m",
                "liftd",
                "plc",
                "-c",
                str(cfg),
                "--host",
                d.address,
                "--channel",
                "2",
                "--duration",
                "12",
                "--json",
            ],
            capture_output=True,
            text=True,
            timeout=60,
            check=False,
        )
        assert run.returncode == 0, run.stderr
        objects = {json.loads(line).get("object") for line in run.stdout.splitlines()}
        assert "W.lift_active" in objects, run.stdout[:500]
        bad = subprocess.run(
            [
                sys.executable,
                "-m",
                "liftd",
                "plc",
                "-c",
                str(cfg),
                "--host",
                d.address,
                "--channel",
                "3",
                "--duration",
                "1",
            ],
            capture_output=True,
            text=True,
            timeout=60,
            check=False,
        )
        assert bad.returncode == 2 and "--channel" in bad.stderr
    finally:
        assert d.stop() == 0
    with trace.open() as f:
        head1 = next(csv.reader(f))
    with (tmp_path / "run.ch2.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert head1[:9] == [
        "t",
        "line",
        "x",
        "y",
        "z",
        "v_path",
        "override",
        "lift_active",
        "lift_suppressed",
    ]
    assert list(rows[0])[:5] == ["t", "line", "u", "v", "w"]
    assert any(r["lift_active"] == "1" for r in rows)
    assert any(rec.get("channel") == 2 and rec["event"] == "lift.start" for rec in d.logs)


def test_a_reload_reaches_each_channel_at_its_own_program_boundary(tmp_path: Path) -> None:
    """SIGHUP: channel 2 (a 0.5 s program) takes its new program at its next end, while
    channel 1 (a long one) runs on and takes it at its own end."""
    config = REPO / "config"
    long1 = tmp_path / "long1.nc"
    long1.write_text("N10 G01 X400 F6000\nN20 G01 X0\nN30 M30\n")  # 8 s
    short2 = tmp_path / "short2.nc"
    short2.write_text("N10 G01 U30 F6000\nN20 M30\n")
    path = tmp_path / "liftd.toml"
    path.write_text(
        f'[cnc]\nstartup_list = "{config / "cnc-2ch" / "hochlauf.lis"}"\n'
        f'[program]\nfile = "{long1}"\nrepeat = true\n'
        f'[[channel]]\nid = 2\nprogram = "{short2}"\nrepeat = true\n'
        '[ads]\nport = 0\nnet_id = "127.0.0.1.62.1"\n'
        "[rt]\nsched_fifo_priority = 0\nhold_cpu_dma_latency = false\nlock_memory = false\n"
        '[log]\nformat = "json"\n'
    )
    d = Daemon(path)
    try:
        d.ready()
        d.signal(signal.SIGHUP)
        assert d.event("config.reload_accepted") is not None, "".join(d.raw[-20:])
        deadline = time.monotonic() + 30
        reloaded: list[dict[str, object]] = []
        while time.monotonic() < deadline and len(reloaded) < 2:
            reloaded = [r for r in d.logs if r.get("event") == "geo.reloaded"]
            time.sleep(0.05)
        assert [r["channel"] for r in reloaded] == [2, 1]  # the short program ends first
        assert float(str(reloaded[1]["t"])) > 5.0 > float(str(reloaded[0]["t"]))
    finally:
        assert d.stop() == 0


def test_study_runs_a_channels_programs_in_that_channel(tmp_path: Path) -> None:
    head2 = str(REPO / "config" / "programs" / "two-head" / "head2.nc")
    base = [sys.executable, "-m", "liftd", "study", head2, "-c", str(SHIPPED), "--jobs", "1"]
    ok = subprocess.run(
        [*base, "--channel", "2", "--out", str(tmp_path / "ch2")],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert ok.returncode == 0, ok.stderr
    report = json.loads((tmp_path / "ch2" / "report.json").read_text())
    assert report["summary"]["compared"] == 3 and report["summary"]["status"]["ok"] == 1
    # in channel 1 (the default) U V W are no axes: the program is reported with its errors
    wrong = subprocess.run(
        [*base, "--out", str(tmp_path / "ch1")],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert wrong.returncode == 1 and "990018" in wrong.stderr


def liftd(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "liftd", *args],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )


def test_exit_codes_of_bad_channels(tmp_path: Path) -> None:
    """A configuration error exits 2 (check, simulate, run); an axis of another channel in a
    channel's program is an NC error, exit 1."""
    machine = copy_two_head_machine(tmp_path)
    cfg = machine / "liftd.toml"
    head1 = str(machine / "programs" / "two-head" / "head1.nc")
    edit(cfg, "id = 2 ", "id = 5 ")
    for args in (("check",), ("simulate", head1), ("run", "--duration", "1"), ("objects",)):
        r = liftd(args[0], "-c", str(cfg), *args[1:])
        assert r.returncode == 2 and "channel.0.id = '5'" in r.stderr, (args, r.stderr)
    edit(cfg, "id = 5 ", "id = 2 ")
    edit(cfg, "head2.nc", "none.nc")  # a [[channel]] program that cannot be read
    for args in (("check",), ("simulate", head1), ("run", "--duration", "1")):
        r = liftd(args[0], "-c", str(cfg), *args[1:])
        assert r.returncode == 2 and "channel.0.program = " in r.stderr, (args, r.stderr)
    edit(cfg, "none.nc", "head2.nc")
    edit(machine / "programs" / "two-head" / "head2.nc", "N50 V120", "N50 Y120")  # Y is head 1's
    r = liftd("check", "-c", str(cfg))
    assert r.returncode == 1 and "head2.nc:10:5: error 990018: Y is not an axis" in r.stderr
    r = liftd("simulate", "-c", str(cfg), head1, "--json")
    assert r.returncode == 1 and "(channel 2)" in r.stderr
    r = liftd("check", "-c", str(cfg), "--channel", "2", head1)  # X Y Z in channel 2
    assert r.returncode == 1 and "X is not an axis" in r.stderr
    r = liftd("check", "-c", str(cfg), "--channel", "3", head1)
    assert r.returncode == 2 and "--channel = '3' error: no such channel (channels: 1, 2)" in (
        r.stderr
    )
