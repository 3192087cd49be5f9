"""Configurations to break: copies of the shipped ones in a temporary directory."""

from __future__ import annotations

import shutil
from pathlib import Path

from tests.support.paths import REPO


def copy_two_head_machine(tmp: Path) -> Path:
    """The two-head configuration (config/liftd-2ch.toml as tmp/liftd.toml, its lists and
    programs) in tmp."""
    config = REPO / "config"
    for d in ("cnc", "cnc-2ch", "programs"):
        shutil.copytree(config / d, tmp / d)
    shutil.copy(config / "liftd-2ch.toml", tmp / "liftd.toml")
    return tmp


def edit(path: Path, old: str, new: str) -> None:
    text = path.read_text()
    assert old in text, old
    path.write_text(text.replace(old, new))
