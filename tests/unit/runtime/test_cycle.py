"""The GEO loop's missed-cycle policy and its fixed-size histograms, on a virtual clock."""

from __future__ import annotations

import bisect

from liftd.runtime.cycle import BUCKETS, EDGES, CycleClock, bucket, percentile_us

P = 1_000_000  # 1 ms in ns


def test_on_time_cycles_stay_on_the_absolute_grid() -> None:
    clock = CycleClock(P, start_ns=5 * P)
    for k in range(1, 1001):
        # each cycle ends somewhere inside its period: the next deadline is exactly start + k·P
        assert clock.next_cycle(clock.deadline_ns + 300_000 + k % 7) == 0
        assert clock.deadline_ns == 5 * P + k * P  # no drift from integer ns arithmetic


def test_late_cycles_run_back_to_back_until_the_loop_is_on_the_grid_again() -> None:
    clock = CycleClock(P, start_ns=0)
    assert clock.next_cycle(now_ns=0 + 3 * P + 10) == 0  # a 3 ms stall: nothing skipped
    assert clock.deadline_ns == P  # the next cycle is due at once (1 ms ago): catch up
    ends = []
    now = 3 * P + 10
    while clock.deadline_ns < now:
        now += 50_000  # catch-up cycles take 50 µs each
        ends.append(now)
        assert clock.next_cycle(now) == 0
    assert clock.deadline_ns == 4 * P and len(ends) == 3  # back on the wall grid, none cut


def test_more_than_max_behind_skips_wall_ticks_but_keeps_the_grid() -> None:
    clock = CycleClock(P, start_ns=0, max_behind=100)
    assert clock.next_cycle(now_ns=101 * P) == 0  # 100 periods behind: still catching up
    clock = CycleClock(P, start_ns=0, max_behind=100)
    skipped = clock.next_cycle(now_ns=250 * P + 123)  # a 250 ms stall of the machine
    assert skipped == 249
    assert clock.deadline_ns == 250 * P  # on the grid t0 + k·P, due now
    assert clock.next_cycle(250 * P + 400_000) == 0 and clock.deadline_ns == 251 * P


def test_histogram_buckets_and_percentiles() -> None:
    assert len(EDGES) + 1 == BUCKETS
    assert bucket(0) == 0 and bucket(5_000) == 0 and bucket(5_001) == 1
    assert bucket(1_000_000) == 199 and bucket(1_000_001) == 200  # 5 µs steps up to 1 ms
    assert bucket(10_000_000) == BUCKETS - 2 and bucket(10_000_001) == BUCKETS - 1  # overflow
    # the arithmetic is the bisection, at every edge and beside it
    for ns in [-1, 10**9, *(e + d for e in EDGES for d in (-1, 0, 1))]:
        assert bucket(ns) == bisect.bisect_left(EDGES, ns), ns
    counts = [0] * BUCKETS
    assert percentile_us(counts, 0.99) == 0.0
    for ns in [12_000] * 990 + [480_000] * 9 + [20_000_000]:
        counts[bucket(ns)] += 1
    assert percentile_us(counts, 0.5) == 15.0  # upper edge of the 10–15 µs bucket
    assert percentile_us(counts, 0.99) == 15.0
    assert percentile_us(counts, 0.995) == 480.0
    assert percentile_us(counts, 1.0) == float("inf")  # the 20 ms outlier is above the range
