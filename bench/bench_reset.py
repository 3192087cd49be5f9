"""A PLC RESET inside a lift range, at a random moment of a random range, over the scenarios
of `bench_lift_safety.py --wide`: READY must come within 3 s with the lift ended (flags FALSE,
phase NONE). Prints one JSON line: runs, failures, the longest wait from RESET to READY.

Run: .venv/bin/python bench/bench_reset.py [RUNS [FIRST_SEED [advanced|lifting]]]
"""

from __future__ import annotations

import json
import random
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench.cli import parser
from bench.stress_cases import wide_scenario
from liftd.cnc.geo_task import GeoTask
from liftd.cnc.params import LiftMethod
from liftd.cnc.plc import SimPlc
from liftd.cnc.snapshot import ChannelState, Command, GeoSnapshot
from tests.support.closed_loop import run_task


def reset_in_a_range(
    seed: int, method: LiftMethod
) -> tuple[float, float | None, GeoSnapshot] | None:
    """(t of the RESET, t of READY or None, the last snapshot); None without a lift range."""
    sc = wide_scenario(seed, method)
    ref, _ = run_task(sc.channel, sc.text, sc.schedule, max_time=300)
    rnd = random.Random(seed)
    if not ref.lift.records:
        return None
    rec = rnd.choice(ref.lift.records)
    t_reset = rec.t_start + rnd.uniform(0.0, rec.t_end - rec.t_start)
    dt = sc.channel.cycle_time
    task, plc = GeoTask(sc.channel, sc.text), SimPlc(0.02)
    last: GeoSnapshot | None = None
    sent = False
    for k in range(1, round((t_reset + 3.0) / dt) + 2):
        t = k * dt
        inputs = plc.inputs(last, t, sc.schedule)
        if not sent and t >= t_reset:
            inputs, sent = inputs._replace(command=Command.RESET), True
        last = task.step(inputs, t)
        if sent and last.state is ChannelState.READY:
            return t_reset, t, last
    assert last is not None
    return t_reset, None, last


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("runs", nargs="?", type=int, default=300)
    ap.add_argument("first_seed", nargs="?", type=int, default=0)
    ap.add_argument("method", nargs="?", default="advanced", choices=["advanced", "lifting"])
    args = ap.parse_args()
    method = LiftMethod(args.method)
    t0 = time.perf_counter()
    runs, failures, waits = 0, [], []
    for seed in range(args.first_seed, args.first_seed + args.runs):
        got = reset_in_a_range(seed, method)
        if got is None:
            continue
        runs += 1
        t_reset, t_ready, last = got
        if t_ready is None or last.lift_active or last.lift_suppressed or last.lift_phase != 0:
            failures.append({"seed": seed, "t_reset": t_reset, "state": last.state.name})
        else:
            waits.append(t_ready - t_reset)
    print(json.dumps({"bench": "reset_in_a_range", "method": method.value, "runs": runs,
                      "failed_runs": len(failures), "first_failures": failures[:5],
                      "max_wait_s": round(max(waits, default=0.0), 4),
                      "seconds": round(time.perf_counter() - t0, 1)}))  # fmt: skip


if __name__ == "__main__":
    main()
