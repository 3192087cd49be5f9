"""`liftd check` prints one line per lift range (issue 15, "also in scope")."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.fidelity.test_s3_programming import SINGLE_ROW
from tests.integration.test_cli_check import liftd
from tests.support.paths import REPO

pytestmark = pytest.mark.integration


def test_check_lists_the_lift_ranges_of_the_vendor_single_row_example(tmp_path: Path) -> None:
    program = tmp_path / "single_row.nc"
    program.write_text(SINGLE_ROW)
    r = liftd("check", "-c", str(REPO / "config" / "liftd.toml"), str(program))
    assert r.returncode == 0, r.stderr
    lines = [line for line in r.stdout.splitlines() if ": lift " in line]
    assert len(lines) == 5
    assert lines[0].startswith(
        f"{program}: lift 1: line 2, single block, Advanced Lifting, Z 40.000 -> POS 30.000 mm, "
        "limit 150.000 mm (POS_LIMIT 300.000 held at the software limit), path 11.180 mm: "
        "lifts (planned peak "
    )
    # the planned peak and nominal time are what the GEO core does: simulate reports the same
    sim = liftd("simulate", "-c", str(REPO / "config" / "liftd.toml"), str(program), "--json")
    assert sim.returncode == 0, sim.stderr
    for line, lift in zip(lines, json.loads(sim.stdout)["lifts"], strict=True):
        nominal = lift["duration_s"] - lift["path_delay_s"]  # no waits in these ranges
        assert line.endswith(f"(planned peak {lift['peak']:.3f} mm, nominal {nominal:.3f} s)")
        assert max(lift["z_start"], lift["z_target"]) < lift["peak"] <= 150.0
    assert r.stderr.count("warning 990036: POS_LIMIT 300.0000 mm lies beyond") == 5
    assert r.stdout.splitlines()[-2] == f"{program}: ok (7 blocks, 5 lift ranges)"
