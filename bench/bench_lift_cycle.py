"""Cost of one GEO cycle from Python (issue 4): the Advanced-Lifting generator step by kind
(rise, follow the descent, re-plan the descent, the sub-cycle switch), and GeoTask.step on the
demo program. Targets: generator median ≤ 10 µs, p99 ≤ 20 µs, switch cycle ≤ 100 µs.

Run: .venv/bin/python bench/bench_lift_cycle.py
"""

from __future__ import annotations

import gc
import json
import random
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.cli import parser  # noqa: E402
from liftd.cnc.geo_task import GeoTask  # noqa: E402
from liftd.cnc.lift.advanced import AdvancedLift  # noqa: E402
from liftd.cnc.lift.profile import LiftProfiles  # noqa: E402
from liftd.cnc.snapshot import (  # noqa: E402
    ChannelState,
    GeoInputs,
    LiftPhase,
)
from liftd.settings import load_settings  # noqa: E402

DT = 1e-3


def stats(ns: list[int]) -> dict[str, float]:
    a = np.array(ns) / 1e3
    if not len(a):
        return {"n": 0}
    return {
        "n": len(a),
        "median_us": round(float(np.median(a)), 2),
        "p99_us": round(float(np.percentile(a, 99)), 2),
        "max_us": round(float(a.max()), 1),
    }


def generator(runs: int = 400) -> None:
    rng = random.Random(1)
    kinds: dict[str, list[int]] = {"up": [], "down_follow": [], "down_replan": [], "switch": []}
    every: list[int] = []
    for _ in range(runs):
        prof = LiftProfiles(rng.uniform(0.3, 1.5), rng.uniform(3, 20), rng.uniform(100, 2000))
        gen = AdvancedLift(prof, DT)
        gen.start(
            0.0, 0.0, 0.0, 0.0, rng.uniform(-0.02, 0.02), rng.uniform(0.02, 0.1), False, False
        )
        left, ov, t = rng.uniform(0.05, 1.2), 1.0, 0.0
        jumps = {round(rng.uniform(0.0, 1.0), 3): rng.uniform(0.3, 2.0) for _ in range(2)}
        while left > 0 or not gen.done:
            ov = jumps.get(round(t, 3), ov)
            t_rem = left / ov
            before_phase, before_plan = gen.phase, gen.plan
            t0 = time.perf_counter_ns()
            gen.step(t + DT, t_rem)
            ns = time.perf_counter_ns() - t0
            every.append(ns)
            if before_phase is LiftPhase.UP and gen.phase is LiftPhase.DOWN:
                kinds["switch"].append(ns)
            elif before_phase is LiftPhase.UP:
                kinds["up"].append(ns)
            elif before_phase is LiftPhase.DOWN:
                kinds["down_follow" if gen.plan is before_plan else "down_replan"].append(ns)
            t += DT
            left = max(0.0, left - DT * ov)
            if t > 10:
                break
    print(
        json.dumps(
            {
                "bench": "lift_cycle",
                "part": "generator",
                "all": stats(every),
                **{k: stats(v) for k, v in kinds.items()},
            }
        )
    )


def geo_task() -> None:
    settings = load_settings(str(ROOT / "config" / "liftd.toml"))
    text = (ROOT / "config" / "programs" / "demo.nc").read_text()
    task = GeoTask(settings.channel, text)
    ns: list[int] = []
    lifting: list[int] = []
    last = None
    k = 0
    while True:
        k += 1
        ack = last is not None and last.m_pending >= 0
        t0 = time.perf_counter_ns()
        last = task.step(GeoInputs(m_ack=ack), k * DT)
        dt = time.perf_counter_ns() - t0
        ns.append(dt)
        if last.lift_active:
            lifting.append(dt)
        if last.state is ChannelState.READY and k > 10:
            break
    print(
        json.dumps(
            {
                "bench": "lift_cycle",
                "part": "GeoTask.step demo",
                "all": stats(ns),
                "while_lifting": stats(lifting),
            }
        )
    )


if __name__ == "__main__":
    parser(__doc__).parse_args()
    gc.disable()
    generator()
    geo_task()
