"""Seeded random closed-loop runs (the CI-sized share of bench/bench_lift_safety.py).

The first seeds are those that once broke a promise (each fixed in the commit that added it):
Z state time on resume, feed-hold brakes across corners and stops, ruckig edge cases after an
override drop, Zeno creep of the override limit, float rounding at LIFT_END."""

from __future__ import annotations

import pytest

from bench.stress_cases import describe, scenario, violations
from tests.helpers import run_task

REGRESSIONS = [7, 8, 25, 26, 39, 145, 158, 159, 174, 254, 312, 432, 499, 666, 673, 730, 875]


@pytest.mark.parametrize("seed", REGRESSIONS + list(range(2000, 2020)))
def test_random_run_keeps_every_promise(seed: int) -> None:
    sc = scenario(seed)
    task, snaps = run_task(sc.channel, sc.text, sc.schedule, max_time=120)
    assert violations(sc, snaps, task.lift.records) == [], describe(sc)
