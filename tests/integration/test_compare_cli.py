"""`liftd simulate PROGRAM --compare`: both lift methods on the user's program, paired per lift."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

from liftd.sim import plot
from tests.integration.test_simulate_cli import CONTRACT_COLUMNS, DEMO, LIFT_KEYS, simulate

pytestmark = pytest.mark.integration


@pytest.fixture(scope="module")
def compared(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict, Path, Path]:
    out = tmp_path_factory.mktemp("compare")
    png = out / "cmp.png"
    trace = out / "run.csv"
    args = ["--compare", "--json", "--trace", str(trace)]
    if plot.available():
        args += ["--plot", str(png)]
    r = simulate(DEMO, *args)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout), png, out


def test_both_runs_and_their_lifts_are_paired(compared: tuple[dict, Path, Path]) -> None:
    summary, _, _ = compared
    assert summary["advanced"]["method"] == "advanced"
    assert summary["lifting"]["method"] == "lifting"
    pairs = summary["lifts"]
    assert [p["start_line"] for p in pairs] == [
        x["start_line"] for x in summary["advanced"]["lifts"]
    ]
    assert len(pairs) == 5
    for p in pairs:
        assert set(p["advanced"]) == LIFT_KEYS and set(p["lifting"]) == LIFT_KEYS
        assert p["advanced"]["z_a_max_ratio"] <= 1.0 + 1e-9
        assert p["advanced"]["arrival_error"] <= 1e-3 and p["lifting"]["arrival_error"] <= 1e-3
        if p["advanced"]["suppressed"]:
            assert p["clearance_ratio"] is None  # nothing lifted: no ratio
            continue
        # the reason for Advanced Lifting: at least the clearance on every lift
        assert p["clearance_ratio"] >= 1.0
        assert p["clearance_ratio"] == pytest.approx(
            p["advanced"]["mean_clearance"] / p["lifting"]["mean_clearance"], rel=1e-5
        )
    totals = summary["totals"]
    assert totals["min_clearance_ratio"] == min(
        p["clearance_ratio"] for p in pairs if p["clearance_ratio"]
    )


def test_compare_writes_one_trace_per_method(compared: tuple[dict, Path, Path]) -> None:
    summary, _, out = compared
    for method in ("advanced", "lifting"):
        with (out / f"run.{method}.csv").open(newline="") as f:
            rows = list(csv.reader(f))
        assert rows[0][: len(CONTRACT_COLUMNS)] == CONTRACT_COLUMNS
        assert len(rows) - 1 == summary[method]["cycles"]


@pytest.mark.skipif(not plot.available(), reason="matplotlib not installed")
def test_compare_plot_is_a_png(compared: tuple[dict, Path, Path]) -> None:
    _, png, _ = compared
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 50000


def test_override_above_100_overloads_only_path_based_lifting() -> None:
    """Path-based Lifting keeps Z within a_max at 100 % (issue 37 item 3); an override above
    it scales Z's acceleration with its square (vendor §2.2.1, §2.5), here beyond the
    P-AXIS-00441 warning level; Advanced Lifting never overloads Z."""
    runs = {}
    for pct in (100, 200):
        r = simulate(DEMO, "--compare", "--json", "--override", f"0:{pct}")
        assert r.returncode == 0, r.stderr
        runs[pct] = json.loads(r.stdout)
    for summary in runs.values():
        assert summary["totals"]["z_a_max_ratio"]["advanced"] <= 1.0 + 1e-9
        assert summary["advanced"]["z_overload"]["error_cycles"] == 0
    assert runs[100]["totals"]["z_a_max_ratio"]["lifting"] <= 1.0
    assert runs[100]["lifting"]["z_overload"]["warning_cycles"] == 0
    assert runs[200]["totals"]["z_a_max_ratio"]["lifting"] > 1.5  # above the P-AXIS-00441 level
    assert runs[200]["lifting"]["z_overload"]["warning_cycles"] > 0


def test_compare_table_and_bad_arguments(tmp_path: Path) -> None:
    r = simulate(DEMO, "--compare", "--method", "lifting")
    assert r.returncode == 2 and "--compare runs both methods" in r.stderr
    prog = tmp_path / "down.nc"
    prog.write_text(
        "G01 X10 Y10 Z30 F6000\nZ[LIFT_START DOWN POS=30 POS_LIMIT=2]\nX200\nZ[LIFT_END]\nM30\n"
    )
    r = simulate(str(prog), "--compare")
    assert r.returncode == 1  # DOWN is an NC error for path-based Lifting only
    assert f"{prog}:2: error 990006:" in r.stderr and "(lifting run)" in r.stderr
    assert "(advanced run)" not in r.stderr
    assert "clearance adv" in r.stdout  # the table still shows what ran
