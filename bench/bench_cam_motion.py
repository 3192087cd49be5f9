"""Every cycle of CAM-shaped programs (tests/support/cam_cases.py: overrides 10–200 %, override
steps in half the runs) and of the random closed-loop lift runs (tests/support/scenarios.py)
through the independent check of tests/support/motion_check.py (issue 36, item 2), with the
limits (segments within the axes' limits, transitions within the block-transition
parameters) and the tracker's own errors.

A run fails on a tracker error, a limit violation, a rest no rule explains (a stop) or not
ending within its time limit (tests/support/cam_runs.py `time_limit`: twice the program's time
at its ceilings under the lowest override, at least 300 s); the slowdowns the check finds
otherwise (a boundary passed slower than the rules allow, a dip between two boundaries) are
counted apart: docs/architecture.md lists them as known
deviations. One JSON line per kind of run with the counts and the first findings.

Run: .venv/bin/python bench/bench_cam_motion.py [RUNS [FIRST_SEED]]
[--kind cam|wide|narrow|feeds|drops] [--all] (feeds: tests/support/feed_cases.py, short blocks
whose feed changes block by block; drops: a cold review's random short blocks with an override
drop as they come, `drop_scenario`)
(--all: a line for each run with findings or problems, all of them, before the summary)
[--shift SECONDS] moves every override step of each run by that much (−0.02: the cold
review's variant of the drops corpus with its drop 20 ms earlier); [--no-steps] drops them
(the same programs at 100 %).
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench.cli import parser
from tests.support.cam_cases import cam_scenario
from tests.support.cam_runs import check
from tests.support.feed_cases import drop_scenario, feed_scenario, moved_steps
from tests.support.scenarios import scenario, wide_scenario

KINDS = {
    "cam": cam_scenario, "wide": wide_scenario, "narrow": scenario, "feeds": feed_scenario,
    "drops": drop_scenario,
}  # fmt: skip


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("runs", nargs="?", type=int, default=1000)
    ap.add_argument("first_seed", nargs="?", type=int, default=0)
    ap.add_argument("--kind", choices=sorted(KINDS), default="cam")
    ap.add_argument("--all", action="store_true", help="a JSON line for every run with findings")
    ap.add_argument("--shift", type=float, default=0.0, help="move every override step (s)")
    ap.add_argument("--no-steps", action="store_true", help="no override steps (100 %%)")
    args = ap.parse_args()
    make = KINDS[args.kind]
    cycles = failed = slowed = findings = 0
    first: list[dict[str, object]] = []
    slow_first: list[dict[str, object]] = []
    t0 = time.perf_counter()
    for seed in range(args.first_seed, args.first_seed + args.runs):
        sc = make(seed)
        if args.shift or args.no_steps:
            sc = moved_steps(sc, args.shift, keep=not args.no_steps)
        try:
            n, hard, slow, _ = check(sc)
        except Exception as exc:  # a crash is a failure to report, not the end of the bench
            n, hard, slow = 0, [f"exception {type(exc).__name__}: {exc}"], []
        cycles += n
        if hard:
            failed += 1
            if len(first) < 5:
                first.append({"seed": seed, "problems": hard[:3]})
        if (slow or hard) and args.all:
            print(json.dumps({"seed": seed, "look_ahead": sc.channel.look_ahead_blocks,
                              "findings": slow, "problems": hard}), flush=True)  # fmt: skip
        if slow:
            slowed += 1
            findings += len(slow)
            if len(slow_first) < 5:
                slow_first.append({"seed": seed, "look_ahead": sc.channel.look_ahead_blocks,
                                   "findings": slow[:2]})  # fmt: skip
    print(json.dumps({
        "bench": f"cam_motion_{args.kind}",
        "runs": args.runs,
        "first_seed": args.first_seed,
        "override_shift": args.shift,
        "override_steps": not args.no_steps,
        "cycles": cycles,
        "failed_runs": failed,
        "runs_with_unexplained_slowdowns": slowed,
        "slowdown_findings": findings,
        "first_failures": first,
        "first_slowdowns": slow_first,
        "seconds": round(time.perf_counter() - t0, 1),
    }))  # fmt: skip


if __name__ == "__main__":
    main()
