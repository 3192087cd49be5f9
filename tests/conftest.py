from __future__ import annotations

import os
import shutil
from collections.abc import Callable
from pathlib import Path

import pytest
from hypothesis import settings

from liftd.cnc.params import AxisParams, ChannelParams, LiftMethod, MSync, SlopeType

# CI: derandomised and bounded; `HYPOTHESIS_PROFILE=dev` for longer local runs
settings.register_profile("ci", max_examples=150, deadline=None, derandomize=True)
settings.register_profile("dev", max_examples=5000, deadline=None)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))

REPO = Path(__file__).resolve().parents[1]
GOLDEN = REPO / "tests" / "golden"


def make_channel(
    method: LiftMethod = LiftMethod.ADVANCED,
    lift_min_dist: float = 0.0,
    cycle_time: float = 1e-3,
    slope: SlopeType = SlopeType.TRAPEZ,
    z_limits: tuple[float, float] = (-0.005, 0.15),
    xy: tuple[float, float, float] = (1.5, 10.0, 500.0),
    z: tuple[float, float, float] = (1.0, 10.0, 500.0),
    look_ahead: int = 120,
) -> ChannelParams:
    """The demo machine's channel without files (X, Y, Z; Z lifts)."""
    v, a, j = xy
    zv, za, zj = z
    return ChannelParams(
        channel_id=1,
        axes=(
            AxisParams("X", 1, v, a, j, -0.001, 3.01),
            AxisParams("Y", 2, v, a, j, -0.001, 1.51),
            AxisParams("Z", 3, zv, za, zj, *z_limits),
        ),
        lift_axis="Z",
        lift_method=method,
        cycle_time=cycle_time,
        lift_min_dist=lift_min_dist,
        slope=slope,
        look_ahead_blocks=look_ahead,
        m_synch=((4, MSync.MVS_SVS), (5, MSync.MOS), (8, MSync.MNS_SNS)),
    )


@pytest.fixture
def machine(tmp_path: Path) -> Callable[..., Path]:
    """Copy the shipped configuration into tmp_path, apply line edits, return liftd.toml.

    edits: {relative file: {key: new value or None to delete}}; a key that is not present is
    appended. Files given as plain text replace the file.
    """

    def build(edits: dict[str, dict[str, str | None] | str] | None = None) -> Path:
        root = tmp_path / "config"
        if not root.exists():
            shutil.copytree(REPO / "config", root)
        for rel, change in (edits or {}).items():
            path = root / rel
            if isinstance(change, str):
                path.write_text(change)
                continue
            lines = path.read_text().splitlines() if path.exists() else []
            done: set[str] = set()
            out = []
            for line in lines:
                parts = line.split(None, 1)
                key = parts[0] if parts else ""
                if key in change:
                    done.add(key)
                    if change[key] is not None:
                        out.append(f"{key} {change[key]}")
                    continue
                out.append(line)
            out.extend(f"{k} {v}" for k, v in change.items() if k not in done and v is not None)
            path.write_text("\n".join(out) + "\n")
        return root / "liftd.toml"

    return build
