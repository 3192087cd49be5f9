"""≥ 1000 seeded random closed-loop lift runs (issue 4 safety figure; issue 5 with `lifting`).

Each run: random Z dynamics, cycle time, program (1–3 lift ranges, DOWN, waits), override steps
and feed holds. Checks: |v|, |a|, |j| of every axis ≤ limit (+1e-9 relative, finite
differences), no excursion beyond POS_LIMIT or the software limits (+0.1 µm), arrival error
≤ 1 µm, never late (no lift.late). Prints one JSON line with the counts and the first failures.

Path-based Lifting (METHOD = lifting) is checked the same way, except that an override above
100 % scales Z's acceleration and jerk with override² and override³ (the overload band the
vendor allows for feed changes, §2.2.1; lift/path_based.py `segment_cap`).

With --stops every run also gets a PLC STOP at a random moment (inside a lift range in two of
three runs; the moment from a first run without it) and START after a random hold of 1 ms–2 s
(tests/unit/cnc/test_stop_start.py runs the first seeds).

With --flush (issue 37) #FLUSH / #FLUSH WAIT follow some motion blocks inside ranges (a
generator of their own: each seed's program is otherwise the same).

With --wide (issue 14) the scenarios cover the whole input space: ranges of up to 400 short
blocks (longer than every look-ahead), slightly bent polylines, ranges without path motion,
ranges back to back, waits before and inside ranges, every look-ahead size, override steps of
0–200 % at random moments and feed holds. `program_time_s` sums the runs' program times (the
last cycle's time): a change's cost in path time, A/B against a base tree. Every run (not only --wide) also fails on any error
of the path tracker (a refused profile, a run boundary passed with acceleration).

Run: .venv/bin/python bench/bench_lift_safety.py [--wide] [--stops] [--flush] [RUNS [FIRST_SEED [advanced|lifting]]]
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench.cli import parser
from liftd.cnc.params import LiftMethod
from tests.support.closed_loop import run_task
from tests.support.cycle_check import violations
from tests.support.scenarios import describe, scenario, wide_scenario
from tests.support.stops import stop_and_start


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--wide", action="store_true", help="the whole input space (issue 14)")
    ap.add_argument("--stops", action="store_true", help="a PLC STOP and START in every run")
    ap.add_argument(
        "--flush", action="store_true", help="#FLUSH / #FLUSH WAIT inside ranges (issue 37)"
    )
    ap.add_argument("runs", nargs="?", type=int, default=1000, help="seeded runs (1000)")
    ap.add_argument("first_seed", nargs="?", type=int, default=0, help="the first seed (0)")
    ap.add_argument(
        "method",
        nargs="?",
        default="advanced",
        choices=["advanced", "lifting"],
        help="lift method (advanced)",
    )
    args = ap.parse_args()
    wide, runs, first, method = args.wide, args.runs, args.first_seed, LiftMethod(args.method)
    make = wide_scenario if wide else scenario
    failures: list[dict[str, object]] = []
    cycles = lifts = 0
    program_time = 0.0  # the runs' summed program times (s): the path's cost of a change
    t0 = time.perf_counter()
    for seed in range(first, first + runs):
        sc = make(seed, method, args.flush)
        try:
            if args.stops:
                task, snaps = run_task(
                    sc.channel, sc.text, inputs=stop_and_start(sc, seed), max_time=300
                )
            else:
                task, snaps = run_task(sc.channel, sc.text, sc.schedule, max_time=300)
        except Exception as exc:  # a crash is a failure to report, not the end of the bench
            bad = [f"exception {type(exc).__name__}: {exc}"]
        else:
            cycles += len(snaps)
            program_time += snaps[-1].t
            lifts += len(task.lift.records)
            bad = violations(sc, snaps, task.lift.records)
            if task.interp.plan_errors:
                bad.append(
                    f"{task.interp.plan_errors} tracker errors: {task.interp.last_plan_error}"
                )
        if bad:
            failures.append({"seed": seed, "problems": bad})
            if len(failures) <= 3:
                print(describe(sc), bad, file=sys.stderr)
    print(
        json.dumps(
            {
                "bench": ("lift_safety_wide" if wide else "lift_safety")
                + ("_stops" if args.stops else "")
                + ("_flush" if args.flush else ""),
                "method": method.value,
                "runs": runs,
                "first_seed": first,
                "cycles": cycles,
                "program_time_s": round(program_time, 6),
                "lifts": lifts,
                "failed_runs": len(failures),
                "first_failures": failures[:5],
                "seconds": round(time.perf_counter() - t0, 1),
            }
        )
    )


if __name__ == "__main__":
    main()
