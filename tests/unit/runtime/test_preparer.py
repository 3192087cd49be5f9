"""The preparer's thread (runtime/preparer.py): a job runs only in the slices the loop grants,
blocks at the core's next pause point past its slice, hands back its result or the exception
it raised, and pause points in the loop's own thread do nothing. The thread is real; the
clock is the test's, so a slice ends when the test says."""

from __future__ import annotations

import threading
from collections.abc import Iterator

import pytest

from liftd.cnc import pause
from liftd.runtime.preparer import Preparer


class Clock:
    def __init__(self) -> None:
        self.now = 0

    def __call__(self) -> int:
        return self.now


@pytest.fixture
def prep() -> Iterator[tuple[Preparer, Clock]]:
    clock = Clock()
    p = Preparer(1_000_000, clock=clock)
    yield p, clock
    p.close()
    assert pause.hook is None


def wait(cond: object, timeout: float = 10.0) -> bool:
    """Wait for the other thread's state (an Event per step: no timing assumption)."""
    done = threading.Event()
    for _ in range(int(timeout * 1000)):
        if cond():  # type: ignore[operator]
            return True
        done.wait(0.001)
    return False


def test_a_job_runs_only_once_a_slice_is_granted(prep: tuple[Preparer, Clock]) -> None:
    p, clock = prep
    steps: list[int] = []

    def job() -> str:
        for k in range(5):
            steps.append(k)
            pause.pause()
        return "built"

    p.submit(("run", 0), job)
    assert p.busy
    assert not wait(lambda: steps, 0.05)  # no slice granted: nothing ran
    p.grant(clock.now + p.margin_ns + 1000)
    assert wait(lambda: p.jobs_done == 1)
    assert [(k, r) for k, r, _ in p.results()] == [(("run", 0), "built")]
    assert steps == list(range(5)) and not p.busy and p.results() == []


def test_a_slice_ends_at_the_first_pause_past_it(prep: tuple[Preparer, Clock]) -> None:
    p, clock = prep
    steps: list[int] = []
    gate = threading.Event()

    def job() -> None:
        for k in range(10):
            steps.append(k)
            if k == 2:
                clock.now = 1 << 30  # the loop's deadline came while the job worked
            pause.pause()
        gate.set()

    p.submit(("run", 0), job)
    p.grant(1_000 + p.margin_ns)
    assert wait(lambda: len(steps) == 3)
    assert not wait(lambda: len(steps) > 3, 0.05)  # blocked at the pause after step 2
    p.grant(clock.now + 10 * p.margin_ns)
    assert wait(gate.is_set)
    assert steps == list(range(10))


def test_an_exception_comes_back_as_the_result(prep: tuple[Preparer, Clock]) -> None:
    p, _ = prep

    def job() -> None:
        raise ValueError("a bug in the core")

    p.submit(("run", 1), job)
    p.grant(1 << 40)
    assert wait(lambda: p.jobs_done == 1)
    ((key, result, took),) = p.results()
    assert key == ("run", 1) and isinstance(result, ValueError) and took >= 0


def test_pause_points_in_the_loops_own_thread_do_nothing(prep: tuple[Preparer, Clock]) -> None:
    p, clock = prep
    clock.now = 1 << 50  # every slice long over
    for _ in range(3):
        pause.pause()  # returns: this is not the preparer's thread
    assert not p.busy
