"""The compiled GEO core (mypyc, `make core`) computes exactly what its Python source does:
every field of every snapshot, bit for bit, on the demo, a nesting job under override steps
and feed holds, and random closed-loop runs of both lift methods. mypyc keeps Python's
semantics only as far as the types say (a narrowed attribute a call changes is a TypeError
there, not here), so the run itself is the test."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from liftd.cnc import COMPILED
from liftd.runtime.core import core_build
from tests.support.core_digest import digests
from tests.support.paths import REPO
from tests.support.pure_core import PureCore


def test_the_compiled_modules_are_the_ones_the_cycle_imports() -> None:
    """Every module named to be compiled exists as source (a renamed module would silently
    run as Python), and the build is current where one exists."""
    for name in COMPILED:
        assert (REPO / Path(*name.split("."))).with_suffix(".py").is_file(), name
    assert core_build() in ("compiled", "python"), "stale extensions: run `make core`"


@pytest.mark.skipif(core_build() != "compiled", reason="core not compiled (no C compiler)")
def test_compiled_core_equals_the_python_source_bit_for_bit(pure_core: PureCore) -> None:
    code = (
        "import json\nfrom tests.support.core_digest import digests\nprint(json.dumps(digests()))"
    )
    python = json.loads(pure_core.run(code))
    assert digests() == python


@pytest.mark.skipif(core_build() != "compiled", reason="core not compiled (no C compiler)")
def test_an_edited_source_makes_the_build_stale(tmp_path: Path) -> None:
    """Python imports the extension, not the edited source: the build says so (by content,
    so a wheel's install, which sets every file's time, is not taken for an edit)."""
    shutil.copytree(
        REPO / "liftd", tmp_path / "liftd", ignore=shutil.ignore_patterns("__pycache__")
    )
    code = "import sys; sys.path.insert(0, sys.argv[1]); from liftd.runtime.core import core_build; print(core_build())"

    def state() -> str:
        run = [sys.executable, "-c", code, str(tmp_path)]
        return subprocess.run(run, capture_output=True, text=True, check=True).stdout.strip()

    for path in (tmp_path / "liftd").rglob("*.py"):
        os.utime(path)  # newer than every extension: times do not count
    assert state() == "compiled"
    machine = tmp_path / "liftd" / "cnc" / "machine.py"
    machine.write_text(machine.read_text() + "# an edit\n")
    assert state() == "stale"


@pytest.mark.skipif(core_build() != "compiled", reason="core not compiled (no C compiler)")
def test_the_build_reads_the_same_whatever_was_imported_first() -> None:
    """A compiled module imported by another compiled one carries a wrong spec (mypyc's shared
    group names liftd/liftd/cnc/…): the build is read from the import path, not from it."""
    for first in ("liftd.sim.simulate", "liftd.sim.compare", "liftd.cnc.geo_task"):
        code = f"import {first}; from liftd.runtime.core import core_build; print(core_build())"
        out = subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=REPO
        ).stdout.strip()
        assert out == "compiled", first
