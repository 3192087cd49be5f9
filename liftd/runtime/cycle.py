"""The GEO loop's timing policy and statistics. Pure: times are passed in (integer ns).

Missed-cycle policy (docs/reference/design.md §5, TwinCAT's model): every GEO cycle is computed and
the GEO timeline advances by exactly one cycle per step (t = k·dt, so a run reproduces `simulate`
bit for bit). A cycle that starts late runs late, and the following ones run back to back
until the loop is on its wall-clock grid t0 + k·P again; a cycle that finishes after the start
of the next one counts as *exceeded*. Only when the loop is more than `max_behind` periods
behind (a stall of the machine) does it skip wall-clock ticks — counted as `regridded` — to
stay on the grid without a burst of catch-up; the GEO timeline is never cut.
"""

from __future__ import annotations

from collections.abc import MutableSequence

US = 1000


FINE, FINE_NS = 200, 5 * US  # 5 µs steps to 1 ms
FINE_TOP_NS = FINE * FINE_NS
COARSE, COARSE_NS = 90, 100 * US  # then 100 µs steps to 10 ms


def _edges() -> list[int]:
    """Histogram bucket upper edges (ns): 5 µs steps to 1 ms, 100 µs steps to 10 ms."""
    return [k * FINE_NS for k in range(1, FINE + 1)] + [
        FINE_TOP_NS + k * COARSE_NS for k in range(1, COARSE + 1)
    ]


EDGES = _edges()
BUCKETS = len(EDGES) + 1  # the last bucket: above 10 ms


class CycleClock:
    def __init__(self, period_ns: int, start_ns: int, max_behind: int = 100) -> None:
        self.period_ns = period_ns
        self.deadline_ns = start_ns  # start of the current cycle on the wall grid
        self.max_behind = max_behind

    def next_cycle(self, now_ns: int) -> int:
        """Advance to the next cycle's start; returns the wall ticks skipped (0 normally)."""
        p = self.period_ns
        self.deadline_ns += p
        behind = now_ns - self.deadline_ns
        if behind > self.max_behind * p:
            skipped = behind // p
            self.deadline_ns += skipped * p
            return int(skipped)
        return 0


def bucket(ns: int) -> int:
    """The bucket of `ns` (= bisect_left(EDGES, ns)), by arithmetic: a bisection over the
    edges touches a dozen int objects, cache misses in the loop's cold cycles."""
    if ns <= FINE_TOP_NS:
        return (ns - 1) // FINE_NS if ns > 0 else 0
    return FINE + min(COARSE, (ns - FINE_TOP_NS - 1) // COARSE_NS)


def percentile_us(counts: MutableSequence[int], q: float) -> float:
    """Upper edge (µs) of the bucket holding the q-quantile; inf if it is the overflow bucket,
    0 without samples."""
    total = sum(counts)
    if total == 0:
        return 0.0
    need = q * total
    run = 0
    for i, c in enumerate(counts):
        run += c
        if run >= need:
            return EDGES[i] / US if i < len(EDGES) else float("inf")
    return float("inf")
