"""The GEO core's program time against the offline reference profile (issue 36, item 3) on
CAM-shaped programs (bench/cam_cases.py) at constant overrides of 10–200 %.

For each program: the time the core's path takes from its start to the program's end (the
interpolator alone, cycle by cycle, as `GeoTask` drives it, without the lift: the same
prepared path, its Advanced lift caps included), against two references over the same
ceilings, transition caps, run boundaries and look-ahead window:

* `ratio`: bench/reference_profile.py, ruckig profiles chained with zero acceleration at every
  node: a feasible motion near the optimum, which the core may beat (it need not stop
  accelerating at a cap that is no run boundary);
* `ratio_bound`: bench/reference_bound.py, a lower bound: no motion within the rules is
  faster, so ≥ 1 always, or the core broke a rule.

The optimum lies between the two: the core is within 1 % of it where `ratio` ≤ 1.01 (or
`ratio_bound` ≤ 1.01). Prints one JSON line per program with --each, and one summary line:
max, p99, median and min of both ratios, how many below 1 and above 1.01, the worst programs.

Run: .venv/bin/python bench/bench_reference.py [PROGRAMS [FIRST_SEED]]   (200: ~2 min)
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench.cli import parser
from liftd.cnc.geo_task import GeoTask
from tests.support.cam_cases import cam_scenario
from tests.support.cam_runs import core_time
from tests.support.reference_bound import lower_bound_time
from tests.support.reference_profile import reference_time


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("programs", nargs="?", type=int, default=200)
    ap.add_argument("first_seed", nargs="?", type=int, default=0)
    ap.add_argument("--each", action="store_true", help="one JSON line per program")
    args = ap.parse_args()
    rows: list[dict[str, float | int]] = []
    t0 = time.perf_counter()
    for seed in range(args.first_seed, args.first_seed + args.programs):
        sc = cam_scenario(seed, steps=False)
        ov = sc.schedule.override_at(0.0)
        task = GeoTask(sc.channel, sc.text)
        core, errors = core_time(task, ov)
        ref = reference_time(task.prog.path, task.prog.table, sc.channel.look_ahead_blocks, ov)
        bound = lower_bound_time(task.prog.path, task.prog.table, sc.channel.look_ahead_blocks, ov)
        row = {"seed": seed, "core_s": round(core, 6), "reference_s": round(ref.time, 6),
               "ratio": core / ref.time if ref.time > 0 else 1.0, "tracker_errors": errors,
               "bound_s": round(bound, 6), "ratio_bound": core / bound if bound > 0 else 1.0,
               "override": ov, "look_ahead": sc.channel.look_ahead_blocks,
               "cycle_ms": sc.channel.cycle_time * 1e3, "blocks": task.prog.table.n,
               "pieces_refused": ref.pieces_refused}  # fmt: skip
        rows.append(row)
        if args.each:
            print(json.dumps({"bench": "reference_program", **row}), flush=True)
    ratios = sorted(float(r["ratio"]) for r in rows)
    by_ratio = sorted(rows, key=lambda r: float(r["ratio"]))
    bounds = sorted(float(r["ratio_bound"]) for r in rows)
    by_bound = sorted(rows, key=lambda r: float(r["ratio_bound"]))
    keys = ("seed", "ratio", "ratio_bound", "core_s", "reference_s", "bound_s", "look_ahead",
            "override", "blocks")  # fmt: skip
    summary = {
        "bench": "reference",
        "programs": len(rows),
        "first_seed": args.first_seed,
        "ratio_max": round(ratios[-1], 5),
        "ratio_p99": round(ratios[min(len(ratios) - 1, int(0.99 * len(ratios)))], 5),
        "ratio_median": round(ratios[len(ratios) // 2], 5),
        "ratio_min": round(ratios[0], 5),
        "below_1": sum(1 for r in ratios if r < 1.0 - 1e-9),
        "above_1_01": sum(1 for r in ratios if r > 1.01),
        "tracker_errors": sum(int(r["tracker_errors"]) for r in rows),
        # against the lower bound (bench/reference_bound.py): ≥ 1 or the core broke a rule
        "bound_ratio_max": round(bounds[-1], 5),
        "bound_ratio_p99": round(bounds[min(len(bounds) - 1, int(0.99 * len(bounds)))], 5),
        "bound_ratio_median": round(bounds[len(bounds) // 2], 5),
        "bound_ratio_min": round(bounds[0], 5),
        "below_bound": sum(1 for r in bounds if r < 1.0 - 1e-9),
        "worst_against_bound": [{k: r[k] for k in keys} for r in by_bound[-5:][::-1]],
        "worst": [{k: r[k] for k in keys} for r in by_ratio[-5:][::-1]],
        "fastest": [{k: r[k] for k in keys} for r in by_ratio[:3]],
        "seconds": round(time.perf_counter() - t0, 1),
    }
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
