from __future__ import annotations

import os
import shutil
from collections.abc import Callable
from pathlib import Path

import pytest
from hypothesis import settings

from tests.support.paths import REPO
from tests.support.pure_core import PureCore

# CI: derandomised and bounded; `HYPOTHESIS_PROFILE=dev` for longer local runs
settings.register_profile("ci", max_examples=150, deadline=None, derandomize=True)
settings.register_profile("dev", max_examples=5000, deadline=None)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


def pytest_sessionstart(session: pytest.Session) -> None:
    """An edited core module whose old extension would run instead: test nothing."""
    from liftd import cnc, runtime, sim  # noqa: PLC0415
    from liftd.runtime.core import build_state  # noqa: PLC0415

    if build_state(cnc.COMPILED + sim.COMPILED + runtime.COMPILED) == "stale":
        pytest.exit("a compiled module was built from another source: run `make core`", 2)


@pytest.fixture(scope="session")
def pure_core(tmp_path_factory: pytest.TempPathFactory) -> PureCore:
    """The core as Python source in a subprocess (tests/support/pure_core.py)."""
    return PureCore(tmp_path_factory.mktemp("pure"))


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
