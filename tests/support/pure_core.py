"""The GEO core as Python source, in a subprocess: for what only the interpreted core allows
(patching a method of a compiled class to inject a fault) and for comparing the two.

`PureCore(root).run(code)` runs `code` with a copy of the tree that has no extensions first on
sys.path and returns its stdout; `root` is made once per test session."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

from tests.support.paths import REPO

SKIP = shutil.ignore_patterns("*.so", "__pycache__", "node_modules", ".hypothesis")


class PureCore:
    def __init__(self, root: Path) -> None:
        self.root = root
        for tree in ("liftd", "bench", "tests", "config"):
            shutil.copytree(REPO / tree, root / tree, ignore=SKIP)

    def run(self, code: str, timeout: float = 300.0) -> str:
        prologue = (
            f"import sys; sys.path.insert(0, {str(self.root)!r})\n"
            "import liftd.cnc.geo_task as _g\n"
            "assert _g.__file__.endswith('.py'), _g.__file__\n"
        )
        env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
        out = subprocess.run(
            [sys.executable, "-c", prologue + code],
            capture_output=True,
            text=True,
            timeout=timeout,
            cwd=self.root,
            env=env,
            check=False,
        )
        if out.returncode != 0:
            raise AssertionError(f"pure core run failed:\n{out.stderr}")
        return out.stdout
