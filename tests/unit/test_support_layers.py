"""The tests hold the specification's checker and the program generators (tests/support);
bench/ imports them from there, never the reverse: no test imports bench (issue 40)."""

from __future__ import annotations

import ast

from tests.support.paths import REPO


def imported(path: str) -> set[str]:
    tree = ast.parse((REPO / path).read_text(), path)
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module)
    return names


def test_no_test_imports_bench() -> None:
    found = {
        str(p.relative_to(REPO)): sorted(
            m for m in imported(str(p.relative_to(REPO))) if m.split(".")[0] == "bench"
        )
        for p in (REPO / "tests").rglob("*.py")
        if "node_modules" not in p.parts
    }
    assert {path: mods for path, mods in found.items() if mods} == {}


def test_the_bench_checker_is_the_tests_one() -> None:
    """bench_lift_safety.py checks its runs with the tests' checker and scenarios."""
    mods = imported("bench/bench_lift_safety.py")
    assert {"tests.support.cycle_check", "tests.support.scenarios"} <= mods
