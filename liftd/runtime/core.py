"""Which GEO core runs: the modules of `liftd.cnc.COMPILED` as mypyc extensions (`make core`,
tools/compile_core.py) or as Python. Read from the import system and the sources' hashes that
the build recorded (`liftd/_core_sources.json`), nothing is imported; the daemon logs it
(`daemon.ready core=…`) and `liftd --version` prints it."""

from __future__ import annotations

import hashlib
import importlib.machinery
import importlib.util
import json
from pathlib import Path

from liftd.cnc import COMPILED
from liftd.runtime import COMPILED as RUNTIME

EXTENSION = (".so", ".pyd")
SOURCES = "_core_sources.json"  # {module: sha256 of its source when it was compiled}


def source_hash(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def core_build() -> str:
    """How the GEO core's cycle runs: `build_state` of the core's modules (`liftd.cnc.COMPILED`)
    and the GEO loop's (`liftd.runtime.COMPILED`)."""
    return build_state(COMPILED + RUNTIME)


def _origin(name: str) -> str | None:
    """The file the import system finds for module `name`, by a fresh search of its package's
    path. Not `find_spec(name)`: for a module already imported it returns the module's own
    spec, and a module a compiled module imported (mypyc's shared group initialises it) has a
    wrong one (`liftd/liftd/cnc/…`), which read as a stale build once `liftd.sim` was
    imported first."""
    parent = name.rpartition(".")[0]
    package = importlib.util.find_spec(parent) if parent else None
    search = package.submodule_search_locations if package is not None else None
    spec = importlib.machinery.PathFinder.find_spec(name, None if search is None else list(search))
    return spec.origin if spec is not None else None


def build_state(modules: tuple[str, ...]) -> str:
    """`compiled` (every module an extension built from the source next to it), `stale` (an
    extension built from another source than the one next to it, or without a record: Python
    imports the extension, so an edit does not run until `make core`), or `python` (not
    compiled, or only partly). By content, not file times (a wheel's install sets those)."""
    compiled = 0
    recorded: dict[str, str] | None = None
    for name in modules:
        origin = _origin(name)
        if origin is None or not origin.endswith(EXTENSION):
            continue
        ext = Path(origin)
        if recorded is None:
            package = ext.parents[len(name.split(".")) - 2]  # the directory of `liftd`
            try:
                recorded = json.loads((package / SOURCES).read_text(encoding="utf-8"))
            except (OSError, ValueError):
                return "stale"
        source = ext.parent / (name.rpartition(".")[2] + ".py")
        if source.exists() and recorded.get(name) != source_hash(source):
            return "stale"
        compiled += 1
    return "compiled" if compiled == len(modules) else "python"
