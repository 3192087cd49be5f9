"""The layering of liftd, read from the source with `ast` (no module is imported): who may
import whom, what the real-time GEO process may load, no import cycles, and every package
says in its docstring what it holds and may import (docs/architecture.md, "Import rules")."""

from __future__ import annotations

import ast
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from tests.support.paths import REPO

PACKAGE = REPO / "liftd"

# top-level part of liftd → the parts of liftd it may import (itself always)
ALLOWED: dict[str, set[str]] = {
    "cnc": set(),  # the pure core
    "ads": set(),  # the protocol layer knows nothing of the CNC
    "settings": {"cnc"},
    "objects": {"ads", "cnc"},
    "runtime": {"cnc"},
    "sim": {"cnc"},
    "clients": {"ads", "cnc"},
    "service": {"ads", "objects", "runtime", "settings", "cnc", "sim", "ui"},
    "ui": {"objects", "cnc", "settings"},  # the live view: no runtime, no ADS protocol
}
# the GEO process: these modules and all they import, transitively, at any depth
GEO_PROCESS_ROOTS = ("liftd.runtime.geo_loop", "liftd.runtime.__main__")
# the four the issue names, and what only the daemon needs (memory the RT process would lock)
GEO_PROCESS_FORBIDDEN = {"numpy", "matplotlib", "pyads", "structlog"} | {
    "pydantic",
    "uvloop",
    "asyncio",
    "prometheus_client",
    "dask",  # the study's cluster client (liftd.sim.cluster)
    "distributed",
    "aiohttp",  # the live view's server (liftd/ui)
}


@dataclass(frozen=True)
class Import:
    module: str  # absolute dotted name, e.g. liftd.cnc.geo_task or numpy.linalg
    line: int
    type_checking: bool  # only under `if TYPE_CHECKING:`


def module_name(path: Path) -> str:
    parts = path.relative_to(REPO).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def is_package(path: Path) -> bool:
    return path.name == "__init__.py"


def modules() -> dict[str, Path]:
    return {module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def imports(path: Path, known: set[str]) -> list[Import]:
    """Every import statement of a module, anywhere in it (also inside functions: a lazy
    import still runs in the process that calls it), resolved to absolute names; `from a
    import b` counts as a.b when a.b is a module of liftd."""
    name = module_name(path)
    package = name if is_package(path) else name.rpartition(".")[0]
    tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
    guarded: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and _is_type_checking(node.test):
            for child in node.body:
                guarded.update(id(n) for n in ast.walk(child))
    out: list[Import] = []
    for node in ast.walk(tree):
        tc = id(node) in guarded
        if isinstance(node, ast.Import):
            out += [Import(a.name, node.lineno, tc) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target == "__future__":
                continue
            subs = [f"{target}.{a.name}" for a in node.names if f"{target}.{a.name}" in known]
            if len(subs) < len(node.names):  # some name comes from the module itself
                out.append(Import(target, node.lineno, tc))
            out += [Import(sub, node.lineno, tc) for sub in subs]
    return out


def _liftd_targets(name: str, known: set[str]) -> Iterator[str]:
    """An import of a.b.c loads the packages a, a.b and the module a.b.c."""
    parts = name.split(".")
    for i in range(1, len(parts) + 1):
        prefix = ".".join(parts[:i])
        if prefix in known:
            yield prefix


GRAPH = modules()
KNOWN = set(GRAPH)
IMPORTS = {name: imports(path, KNOWN) for name, path in GRAPH.items()}


def part(name: str) -> str:
    """liftd.cnc.nc.decoder → cnc; liftd.cli → cli; liftd → ''."""
    parts = name.split(".")
    return parts[1] if len(parts) > 1 else ""


@pytest.mark.parametrize("layer", sorted(ALLOWED))
def test_each_layer_imports_only_what_it_may(layer: str) -> None:
    wrong = []
    for name, found in IMPORTS.items():
        if part(name) != layer:
            continue
        for imp in found:
            if not imp.module.startswith("liftd.") or imp.module in ("liftd",):
                continue
            target = part(imp.module)
            if target != layer and target not in ALLOWED[layer]:
                wrong.append(f"{GRAPH[name].relative_to(REPO)}:{imp.line} imports {imp.module}")
    assert not wrong, f"liftd.{layer} may import {sorted(ALLOWED[layer]) or 'nothing'}:\n" + (
        "\n".join(wrong)
    )


def test_the_root_package_imports_nothing() -> None:
    assert not [i for i in IMPORTS["liftd"] if i.module != "__future__"]


def geo_process_modules() -> dict[str, str]:
    """Every liftd module the GEO process loads → the module that first pulled it in."""
    seen: dict[str, str] = {}
    todo = [(root, "(root)") for root in GEO_PROCESS_ROOTS]
    while todo:
        name, via = todo.pop()
        for target in _liftd_targets(name, KNOWN):
            if target in seen:
                continue
            seen[target] = via
            todo += [
                (imp.module, target)
                for imp in IMPORTS[target]
                if not imp.type_checking and imp.module.split(".")[0] == "liftd"
            ]
    return seen


def test_the_geo_process_loads_no_heavy_or_daemon_side_library() -> None:
    loaded = geo_process_modules()
    assert set(GEO_PROCESS_ROOTS) <= set(loaded)
    bad = [
        f"{GRAPH[name].relative_to(REPO)}:{imp.line} imports {imp.module} (via {via})"
        for name, via in loaded.items()
        for imp in IMPORTS[name]
        if not imp.type_checking and imp.module.split(".")[0] in GEO_PROCESS_FORBIDDEN
    ]
    assert not bad, "\n".join(bad)
    outside = sorted(n for n in loaded if part(n) not in ("", "runtime", "cnc"))
    assert not outside, f"the GEO process loads liftd modules outside runtime and cnc: {outside}"


def test_no_import_cycles_between_liftd_modules() -> None:
    """Tarjan's strongly connected components over every import (TYPE_CHECKING ones too: a
    type-only cycle is still two modules that cannot be understood apart)."""
    edges = {
        name: {imp.module for imp in found if imp.module in KNOWN and imp.module != name}
        for name, found in IMPORTS.items()
    }  # the module named (its parent packages load first, but re-exporting is no cycle)
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    cycles: list[list[str]] = []
    counter = [0]

    def visit(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in edges[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            scc = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                scc.append(w)
                if w == v:
                    break
            if len(scc) > 1:
                cycles.append(sorted(scc))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    assert not cycles, cycles


@pytest.mark.parametrize("layer", sorted(ALLOWED))
def test_every_package_says_what_it_holds_and_may_import(layer: str) -> None:
    doc = ast.get_docstring(ast.parse((PACKAGE / layer / "__init__.py").read_text())) or ""
    assert len(doc.split()) >= 12, f"liftd/{layer}/__init__.py: say what the package holds"
    assert "import" in doc.lower(), f"liftd/{layer}/__init__.py: say what it may import"
    for other in ALLOWED[layer]:
        assert f"liftd.{other}" in doc or f"`{other}`" in doc, (
            f"liftd/{layer}/__init__.py: name liftd.{other}, which it may import"
        )
