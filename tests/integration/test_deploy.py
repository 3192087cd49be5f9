"""What a deployment relies on: the systemd unit keeps the RT split and verifies, the image's
files exist and its configuration loads."""

from __future__ import annotations

import configparser
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from tests.support.paths import REPO

pytestmark = pytest.mark.integration
UNIT = REPO / "systemd" / "liftd.service"


def unit() -> configparser.ConfigParser:
    parser = configparser.ConfigParser(strict=False, interpolation=None)
    parser.optionxform = str  # type: ignore[assignment,method-assign]
    parser.read_string(UNIT.read_text())
    return parser


def test_the_unit_keeps_the_server_out_of_real_time_and_the_loop_able_to_enter_it() -> None:
    svc = unit()["Service"]
    assert svc["Type"] == "notify" and svc["NotifyAccess"] == "main"
    assert svc["KillMode"] == "mixed"  # SIGTERM to the daemon; it stops the GEO child itself
    assert "CPUSchedulingPolicy" not in svc and "CPUSchedulingPriority" not in svc
    assert svc.get("RestrictRealtime", "no") == "no"
    assert svc["LimitRTPRIO"] == "80" and svc["LimitMEMLOCK"] == "infinity"
    assert svc["WatchdogSec"] and svc["RestartPreventExitStatus"] == "2"
    assert svc["User"] != "root" and svc["NoNewPrivileges"] == "yes"
    assert svc["CapabilityBoundingSet"] == ""
    assert "@resources" not in svc.get("SystemCallFilter", "")  # sched_setscheduler lives there


@pytest.mark.skipif(shutil.which("systemd-analyze") is None, reason="no systemd-analyze")
def test_the_unit_verifies(tmp_path: Path) -> None:
    # verify checks ExecStart exists: point it at this venv's liftd
    exe = Path(sys.executable).with_name("liftd")
    text = UNIT.read_text().replace("/opt/liftd/.venv/bin/liftd", str(exe))
    (tmp_path / "liftd.service").write_text(text)
    r = subprocess.run(["systemd-analyze", "verify", str(tmp_path / "liftd.service")],
                       capture_output=True, text=True, timeout=60, check=False)  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert "liftd.service" not in r.stderr, r.stderr  # no warnings about our unit


def test_the_image_files_exist_and_its_configuration_loads(tmp_path: Path) -> None:
    dockerfile = (REPO / "Dockerfile").read_text()
    for line in dockerfile.splitlines():
        if line.startswith("COPY") and "--from" not in line:
            for src in line.split()[1:-1]:
                assert (REPO / src).exists(), src
    assert 'CMD ["liftd", "healthcheck"]' in dockerfile and "EXPOSE 48898" in dockerfile
    assert "USER 10001" in dockerfile
    etc = tmp_path / "etc-liftd"  # the image's /etc/liftd: config/ with docker/liftd.toml over it
    shutil.copytree(REPO / "config", etc)
    shutil.copy(REPO / "docker" / "liftd.toml", etc / "liftd.toml")
    r = subprocess.run([sys.executable, "-m", "liftd", "check", "-c", str(etc / "liftd.toml")],
                       capture_output=True, text=True, timeout=60, check=False)  # fmt: skip
    assert r.returncode == 0, r.stderr
