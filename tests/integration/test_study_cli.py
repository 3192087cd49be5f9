"""`liftd study` as a machine builder runs it: a library of NC programs (the shipped demo, the
CAM corpus, one program with an NC error) through `simulate --compare` in parallel, into
report.csv, report.json and a self-contained report.html (issue 18 item 3)."""

from __future__ import annotations

import csv
import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from liftd import cli
from liftd.sim import plot
from tests.support.paths import GOLDEN, REPO

pytestmark = pytest.mark.integration
CONFIG = str(REPO / "config" / "liftd.toml")
ERROR_PROGRAM = (  # an unknown word inside a lift range: exit 1, the range open at the stop
    "G90 G17 G94\nG01 X10 Y10 Z1 F6000\nZ[LIFT_START POS=1 POS_LIMIT=40]\n"
    "G01 X150 F24000\nQ3\nX200\nZ[LIFT_END]\nM30\n"
)


def liftd(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "liftd", *args],
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
        cwd=cwd,
    )


@pytest.fixture(scope="module")
def studied(
    tmp_path_factory: pytest.TempPathFactory,
) -> tuple[subprocess.CompletedProcess[str], Path, list[Path]]:
    tmp = tmp_path_factory.mktemp("study")
    errors = tmp / "errors"
    errors.mkdir()
    (errors / "stops_in_a_lift.nc").write_text(ERROR_PROGRAM)
    out = tmp / "out"
    dirs = [REPO / "config" / "programs", GOLDEN / "nc" / "cam", errors]
    r = liftd("study", *map(str, dirs), "-c", CONFIG, "--jobs", "2", "--out", str(out))
    programs = sorted(p for d in dirs for p in d.glob("*.nc"))  # not cam/lib/: subroutines
    return r, out, programs


def compare_json(program: Path) -> dict:
    r = liftd("simulate", str(program), "-c", CONFIG, "--compare", "--json")
    assert r.returncode in (0, 1), r.stderr
    return json.loads(r.stdout)


def _mean(values: list[float]) -> float | None:
    return round(sum(values) / len(values), 6) if values else None


def expected_row(cmp: dict) -> dict:
    """A report row as the user would work it out from `simulate --compare --json`."""
    whole = [p for p in cmp["lifts"] if p["clearance_ratio"] is not None]
    adv = [p["advanced"] for p in whole]
    lift = [p["lifting"] for p in whole]
    totals = cmp["totals"]
    return {
        "lifts": len(cmp["lifts"]),
        "compared": len(whole),
        "clearance_advanced_mm": _mean([x["mean_clearance"] for x in adv]),
        "clearance_lifting_mm": _mean([x["mean_clearance"] for x in lift]),
        "clearance_ratio_mean": totals["mean_clearance_ratio"],
        "clearance_ratio_min": totals["min_clearance_ratio"],
        "peak_height_advanced_mm": _mean([abs(x["peak"] - x["z_start"]) for x in adv]),
        "peak_height_lifting_mm": _mean([abs(x["peak"] - x["z_start"]) for x in lift]),
        "duration_advanced_s": totals["duration_s"]["advanced"],
        "duration_lifting_s": totals["duration_s"]["lifting"],
        "time_difference_s": round(
            totals["duration_s"]["lifting"] - totals["duration_s"]["advanced"], 6
        ),
        "lifting_z_overload_cycles": totals["z_overload_cycles"]["lifting"],
        "lifting_z_error_cycles": cmp["lifting"]["z_overload"]["error_cycles"],
        "lifting_z_a_max_ratio": totals["z_a_max_ratio"]["lifting"],
        "errors": [
            {"method": m, "id": e["id"], "line": e["line"], "message": e["message"]}
            for m in ("advanced", "lifting")
            for e in cmp[m]["errors"]
        ],
    }


def test_study_reports_every_program_and_exits_1_for_the_error(
    studied: tuple[subprocess.CompletedProcess[str], Path, list[Path]],
) -> None:
    r, out, programs = studied
    assert r.returncode == 1, r.stderr  # one program had an NC error: reported, not fatal
    assert len(programs) == 7
    assert re.search(r"stops_in_a_lift\.nc: error: advanced run, line 5: error 990018: ", r.stderr)
    assert "study: 7 programs (6 ok, 1 error)" in r.stdout
    for name in ("report.csv", "report.json", "report.html"):
        assert (out / name).stat().st_size > 0
    assert sorted(p.name for p in out.iterdir()) == ["report.csv", "report.html", "report.json"]


