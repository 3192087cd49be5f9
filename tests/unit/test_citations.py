"""Every document the code and the docs cite is in the repository (issue 40 item 4).

A contributor who clones liftd must be able to follow a citation such as
`docs/reference/isg-cnc.md §3.1`: a citation that names a file outside the tree (the project's
old `DESIGN.md`, `reference/*.md` or `seeds/` next to the repository) or a `docs/…` file that does
not exist fails here, with the file and line that cites it."""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.support.paths import REPO

SCANNED = ("liftd", "tests", "bench", "tools", "docs", "config", "systemd", "docker")
ROOT_FILES = ("README.md", "Makefile", "Dockerfile", "pyproject.toml", "mkdocs.yml")
SUFFIXES = {".py", ".md", ".txt", ".toml", ".yml", ".lis", ".nc", ".service", ".rules", ""}

# A repository path under docs/ that a text names: docs/reference/ads.md, docs/ui.png, …
DOCS_PATH = re.compile(r"(?<![\w/.-])docs/[\w./*-]*\.(?:md|txt|png|yml)\b")
# The documents that lived next to the repository, named without docs/reference/ in front
# (`isg-cnc.md §1`, `reference/ads.md`, `../shared/DESIGN.md`, `shared/seeds/…`).
OUTSIDE = re.compile(
    r"(?<![\w/.-])(?:\.\./)?(?:shared/|reference/)?"
    r"(?:(?:isg-cnc|ads|lift-algorithm|path-planning|rt-python|style-anchors)\.md|DESIGN\.md)"
    r"|(?<![\w/.-])(?:shared/)?seeds/"
)


def _texts() -> Iterator[Path]:
    for name in ROOT_FILES:
        if (REPO / name).is_file():
            yield REPO / name
    for top in SCANNED:
        for path in sorted((REPO / top).rglob("*")):
            skip = {"node_modules", "__pycache__", ".hypothesis"} & set(path.parts)
            if path.is_file() and path.suffix in SUFFIXES and not skip:
                yield path


def _exists(cited: str) -> bool:
    if "*" in cited:  # docs/reference/lift-function-*.txt
        return any(REPO.glob(cited))
    return (REPO / cited).exists()


def _citations() -> list[tuple[str, int, str, bool]]:
    """(file, line, cited text, whether the repository holds it) for every citation."""
    found = []
    for path in _texts():
        rel = path.relative_to(REPO).as_posix()
        if rel == "tests/unit/test_citations.py":
            continue  # its own patterns and examples
        text = path.read_text(encoding="utf-8", errors="replace")
        for lineno, line in enumerate(text.splitlines(), 1):
            for m in OUTSIDE.finditer(line):
                # the manual's pages name each other relative to themselves (mkdocs.yml: to
                # docs/), as the notes in docs/reference/ do by name: held when that file is
                base = REPO / "docs" if rel == "mkdocs.yml" else path.parent
                relative = rel == "mkdocs.yml" or rel.startswith("docs/")
                target = (base / m.group(0)).resolve()
                held = relative and target.is_file() and target.is_relative_to(REPO)
                found.append((rel, lineno, m.group(0), held))
            for m in DOCS_PATH.finditer(line):
                ok = _exists(m.group(0))
                found.append((rel, lineno, m.group(0), ok))
    return found


def test_every_cited_document_is_in_the_repository() -> None:
    missing = [f"{rel}:{lineno}: {cited}" for rel, lineno, cited, ok in _citations() if not ok]
    assert not missing, "citations of documents the repository does not hold:\n" + "\n".join(
        missing
    )


def test_the_code_cites_the_reference_documents() -> None:
    """The check sees the citations it guards (a pattern that matched nothing would pass)."""
    cited = {c for rel, _, c, _ in _citations() if rel.startswith("liftd/")}
    for name in ("design.md", "isg-cnc.md", "ads.md", "lift-algorithm.md", "rt-python.md"):
        assert f"docs/reference/{name}" in cited, name


@pytest.mark.parametrize(
    ("line", "ok"),
    [
        ("Addressing (docs/reference/isg-cnc.md §1)", True),
        ("Addressing (isg-cnc.md §1)", False),
        ("(reference/ads.md §3)", False),
        ("`../shared/DESIGN.md` is the original specification", False),
        ("the vendor text (shared/seeds/lift-function-*.txt)", False),
        ("docs/reference/no-such-notes.md §2", False),
        ("docs/reference/lift-function-*.txt", True),
    ],
)
def test_the_patterns_tell_a_held_document_from_one_outside(line: str, ok: bool) -> None:
    outside = OUTSIDE.search(line) is not None
    held = all(_exists(m.group(0)) for m in DOCS_PATH.finditer(line))
    assert (not outside and held) is ok
