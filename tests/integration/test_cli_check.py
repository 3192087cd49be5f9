"""`liftd check` as a user runs it: subprocess, exit codes, messages on stderr."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from tests.support.paths import GOLDEN, REPO

pytestmark = pytest.mark.integration


def liftd(
    *args: str,
    cwd: Path | None = None,
    env: dict[str, str] | None = None,
    timeout: float = 60,
) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "liftd", *args],
        check=False,
        capture_output=True,
        text=True,
        timeout=timeout,
        cwd=cwd,
        env=env,
    )


@pytest.mark.parametrize("config", ["config/liftd.toml", "config/liftd-lifting.toml"])
def test_shipped_configs_and_demo_check_clean(config: str) -> None:
    r = liftd("check", "-c", str(REPO / config))
    assert r.returncode == 0, r.stderr
    assert r.stderr == ""
    assert "demo.nc: ok (" in r.stdout


def test_configuration_error_exits_2_with_location(tmp_path: Path) -> None:
    bad = tmp_path / "liftd.toml"
    bad.write_text('[cnc]\nstartup_list = "x/hochlauf.lis"\ncycle_time_us = 99\n')
    r = liftd("check", "-c", str(bad))
    assert r.returncode == 2
    assert f"{bad}:3: cnc.cycle_time_us = '99' error:" in r.stderr


def test_list_error_exits_2_with_location(machine) -> None:  # type: ignore[no-untyped-def]
    cfg = machine({"cnc/achsmds3.lis": {"getriebe[0].dynamik.tr_min": "fast"}})
    r = liftd("check", "-c", str(cfg))
    assert r.returncode == 2
    assert re.search(
        r"achsmds3\.lis:\d+: getriebe\[0\]\.dynamik\.tr_min = 'fast' error: "
        r"expected an integer",
        r.stderr,
    ), r.stderr


def program_cases() -> list[Path]:
    return sorted((GOLDEN / "nc" / "bad").glob("*.nc"))


@pytest.mark.parametrize("program", program_cases(), ids=lambda p: p.stem)
def test_golden_bad_programs(program: Path) -> None:
    m = re.match(r"; expect (\d+) line (\d+)", program.read_text().splitlines()[0])
    assert m, "first line must be '; expect <id> line <n>'"
    r = liftd("check", "-c", str(REPO / "config" / "liftd.toml"), str(program))
    assert r.returncode == 1
    first = r.stderr.splitlines()[0]
    assert first.startswith(f"{program}:{m.group(2)}:")
    assert f" error {m.group(1)}: " in first


HEADER = "G90 G17 G94\nG00 X20 Y20 Z1\nG01 X100 F6000\n"


@pytest.mark.parametrize(
    ("body", "first", "listing"),
    [
        ("Z[LIFT_START POS=1]\nG01 X120\n", ":4:1: error 990008: ", ""),
        (
            "Z[LIFT_START POS=1 POS_LIMIT=40]\nX110 Z[LIFT POS=1 POS_LIMIT=40]\nG01 X120\n",
            ":5:6: error 120604: ",
            ": lift 1: from line 4, ",  # open where execution stops, closed by nothing else
        ),
    ],
)
def test_a_refused_lift_command_is_one_error_and_its_lift_end_none(
    tmp_path: Path, body: str, first: str, listing: str
) -> None:
    program = tmp_path / "refused.nc"
    program.write_text(HEADER + body + "Z[LIFT_END]\nM30\n")
    r = liftd("check", "-c", str(REPO / "config" / "liftd.toml"), str(program))
    assert r.returncode == 1
    assert [line.startswith(f"{program}{first}") for line in r.stderr.splitlines()] == [True]
    ranges = [line for line in r.stdout.splitlines() if ": lift " in line]
    assert [line.startswith(f"{program}{listing}") for line in ranges] == (
        [True] if listing else []
    )


def test_a_range_from_a_subroutine_file_into_the_program_names_both_files(
    tmp_path: Path,
) -> None:
    (tmp_path / "liftsub.nc").write_text("Z[LIFT_START POS=1 POS_LIMIT=40]\nG01 X300 F24000\nM17\n")
    program = tmp_path / "main2.nc"
    program.write_text(HEADER + "L liftsub.nc\nG01 X400\nZ[LIFT_END]\nM30\n")
    r = liftd("check", "-c", str(REPO / "config" / "liftd.toml"), str(program))
    assert r.returncode == 0, r.stderr
    assert f"{program}: lift 1: lines {tmp_path / 'liftsub.nc'}:1 to {program}:6, " in r.stdout


def config_cases() -> list[Path]:
    return sorted((GOLDEN / "config" / "bad").glob("*/liftd.toml"))


@pytest.mark.parametrize("config", config_cases(), ids=lambda p: p.parent.name)
def test_golden_bad_configurations(config: Path) -> None:
    """Each broken liftd.toml says on its first line what `liftd check` must answer."""
    m = re.match(r"# expect (\d): (.+)$", config.read_text().splitlines()[0])
    assert m, "first line must be '# expect <exit code>: <text in the first message>'"
    r = liftd("check", "-c", str(config))
    assert r.returncode == int(m.group(1)), r.stderr
    assert m.group(2) in r.stderr.splitlines()[0], r.stderr


def test_unreadable_program_is_a_program_error(tmp_path: Path) -> None:
    r = liftd("check", "-c", str(REPO / "config" / "liftd.toml"), str(tmp_path / "none.nc"))
    assert r.returncode == 1 and "cannot read program" in r.stderr


def test_wheel_ships_the_default_config_and_runs_from_anywhere(tmp_path: Path) -> None:
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            "--no-deps",
            "--no-build-isolation",
            "-q",
            "-w",
            str(tmp_path / "dist"),
            str(REPO),
        ],
        check=True,
        timeout=120,
    )
    (wheel,) = (tmp_path / "dist").glob("liftd-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    assert "liftd/_config/liftd.toml" in names
    assert "liftd/_config/programs/demo.nc" in names
    assert "liftd/_config/cnc/hochlauf.lis" in names
    target = tmp_path / "site"
    with zipfile.ZipFile(wheel) as zf:
        zf.extractall(target)
    env = {**os.environ, "PYTHONPATH": str(target)}
    env.pop("LIFTD_CONFIG", None)
    work = tmp_path / "elsewhere"
    work.mkdir()
    r = liftd("check", cwd=work, env=env)
    assert r.returncode == 0, r.stderr
    assert str(target / "liftd" / "_config" / "liftd.toml") in r.stdout