def test_rows_match_simulate_compare_of_the_same_program(
    studied: tuple[subprocess.CompletedProcess[str], Path, list[Path]],
) -> None:
    _, out, programs = studied
    report = json.loads((out / "report.json").read_text())
    rows = {Path(row["program"]).name: row for row in report["programs"]}
    assert sorted(rows) == sorted(p.name for p in programs)
    with (out / "report.csv").open(newline="") as f:
        table = {Path(row["program"]).name: row for row in csv.DictReader(f)}
    assert sorted(table) == sorted(rows)
    for program in programs:
        row = rows[program.name]
        want = expected_row(compare_json(program))
        errors = want.pop("errors")
        assert {k: row[k] for k in want} == pytest.approx(want, abs=1e-6), program.name
        assert row["errors"] == errors
        assert row["status"] == ("error" if errors else "ok")
        assert table[program.name]["lifts"] == str(want["lifts"])
        assert table[program.name]["errors"] == str(len(errors))
    stopped = rows["stops_in_a_lift.nc"]
    assert stopped["open"] == 1 and stopped["compared"] == 0  # one range, open in both runs
    assert "line 5: error 990018" in table["stops_in_a_lift.nc"]["why"]


def test_summary_over_all_programs(
    studied: tuple[subprocess.CompletedProcess[str], Path, list[Path]],
) -> None:
    _, out, _ = studied
    report = json.loads((out / "report.json").read_text())
    rows, s = report["programs"], report["summary"]
    ok = [row for row in rows if row["status"] == "ok"]
    assert s["programs"] == 7 and s["status"]["ok"] == 6 and s["status"]["error"] == 1
    assert s["lifts"] == sum(row["lifts"] for row in rows)
    assert s["compared"] == sum(row["compared"] for row in rows)
    assert s["finished"] == 6
    assert s["duration_advanced_s"] == pytest.approx(sum(row["duration_advanced_s"] for row in ok))
    assert s["lifting_z_overload_cycles"] == sum(row["lifting_z_overload_cycles"] for row in ok)
    assert s["clearance_ratio_min"] == min(r["clearance_ratio_min"] for r in ok)
    assert s["clearance_ratio_of_means"] >= 1.0  # Advanced keeps Z higher on this library
    assert sum(s["clearance_ratio_histogram"]["counts"]) == s["compared"]
    assert s["errors_by_id"] == {"990018": 2}  # both runs
    assert report["run"]["jobs"] == 2 and report["run"]["max_rss_mib"]["worker"] > 0
    assert report["study"]["programs"] == 7


def test_html_is_self_contained_with_tables_and_figures(
    studied: tuple[subprocess.CompletedProcess[str], Path, list[Path]],
) -> None:
    _, out, programs = studied
    page = (out / "report.html").read_text()
    assert page.startswith("<!DOCTYPE html>") and page.rstrip().endswith("</html>")
    assert not re.search(r"""(src|href)=["']?(https?:|//)""", page)  # nothing fetched
    for program in programs:
        assert program.name in page
    assert "Summary over all programs" in page and "1 programs did not run to the end" in page
    if plot.available():
        assert page.count("src='data:image/png;base64,") == 4
    else:
        assert "pip install liftd[plot]" in page


def test_without_matplotlib_the_report_has_the_tables_and_says_how_to_get_figures(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setattr(plot, "available", lambda: False)
    demo = str(REPO / "config" / "programs" / "demo.nc")
    code = cli.main(["study", demo, "-c", CONFIG, "--jobs", "1", "--out", str(tmp_path)])
    assert code == 0, capsys.readouterr().err
    page = (tmp_path / "report.html").read_text()
    assert "pip install liftd[plot]" in page and "data:image/png" not in page
    assert "demo.nc" in page and "study: 1 programs (1 ok)" in capsys.readouterr().out


def test_configuration_and_argument_errors_exit_2(tmp_path: Path) -> None:
    demo = str(REPO / "config" / "programs" / "demo.nc")
    r = liftd("study", demo, "-c", str(tmp_path / "none.toml"), "--out", str(tmp_path / "a"))
    assert r.returncode == 2
    config = tmp_path / "config"
    shutil.copytree(REPO / "config", config)
    toml = config / "liftd.toml"
    toml.write_text(toml.read_text().replace("cycle_time_us = 1000", "cycle_time_us = -5"))
    r = liftd("study", demo, "-c", str(toml), "--out", str(tmp_path / "b"))
    assert r.returncode == 2 and "cycle_time_us" in r.stderr
    r = liftd("study", demo, "-c", CONFIG, "--jobs", "0", "--out", str(tmp_path / "c"))
    assert r.returncode == 2 and "--jobs" in r.stderr
    (tmp_path / "empty").mkdir()
    r = liftd("study", str(tmp_path / "empty"), "-c", CONFIG, "--out", str(tmp_path / "d"))
    assert r.returncode == 2 and "no NC programs" in r.stderr
    assert not any((tmp_path / d).exists() for d in "abcd")  # nothing written


def test_an_unreadable_program_is_a_row_and_exit_1(tmp_path: Path) -> None:
    missing = tmp_path / "missing.nc"
    r = liftd("study", str(missing), "-c", CONFIG, "--jobs", "1", "--out", str(tmp_path / "o"))
    assert r.returncode == 1 and "missing.nc: unreadable: cannot read program: " in r.stderr
    rows = list(csv.DictReader((tmp_path / "o" / "report.csv").open(newline="")))
    assert [(row["status"], row["lifts"]) for row in rows] == [("unreadable", "0")]
