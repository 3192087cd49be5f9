"""What a deployment relies on: the systemd unit keeps the RT split and verifies, the image's
files exist and its configuration loads."""

from __future__ import annotations

import configparser
import glob
import re
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from tests.support.paths import REPO
from tests.support.wait import wait_for

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
    r = subprocess.run(
        ["systemd-analyze", "verify", str(tmp_path / "liftd.service")],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert r.returncode == 0, r.stderr
    assert "liftd.service" not in r.stderr, r.stderr  # no warnings about our unit


def test_the_image_files_exist_and_its_configuration_loads(tmp_path: Path) -> None:
    dockerfile = (REPO / "Dockerfile").read_text()
    for line in dockerfile.splitlines():
        if line.startswith("COPY") and "--from" not in line:
            for src in line.split()[1:-1]:
                assert any(REPO.glob(src)) if "*" in src else (REPO / src).exists(), src
    assert "HEALTHCHECK" in dockerfile and "EXPOSE 48898" in dockerfile  # issue 17: no CLI
    assert "USER 10001" in dockerfile
    etc = tmp_path / "etc-liftd"  # the image's /etc/liftd: config/ with docker/liftd.toml over it
    shutil.copytree(REPO / "config", etc)
    shutil.copy(REPO / "docker" / "liftd.toml", etc / "liftd.toml")
    r = subprocess.run(
        [sys.executable, "-m", "liftd", "check", "-c", str(etc / "liftd.toml")],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert r.returncode == 0, r.stderr


def _syscalls(group: str) -> set[str]:
    """The system calls of a systemd syscall group, groups expanded."""
    out = subprocess.run(
        ["systemd-analyze", "syscall-filter", "--no-pager", group],
        capture_output=True,
        text=True,
        timeout=60,
        check=True,
    ).stdout
    calls: set[str] = set()
    for line in out.splitlines()[1:]:
        word = line.strip().split("#")[0].strip()
        if word.startswith("@"):
            calls |= _syscalls(word)
        elif word:
            calls.add(word)
    return calls


def test_the_unit_is_hardened_as_issue_17_asks() -> None:
    svc = unit()["Service"]
    assert svc["RemoveIPC"] == "yes" and svc["ProtectProc"] == "invisible"
    assert svc["MemoryDenyWriteExecute"] == "yes"
    filters = [
        line.split("=", 1)[1]
        for line in UNIT.read_text().splitlines()
        if line.startswith("SystemCallFilter=")
    ]
    assert "~@privileged" in filters and "@system-service" in filters
    assert svc["ExecReload"].endswith("liftd reload")  # synchronous: its exit status counts
    assert svc["RuntimeDirectory"] == "liftd"


@pytest.mark.skipif(shutil.which("systemd-analyze") is None, reason="no systemd-analyze")
def test_the_syscall_filter_keeps_what_the_loop_needs() -> None:
    allowed = _syscalls("@system-service") - _syscalls("@privileged")
    for call in (
        "sched_setscheduler",
        "sched_setaffinity",
        "mlockall",
        "clock_nanosleep",
        "prctl",
        "memfd_create",
        "mmap",
        "ftruncate",
    ):
        assert call in allowed, call


def test_documentation_exists_after_the_install_steps() -> None:
    manual = (REPO / "docs" / "service.md").read_text()  # the install steps, once the README's
    steps = manual[manual.index("sudo useradd --system") :].split("```")[0]
    for url in unit()["Unit"]["Documentation"].split():
        assert url.startswith("file://")
        path = url.removeprefix("file://")
        installed = [line for line in steps.splitlines() if path.rsplit("/", 1)[0] in line]
        assert installed, f"the install steps never put {path} in place"
        source = path.rsplit("/", 1)[1]  # named, or matched by a glob of the line (docs/*.md)
        files = {Path(f).name for line in installed for word in line.split()
                 for f in (glob.glob(word, root_dir=REPO) if "*" in word else [word])}  # fmt: skip
        assert source in files, (source, installed)


def test_the_image_is_reproducible_labelled_and_keeps_its_shipped_config() -> None:
    dockerfile = (REPO / "Dockerfile").read_text()
    assert not re.search(r"^VOLUME", dockerfile, re.M)  # no anonymous volume over /etc/liftd
    assert "--upgrade pip" not in dockerfile
    assert "PIP_CONSTRAINT=/src/docker/constraints.txt" in dockerfile
    for label in ("title", "description", "version", "licenses"):
        assert f"org.opencontainers.image.{label}=" in dockerfile, label
    pinned = dict(
        line.split("==")
        for line in (REPO / "docker" / "constraints.txt").read_text().splitlines()
        if line and not line.startswith("#")
    )
    project = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
    for dep in project["dependencies"]:
        name = re.split(r"[<>=!~ ]", dep)[0].lower()
        assert name in pinned, f"{name} is not pinned in docker/constraints.txt"
    health = dockerfile[dockerfile.index("HEALTHCHECK") :]
    assert "liftd" not in health.split("\n", 2)[1]  # a shell test of a file, no Python start


def test_the_daemon_runs_without_writable_executable_memory(tmp_path: Path) -> None:
    """MemoryDenyWriteExecute=yes: the kernel's own MDWE (PR_SET_MDWE, Linux >= 6.3, what
    systemd uses where the kernel has it) set before exec and inherited by the GEO process."""
    from tests.support.daemon import Daemon, write_config  # noqa: PLC0415

    probe = subprocess.run(
        [sys.executable, "-c", MDWE_WRAPPER, "true"],
        capture_output=True,
        text=True,
        timeout=30,
        check=False,
    )
    if probe.returncode != 0:
        pytest.skip(f"PR_SET_MDWE not available: {probe.stderr.strip()}")
    cfg = write_config(tmp_path, program={"repeat": True})
    d = Daemon(cfg, wrapper=[sys.executable, "-c", MDWE_WRAPPER])
    try:
        d.ready()
        assert d.read_symbol("GEO.ch1.state", "<I") == 4
        cycles = d.read_symbol("GEO.cycle", "<Q")
        assert wait_for(lambda: d.read_symbol("GEO.cycle", "<Q") > cycles + 100)
    finally:
        assert d.stop() == 0
    assert "Traceback" not in "".join(d.raw)


MDWE_WRAPPER = """
import ctypes, os, sys
libc = ctypes.CDLL(None, use_errno=True)
PR_SET_MDWE, PR_GET_MDWE, REFUSE_EXEC_GAIN = 65, 66, 1
if libc.prctl(PR_SET_MDWE, REFUSE_EXEC_GAIN, 0, 0, 0) != 0:
    sys.exit(os.strerror(ctypes.get_errno()))
os.execvp(sys.argv[1], sys.argv[1:])
"""
