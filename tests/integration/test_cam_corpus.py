"""The CAM-shaped corpus (issue 19): every program in tests/golden/nc/cam/ through `liftd check`,
`liftd simulate` and `liftd simulate --compare`, as a user runs them; subroutine files found
next to the program, in [nc] subroutine_dirs, ignoring case; missing and unreadable files."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from liftd.cnc.params import SlopeType
from liftd.cnc.path.limits import transition_allowance
from liftd.settings import load_settings
from tests.integration.test_cli_check import liftd as run_liftd
from tests.support.paths import GOLDEN, REPO

pytestmark = pytest.mark.integration
CAM = GOLDEN / "nc" / "cam"
CONFIG = str(REPO / "config" / "liftd.toml")
# the warnings each program may give (ids); anything else on stderr fails the test
WARNINGS: dict[str, set[int]] = {
    "issue19_small": {990026},  # #HSC ON runs unsmoothed
    "nest_local_subs": {990026},
    "row_sequence": {990026},  # G261
    "two_sheets_global": set(),
    "inch_reference_point": set(),
}


def _allowed() -> dict[str, dict[str, float]]:
    ch = load_settings(CONFIG).channel
    allow = transition_allowance(ch.axes, ch.cycle_time, ch.slope is not SlopeType.STEP,
                                 ch.corr_v_trans_jerk, ch.mode_trans_jerk)  # fmt: skip
    out = {ax.name.lower(): {"a": max(1.0, a), "j": max(1.0, j)}
           for ax, (a, j) in zip(ch.axes, allow, strict=True)}  # fmt: skip
    out["path_z"] = out.get("z", {"a": 1.0, "j": 1.0})
    return out


ALLOWED = _allowed()


def _key(name: str) -> tuple[str, str, str]:
    """(axis prefix, "segment" | "transition" | "run", derivative) of a `limits` key."""
    stem = name.removesuffix("_max_ratio")
    stem, derivative = stem.rsplit("_", 1)
    for kind in ("segment", "transition"):
        if stem.endswith("_" + kind):
            return stem.removesuffix("_" + kind), kind, derivative
    return stem, "run", derivative


def liftd(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    return run_liftd(*args, cwd=cwd, timeout=300)  # simulate --compare on a shared VM


def programs() -> list[Path]:
    return sorted(CAM.glob("*.nc"))


def test_the_corpus_is_what_the_expectations_name() -> None:
    assert {p.stem for p in programs()} == set(WARNINGS)


@pytest.mark.parametrize("program", programs(), ids=lambda p: p.stem)
def test_check_simulate_and_compare(program: Path) -> None:
    r = liftd("check", "-c", CONFIG, str(program))
    assert r.returncode == 0, r.stderr
    ids = {int(m) for m in re.findall(r": warning (\d+): ", r.stderr)}
    assert ids == WARNINGS[program.stem], r.stderr
    assert len(r.stderr.splitlines()) == len(WARNINGS[program.stem]), r.stderr  # one per kind
    m = re.search(r": ok \((\d+) blocks, (\d+) lift ranges\)", r.stdout)
    assert m, r.stdout
    lifts = int(m.group(2))
    assert lifts >= 1
    assert r.stdout.splitlines()[-1].startswith(f"{program}: not emulated: ")

    sim = liftd("simulate", "-c", CONFIG, str(program), "--json")
    assert sim.returncode == 0, sim.stderr
    summary = json.loads(sim.stdout)
    assert summary["errors"] == []
    assert len(summary["lifts"]) == lifts
    # the compensated path keeps the dynamics: in the segments the axes' limits, over block
    # transitions what the block-transition parameters allow (issue 36)
    for name, ratio in summary["limits"].items():
        axis, kind, derivative = _key(name)
        top = 1.0 if kind == "segment" or derivative == "v" else ALLOWED[axis][derivative]
        assert ratio <= top * (1.0 + 1e-9), (name, ratio, top)
    assert all(lift["arrival_error"] <= 1e-6 for lift in summary["lifts"])

    cmp = liftd("simulate", "-c", CONFIG, str(program), "--compare", "--json")
    assert cmp.returncode == 0, cmp.stderr
    both = json.loads(cmp.stdout)
    assert len(both["advanced"]["lifts"]) == len(both["lifting"]["lifts"]) == lifts
    assert both["totals"]["min_clearance_ratio"] >= 1.0


def test_subroutine_dirs_and_names_that_differ_in_case(tmp_path: Path) -> None:
    """`L FLANGE_D80.NC` finds lib/flange_d80.nc through [nc] subroutine_dirs."""
    config = tmp_path / "config"
    shutil.copytree(REPO / "config", config)
    (config / "liftd.toml").write_text(
        (config / "liftd.toml").read_text() + '\n[nc]\nsubroutine_dirs = ["../library"]\n'
    )
    shutil.copytree(CAM / "lib", tmp_path / "library")
    program = tmp_path / "jobs" / "job.nc"
    program.parent.mkdir()
    program.write_text("G90 G17 D1\nG00 X0 Y0 Z1\nP1=60 P2=60\nL FLANGE_D80.NC\nM30\n")
    r = liftd("check", "-c", str(config / "liftd.toml"), str(program))
    assert r.returncode == 0, r.stderr
    assert "ok (" in r.stdout


def test_missing_and_unreadable_files_name_file_line_and_call_chain(tmp_path: Path) -> None:
    program = tmp_path / "job.nc"
    (tmp_path / "outer.nc").write_text("G01 X1 F100\nL unreadable.nc\nM17\n")
    (tmp_path / "unreadable.nc").mkdir()  # a directory: exists, but cannot be read as a file
    program.write_text("G00 X5\nL missing.nc\nL outer.nc\nM30\n")
    r = liftd("check", "-c", CONFIG, str(program))
    assert r.returncode == 1
    lines = r.stderr.splitlines()
    assert lines[0].startswith(f"{program}:2:1: error 990021: L missing.nc: global subroutine not")
    assert re.match(
        rf"{re.escape(str(tmp_path / 'outer.nc'))}:2:1: error 990021: L unreadable.nc: "
        r"global subroutine cannot be read: .* \(call chain: .*job\.nc:3 L outer\.nc\)$",
        lines[1],
    ), lines[1]
    sim = liftd("simulate", "-c", CONFIG, str(program), "--json")
    assert sim.returncode == 1  # the trace holds what executed: the G00 before the call
    assert json.loads(sim.stdout)["errors"][0]["id"] == 990021


def test_recursion_and_huge_repetitions_are_errors_not_crashes(tmp_path: Path) -> None:
    program = tmp_path / "job.nc"
    (tmp_path / "self.nc").write_text("G91 G01 X0.01 F1000\nL self.nc\nM17\n")
    program.write_text("G00 X5\nL self.nc\nM30\n")
    r = liftd("check", "-c", CONFIG, str(program))
    assert r.returncode == 1 and " error 20360: " in r.stderr
    program.write_text("%L s\nG91 G01 X0.001 F1000\nG90\nM17\n%m\nN1 LL s\nN2 M05\n"
                       "L SEQUENCE [N1 N2 REPEAT=1000000]\nM30\n")  # fmt: skip
    r = liftd("check", "-c", CONFIG, str(program))
    assert r.returncode == 1 and " error 990025: " in r.stderr  # [nc] max_executed_blocks
    sim = liftd("simulate", "-c", CONFIG, str(program), "--json")
    assert sim.returncode == 1 and json.loads(sim.stdout)["errors"][0]["id"] == 990025


def test_lift_to_pos_limit_over_a_short_rapid_travel(tmp_path: Path) -> None:
    """The old interpolator divided by zero in the override limit here (found by this test)."""
    program = tmp_path / "park.nc"
    program.write_text("G01 X10 Y10 F6000\nZ[LIFT_START POS=60 POS_LIMIT=60]\nG00 X0 Y0\n"
                       "Z[LIFT_END]\nM30\n")  # fmt: skip
    r = liftd("simulate", "-c", CONFIG, str(program))
    assert r.returncode == 0, r.stderr
