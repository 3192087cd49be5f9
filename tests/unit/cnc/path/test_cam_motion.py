"""A derandomised sample of bench/bench_cam_motion.py in the test suite: CAM-shaped programs
(lines and tangent arcs, S-curves, small and large corners, short and long blocks, feed
changes by any ratio, F-only blocks, G00/G01 hand-overs, Advanced lift ranges; overrides
10–200 % and override steps) and random closed-loop lift runs, every cycle through the
independent check of tests/support/motion_check.py: no rest without a rule, no tracker error,
every limit kept (segments within the axes' limits, transitions within the block-transition
parameters). The slowdowns the check finds besides are docs/architecture.md's known
deviations; the bench counts them over thousands of runs."""

from __future__ import annotations

import pytest

from bench.bench_cam_motion import check
from bench.cam_cases import cam_scenario
from bench.stress_cases import describe, wide_scenario

# every 17th seed of the first 340: a spread over look-ahead sizes, cycle times and shapes
CAM_SEEDS = list(range(0, 340, 17))
WIDE_SEEDS = list(range(5, 300, 37))


@pytest.mark.parametrize("seed", CAM_SEEDS)
def test_cam_shaped_programs_rest_only_where_a_rule_says(seed: int) -> None:
    sc = cam_scenario(seed)
    _, hard, _, errors = check(sc)
    assert hard == [] and errors == 0, (hard, describe(sc))


@pytest.mark.parametrize("seed", WIDE_SEEDS)
def test_random_lift_runs_rest_only_where_a_rule_says(seed: int) -> None:
    sc = wide_scenario(seed)
    _, hard, _, errors = check(sc)
    assert hard == [] and errors == 0, (hard, describe(sc))
