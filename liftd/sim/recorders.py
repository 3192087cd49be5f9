"""What `simulate` keeps of a run besides its trace: the decimated series for the figure
(`SeriesBuffer`) and the step times (`StepTimer`), both in constant memory."""

from __future__ import annotations

import time
from array import array
from collections.abc import Callable

import numpy as np

from liftd.sim.summary import StepCpu


class SeriesBuffer:
    """Decimated copy of the run for plotting, constant memory: when full, every other sample
    is dropped and the stride doubles. Samples are kept flat in an `array` of doubles
    (appending a row to a numpy array costs ~1 µs, extending an array ~0.1 µs)."""

    def __init__(self, columns: int, capacity: int = 20000) -> None:
        self.columns = columns
        self.capacity = capacity
        self.data = array("d")
        self.n = 0
        self.stride = 1
        self.count = 0

    def wants(self) -> bool:
        """Count a sample; True if it is kept (build the row only then)."""
        self.count += 1
        return not (self.count - 1) % self.stride

    def add(self, row: tuple[float, ...]) -> None:
        """Store a sample that `wants()` accepted."""
        if self.n == self.capacity:
            kept = self.rows[::2]
            self.data = array("d", kept.tobytes())
            self.n = kept.shape[0]
            self.stride *= 2
            if (self.count - 1) % self.stride:
                return
        self.data.extend(row)
        self.n += 1

    @property
    def rows(self) -> np.ndarray:
        return np.frombuffer(self.data, dtype=float).reshape(self.n, self.columns).copy()


class StepTimer:
    """Time of `GeoTask.step`: a histogram of 1 µs buckets up to 10 ms and the exact maximum,
    constant memory. By default measured as the GEO loop measures its compute (perf_counter:
    the step's CPU time plus any preemption, an upper bound). The thread's CPU clock, which
    issue 14 names, costs 3.4 µs per call on this VM (a system call, 15 % of a simulated
    cycle) and its accounting is no quieter in the tail (an empty pair of readings measured up
    to 0.7 ms); bench/bench_step.py reports both, next to each clock's own noise."""

    BUCKETS = 10_000

    def __init__(self, clock: Callable[[], int] = time.perf_counter_ns) -> None:
        self.clock = clock
        self.counts = [0] * (self.BUCKETS + 1)
        self.n = 0
        self.max_ns = 0

    def add(self, ns: int) -> None:
        self.n += 1
        self.max_ns = max(self.max_ns, ns)
        us = ns // 1000
        self.counts[us if us < self.BUCKETS else self.BUCKETS] += 1

    def add_many(self, ns: int, n: int) -> None:
        """`n` cycles run in one batch in `ns`: each counts at the batch's average."""
        each = ns // n
        self.n += n
        self.max_ns = max(self.max_ns, each)
        us = each // 1000
        self.counts[us if us < self.BUCKETS else self.BUCKETS] += n

    def percentile(self, q: float) -> float:
        """The q-quantile in µs (upper edge of its 1 µs bucket)."""
        if self.n == 0:
            return 0.0
        rank = q * self.n
        seen = 0
        for us, c in enumerate(self.counts):
            seen += c
            if seen >= rank:
                return float(min(us + 1, self.max_ns / 1e3))
        return self.max_ns / 1e3

    def summary(self) -> StepCpu:
        return StepCpu(
            self.percentile(0.5),
            self.percentile(0.99),
            self.percentile(0.999),
            round(self.max_ns / 1e3, 1),
        )
