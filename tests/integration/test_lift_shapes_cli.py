"""Issue 37's program shapes through the user's commands, both lift methods: `liftd run --trace`
writes the same trace as `liftd simulate --trace`, cycle for cycle, and `simulate --compare`
reports them as the core runs them (a #FLUSH inside a range, a range from rest, a programmed
feed drop, an NC error in a range whose POS lies above POS_LIMIT)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from tests.support.daemon import Daemon, write_config
from tests.support.paths import REPO
from tests.support.wait import wait_for

SHAPES = (
    "N10 G01 X10 Y10 F6000\nN20 X40 Z2\n"
    "N30 Z[LIFT_START POS=12 POS_LIMIT=40]\nN40 X150\nN50 X140\nN60 #FLUSH\nN70 X90\nN80 X40\n"
    "N90 Z[LIFT_END]\nN100 G04 0.05\n"
    "N110 Z[LIFT_START POS=2 POS_LIMIT=40]\nN120 X140\nN130 Z[LIFT_END]\nN140 G04 0.05\n"
    "N150 Z[LIFT_START POS=2 POS_LIMIT=40]\nN160 X240 F12000\nN170 X340 F6000\n"
    "N180 Z[LIFT_END]\nM30\n"
)
ERROR = (
    "N10 G01 X0 Y0 Z10 F6000\nN20 Z[LIFT_START POS=40 POS_LIMIT=30]\nN30 X10\nN40 X20\n"
    "N50 X35 ?!\nN60 X50\nN70 Z[LIFT_END]\nM30\n"
)
LISTS = {"advanced": "cnc/hochlauf.lis", "lifting": "cnc-lifting/hochlauf.lis"}


def _simulate(cfg: Path, program: Path, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "liftd", "simulate", str(program), "-c", str(cfg), *args],
        capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip


@pytest.mark.parametrize("method", LISTS)
@pytest.mark.parametrize("text", [SHAPES, ERROR], ids=["shapes", "error"])
def test_run_trace_is_simulate_s_trace(tmp_path: Path, text: str, method: str) -> None:
    program = tmp_path / "job.nc"
    program.write_text(text)
    lists = str(REPO / "config" / LISTS[method])
    cfg = write_config(tmp_path, program_file=str(program), cnc={"startup_list": lists})
    sim = tmp_path / "sim.csv"
    r = _simulate(cfg, program, "--trace", str(sim), "--json")
    assert r.returncode == (1 if text is ERROR else 0), r.stderr
    expected = sim.read_text().splitlines()
    trace = tmp_path / "run.csv"
    d = Daemon(cfg, "--trace", str(trace))
    try:
        d.ready()
        end = "geo.error" if text is ERROR else "geo.program_end"
        assert d.event(end, 30) is not None
        # after an error the channel stays in ERROR and the run's trace goes on: as far as
        # simulate's, which ends with Z at rest at its height
        assert wait_for(lambda: len(trace.read_text().splitlines()) > len(expected), 10.0)
    finally:
        assert d.stop() == 0
    got = trace.read_text().splitlines()
    assert len(got) >= len(expected) > 300
    assert got[: len(expected)] == expected  # every cycle, bit for bit
    if text is ERROR:
        (lift,) = json.loads(r.stdout)["lifts"]
        assert lift["open"] and lift["peak"] == 40.0 and lift["arrival_error"] == 0.0


def test_compare_reports_the_shapes(tmp_path: Path) -> None:
    program = tmp_path / "job.nc"
    program.write_text(SHAPES)
    cfg = write_config(tmp_path, program_file=str(program))
    r = _simulate(cfg, program, "--compare", "--json")
    assert r.returncode == 0, r.stderr
    summary = json.loads(r.stdout)
    advanced, lifting = summary["advanced"], summary["lifting"]
    assert len(advanced["lifts"]) == len(lifting["lifts"]) == 3  # the flush splits no range
    assert all(x["arrival_error"] == 0.0 for x in advanced["lifts"] + lifting["lifts"])
    assert all(x["z_a_max_ratio"] <= 1.0 for x in lifting["lifts"])  # 100 %: within a_max
    assert lifting["limits"]["z_j_max_ratio"] <= 1.0 + 1e-9
    assert lifting["z_overload"]["warning_cycles"] == 0
    assert advanced["lifts"][0]["peak"] == lifting["lifts"][0]["peak"] == 40.0
