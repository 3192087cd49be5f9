"""The compiled GEO core (mypyc, `make core`) computes exactly what its Python source does:
every field of every snapshot, bit for bit, on the demo, a nesting job under override steps
and feed holds, and random closed-loop runs of both lift methods. mypyc keeps Python's
semantics only as far as the types say (a narrowed attribute a call changes is a TypeError
there, not here), so the run itself is the test."""

from __future__ import annotations

import json
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
