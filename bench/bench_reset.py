"""A PLC RESET inside a lift range, at a random moment of a random range, over the scenarios
of `bench_lift_safety.py --wide`: READY must come within 3 s with the lift ended (flags FALSE,
phase NONE), and from the RESET on Z within its own v, a, j (finite differences). Prints one
JSON line: runs, failures, the longest wait from RESET to READY.

With --nc-error an NC error takes the RESET's place: an unknown word in a random block of a
random range (vendor §2.4: Z rises to POS_LIMIT and stays). ERROR must come, and `simulate`'s
driver end with Z at rest at the range's maximum lift height (POS_LIMIT, or the start or POS
beyond it: §2.1.1, issue 37), never moving toward the part from the error on, within its v, a,
j (before e53490e Z lost the motion between the path's stop and its own last cycle in one
cycle).

Run: .venv/bin/python bench/bench_reset.py [--nc-error] [RUNS [FIRST_SEED [advanced|lifting]]]
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench.cli import parser
from liftd.cnc.params import LiftMethod
from tests.support.reset_runs import nc_error_in_a_range, reset_in_a_range


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("runs", nargs="?", type=int, default=300)
    ap.add_argument("first_seed", nargs="?", type=int, default=0)
    ap.add_argument("method", nargs="?", default="advanced", choices=["advanced", "lifting"])
    ap.add_argument("--nc-error", action="store_true", help="an NC error instead of the RESET")
    args = ap.parse_args()
    method = LiftMethod(args.method)
    t0 = time.perf_counter()
    if args.nc_error:
        runs, failures = 0, []
        for seed in range(args.first_seed, args.first_seed + args.runs):
            problems = nc_error_in_a_range(seed, method)
            if problems is None:
                continue
            runs += 1
            if problems:
                failures.append({"seed": seed, **problems})
        print(
            json.dumps(
                {
                    "bench": "nc_error_in_a_range",
                    "method": method.value,
                    "runs": runs,
                    "failed_runs": len(failures),
                    "first_failures": failures[:5],
                    "seconds": round(time.perf_counter() - t0, 1),
                }
            )
        )
        return
    runs, failures, waits = 0, [], []
    for seed in range(args.first_seed, args.first_seed + args.runs):
        got = reset_in_a_range(seed, method)
        if got is None:
            continue
        runs += 1
        t_reset, t_ready, last, ratio = got
        if (
            t_ready is None
            or last.lift_active
            or last.lift_suppressed
            or last.lift_phase != 0
            or ratio > 1.0 + 1e-6
        ):
            failures.append(
                {"seed": seed, "t_reset": t_reset, "state": last.state.name, "z_limit_ratio": ratio}
            )
        else:
            waits.append(t_ready - t_reset)
    print(
        json.dumps(
            {
                "bench": "reset_in_a_range",
                "method": method.value,
                "runs": runs,
                "failed_runs": len(failures),
                "first_failures": failures[:5],
                "max_wait_s": round(max(waits, default=0.0), 4),
                "seconds": round(time.perf_counter() - t0, 1),
            }
        )
    )


if __name__ == "__main__":
    main()
