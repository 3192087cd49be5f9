"""Pause points of a program's preparation (liftd/cnc/pause.py, issue 41): a hook changes
nothing the preparation computes, it is called at least once per block, and what the
preparation frees in bulk goes a chunk at a time; the program's lines are split as before."""

from __future__ import annotations

from dataclasses import replace

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from bench.gen import count_blocks, nesting_program
from liftd.cnc import pause
from liftd.cnc.geo_program import load_program
from liftd.cnc.nc import sources
from tests.support.channel import make_channel


@pytest.fixture
def counted() -> list[int]:
    calls = [0]

    def hook() -> None:
        calls[0] += 1

    pause.hook = hook
    yield calls
    pause.hook = None


def test_a_hook_changes_nothing_and_is_called_at_least_once_a_block(counted: list[int]) -> None:
    ch = make_channel()
    text = nesting_program(40)
    start = (0.0005, 0.0005, 0.001)
    with_hook = load_program(text, ch, start)
    calls = counted[0]
    pause.hook = None
    plain = load_program(text, ch, start)
    # the same program: range_of is keyed by object identity, the rises are ruckig objects
    assert replace(plain, range_of={}, rises=()) == replace(with_hook, range_of={}, rises=())
    assert sorted(plain.range_of.values()) == sorted(with_hook.range_of.values())
    rises = [(r.q0, r.traj.duration) if r else None for r in plain.rises]
    assert rises == [(r.q0, r.traj.duration) if r else None for r in with_hook.rises]
    assert calls >= 2 * count_blocks(text)  # decode and path preparation: one a block each


def test_release_frees_a_chunk_between_two_pauses(counted: list[int]) -> None:
    items: list[object] = [object() for _ in range(3 * pause.RELEASE_CHUNK + 1)]
    pause.release(items)
    assert items == [] and counted[0] == 4


LINE_END = sources._LINE_END


def reference(text: str) -> list[str]:
    """split_lines before it split in pieces: one regular-expression split."""
    lines = LINE_END.split(text)
    if lines and not lines[-1]:
        lines.pop()
    return lines


@settings(max_examples=300, deadline=None)
@given(st.lists(st.sampled_from(["a", "%L x", " ", "\n", "\r", "\r\n", "ä", "\t"]), max_size=400),
       st.sampled_from([1, 2, 3, 7, 64]))  # fmt: skip
def test_split_lines_in_pieces_is_one_split(parts: list[str], chunk: int) -> None:
    """Pieces end after a LF, so a CR LF is never cut and no empty line appears between."""
    text = "".join(parts)
    old = sources.SPLIT_CHUNK
    sources.SPLIT_CHUNK = chunk
    try:
        assert sources.split_lines(text) == reference(text)
    finally:
        sources.SPLIT_CHUNK = old
