"""Which GEO core runs: the modules of `liftd.cnc.COMPILED` as mypyc extensions (`make core`,
tools/compile_core.py) or as Python. Read from the import system and file times, nothing is
imported; the daemon logs it (`daemon.ready core=…`) and `liftd --version` prints it."""

from __future__ import annotations

import importlib.util
from pathlib import Path

from liftd.cnc import COMPILED

EXTENSION = (".so", ".pyd")


def core_build() -> str:
    """How the GEO core's cycle runs: `build_state(liftd.cnc.COMPILED)`."""
    return build_state(COMPILED)


def build_state(modules: tuple[str, ...]) -> str:
    """`compiled` (every module an extension, none older than its source), `stale` (an
    extension older than the source next to it: Python imports the extension, so an edit does
    not run until `make core`), or `python` (not compiled, or only partly)."""
    compiled = 0
    for name in modules:
        spec = importlib.util.find_spec(name)
        origin = spec.origin if spec is not None else None
        if origin is None or not origin.endswith(EXTENSION):
            continue
        ext = Path(origin)
        source = ext.parent / (name.rpartition(".")[2] + ".py")
        if source.exists() and source.stat().st_mtime > ext.stat().st_mtime:
            return "stale"
        compiled += 1
    return "compiled" if compiled == len(modules) else "python"
