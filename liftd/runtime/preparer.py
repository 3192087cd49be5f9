"""What a START after a RESET, an NC error or a program end, and a reload, need prepared, built
in the GEO process off the cycle: a thread that runs only in the loop's idle time.

Decoding and planning a program costs time in proportion to it (the demo ≈ 2 ms, a 500-part
job ≈ 0.3 s, 100 000 blocks ≈ 2 s). Done in a START's cycle it made that cycle late by as
much (issue 41); the repeat START already found its run built ahead (cnc/runs.py). Now the
loop (geo_loop.py) submits the job here and holds a START back until it is done, as a CNC's
channel waits for its decoder.

Slices: after each cycle, while a job waits or runs, the loop grants the thread the time up to
`margin` before its next deadline, then sleeps. The thread runs the job until the core's next
pause point (liftd/cnc/pause.py) past that time, where it blocks until the next grant, so it
does not hold the interpreter when the loop wakes. How far a job can run past its slice is the
longest stretch between two pause points (bench/bench_prepare.py); the margin covers it.

A finished job's result (or the exception it raised) waits in `results` for the loop, which
takes it at the start of a cycle.
"""

from __future__ import annotations

import contextlib
import os
import threading
import time
from collections import deque
from collections.abc import Callable

from liftd.cnc import pause as pause_points

Key = tuple[object, ...]  # what the loop names a job by (its kind first)
MARGIN_MIN_NS = 200_000  # the slice ends this long before the next deadline at least


class _Stopped(BaseException):
    """The loop is stopping: leave the job where it is."""


class Preparer:
    def __init__(self, period_ns: int, clock: Callable[[], int] = time.perf_counter_ns) -> None:
        # the slice ends a quarter period (at least 200 µs, at most half a period) before
        # the next deadline: the longest stretch between pause points is ~100 µs here
        self.margin_ns = min(max(period_ns // 4, MARGIN_MIN_NS), period_ns // 2)
        self._clock = clock  # the loop's (CLOCK_MONOTONIC in ns)
        self._jobs: deque[tuple[Key, Callable[[], object]]] = deque()
        self._done: deque[tuple[Key, object, int]] = deque()  # key, result, ns it took
        self._until = 0
        self._granted = threading.Event()
        self._stopping = False
        self.running = False  # a job is under way (set before it is taken off `_jobs`)
        self.jobs_done = 0
        self._thread = threading.Thread(target=self._run, name="geo-prepare", daemon=True)
        self._ident = -1
        self._thread.start()
        pause_points.hook = self._pause

    # -- the loop's side -----------------------------------------------------------------------
    @property
    def busy(self) -> bool:
        """A job waits or runs: the loop grants slices."""
        return self.running or bool(self._jobs)

    def submit(self, key: Key, job: Callable[[], object]) -> None:
        self._jobs.append((key, job))

    def grant(self, deadline_ns: int) -> None:
        """Let the thread run until `margin_ns` before `deadline_ns` (the loop's next wake)."""
        self._until = deadline_ns - self.margin_ns
        self._granted.set()

    def results(self) -> list[tuple[Key, object, int]]:
        """The jobs finished since the last call: (key, result or the exception raised, the
        wall time from its start to its end in ns, slices and the cycles between them)."""
        out = []
        while self._done:
            out.append(self._done.popleft())
        return out

    def follow_affinity(self) -> None:
        """Run where the loop's thread may (after rt.apply pinned it to `[rt] cpu`): the
        GEO process keeps to its cpu; the thread stays SCHED_OTHER (it was started before the
        loop took SCHED_FIFO), so the loop preempts it whenever it wakes."""
        tid = self._thread.native_id
        if tid is not None:
            with contextlib.suppress(OSError):
                os.sched_setaffinity(tid, os.sched_getaffinity(0))

    def close(self) -> None:
        self._stopping = True
        self._until = 1 << 62
        self._granted.set()
        pause_points.hook = None
        self._thread.join(1.0)

    # -- the thread's side -------------------------------------------------------------------
    def _pause(self) -> None:
        """The core's pause point: the loop's thread passes; this one blocks past its slice."""
        if threading.get_ident() == self._ident and self._clock() >= self._until:
            self._wait()

    def _wait(self) -> None:
        while True:
            self._granted.clear()
            if self._stopping:
                raise _Stopped
            if self._clock() < self._until:
                return
            self._granted.wait()

    def _run(self) -> None:
        self._ident = threading.get_ident()
        try:
            while True:
                self._wait()  # a slice (granted while busy only: idle, it sleeps here)
                if not self._jobs:
                    self._until = 0  # nothing to do until the loop grants again
                    continue
                self.running = True
                key, job = self._jobs.popleft()
                began = time.perf_counter_ns()
                try:
                    result: object = job()
                except Exception as exc:  # the loop reports it (a bug in the core)
                    result = exc
                self._done.append((key, result, time.perf_counter_ns() - began))
                self.jobs_done += 1
                self.running = False
        except _Stopped:
            return
