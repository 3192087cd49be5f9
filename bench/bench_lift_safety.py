"""≥ 1000 seeded random closed-loop lift runs (issue 4 safety figure; issue 5 with `lifting`).

Each run: random Z dynamics, cycle time, program (1–3 lift ranges, DOWN, waits), override steps
and feed holds. Checks: |v|, |a|, |j| of every axis ≤ limit (+1e-9 relative, finite
differences), no excursion beyond POS_LIMIT or the software limits (+0.1 µm), arrival error
≤ 1 µm, never late (no lift.late). Prints one JSON line with the counts and the first failures.

Path-based Lifting (METHOD = lifting) is checked the same way except Z's acceleration, which
may reach a_max·(1 + P442/1000·override²) by the method's design (lift/path_based.py).

Run: .venv/bin/python bench/bench_lift_safety.py [RUNS [FIRST_SEED [advanced|lifting]]]
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench.stress_cases import describe, scenario, violations
from liftd.cnc.params import LiftMethod
from tests.support.closed_loop import run_task


def main() -> None:
    runs = int(sys.argv[1]) if len(sys.argv) > 1 else 1000
    first = int(sys.argv[2]) if len(sys.argv) > 2 else 0
    method = LiftMethod(sys.argv[3]) if len(sys.argv) > 3 else LiftMethod.ADVANCED
    failures: list[dict[str, object]] = []
    cycles = lifts = 0
    t0 = time.perf_counter()
    for seed in range(first, first + runs):
        sc = scenario(seed, method)
        try:
            task, snaps = run_task(sc.channel, sc.text, sc.schedule, max_time=120)
        except Exception as exc:  # a crash is a failure to report, not the end of the bench
            bad = [f"exception {type(exc).__name__}: {exc}"]
        else:
            cycles += len(snaps)
            lifts += len(task.lift.records)
            bad = violations(sc, snaps, task.lift.records)
        if bad:
            failures.append({"seed": seed, "problems": bad})
            if len(failures) <= 3:
                print(describe(sc), bad, file=sys.stderr)
    print(
        json.dumps(
            {
                "bench": "lift_safety",
                "method": method.value,
                "runs": runs,
                "first_seed": first,
                "cycles": cycles,
                "lifts": lifts,
                "failed_runs": len(failures),
                "first_failures": failures[:5],
                "seconds": round(time.perf_counter() - t0, 1),
            }
        )
    )


if __name__ == "__main__":
    main()
