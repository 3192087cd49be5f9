"""`liftd objects`: the catalogue a PLC programmer looks up addresses in."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

pytestmark = pytest.mark.integration


def objects(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "liftd", "objects", *args],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )


def test_table_names_the_vendor_addresses() -> None:
    r = objects()
    assert r.returncode == 0, r.stderr
    line = next(x for x in r.stdout.splitlines() if x.startswith("GEO.ch1.Z.lift_active"))
    assert line.split()[1:5] == ["0x121301", "0x00030095", "BOOLEAN", "-"]
    assert "gpAx[3].ipo_state.lift_suppressed" in r.stdout and "PLC.ch1.override" in r.stdout


def test_json_and_bad_config(tmp_path: object) -> None:
    data = json.loads(objects("--json").stdout)
    assert data["ams_ports"] == [551]
    rows = {o["symbol"]: o for o in data["objects"]}
    assert rows["GEO.ch1.path_velocity"]["index_offset"] == "0x00000015"
    assert rows["PLC.ch1.feed_hold"]["access"] == "read/write"
    r = objects("-c", "/nonexistent/liftd.toml")
    assert r.returncode == 2 and "liftd.toml" in r.stderr
