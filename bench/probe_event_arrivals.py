"""After an override drop (or a feed hold) the path may only arrive later, never sooner, than
the committed future the lift planned with before it (issue 36, sixth round, part E: an
event's re-plan that leaves the profile the path was on). Each run's cycles as
bench/bench_cam_motion.py runs them; at every event that is an override decrease (the hold
unchanged) or a feed hold, the queue the event discarded (`Interpolator.queue`: one state per future cycle) and its
arrival times (`Interpolator.arrivals`: the boundaries a lift asks for) are compared with the
new queue, cycle by cycle, as the producer refills it (until the next event).

Prints one JSON line per run where the new future is ahead somewhere (`ahead_m`: the largest
s_new − s_old at the same cycle; `sooner_s`: the largest t_old − t_new of a boundary's
arrival), then a summary: the events compared, the runs ahead by more than AHEAD_TOL or
sooner by more than SOONER_TOL, the largest of each.

Run: .venv/bin/python bench/probe_event_arrivals.py [RUNS [FIRST_SEED]] [--kind cam|wide|narrow]
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench.cli import parser
from liftd.cnc.geo_task import GeoTask
from liftd.cnc.plc import SimPlc
from liftd.sim.simulate import run_cycles
from tests.support.cam_cases import cam_scenario
from tests.support.cam_runs import time_limit
from tests.support.scenarios import Scenario, scenario, wide_scenario

KINDS = {"cam": cam_scenario, "wide": wide_scenario, "narrow": scenario}
AHEAD_TOL = 1e-12  # m: a rounding of the path position (`plan.EPS_S`)
SOONER_TOL = 1e-12  # s


def probe(sc: Scenario) -> tuple[int, float, float]:
    """(events compared, largest lead of a new future over the discarded one in m, largest
    earlier arrival in s) of one run."""
    task = GeoTask(sc.channel, sc.text)
    ip = task.interp
    queue, arrivals = ip.queue, ip.arrivals
    ov, hold, restarts = ip.override, ip.hold, ip.restarts
    old_s: dict[int, float] = {}
    old_t: dict[int, float] = {}
    seen = -1
    events = 0
    ahead = sooner = 0.0
    limit = time_limit(task.prog.table, sc)
    for _ in run_cycles(task, SimPlc(0.02), sc.schedule, sc.channel.cycle_time, limit):
        ip = task.interp
        if ip.restarts != restarts:
            old_s, old_t = {}, {}
            if (ip.override < ov and ip.hold == hold) or (ip.hold and not hold):
                # the discarded future is whole: an event's cycle releases nothing of it
                old_s = {e.k: e.s for e in queue}
                old_t = dict(arrivals)
                events += 1 if old_s else 0
            seen = -1
        if old_s:
            for e in reversed(ip.queue):
                if e.k <= seen:
                    break
                s0 = old_s.get(e.k)
                if s0 is not None:
                    ahead = max(ahead, e.s - s0)
                for c in e.crossings:
                    t0 = old_t.get(c.boundary)
                    if t0 is not None:
                        sooner = max(sooner, t0 - c.t)
            if ip.queue:
                seen = ip.queue[-1].k
        queue, arrivals = ip.queue, ip.arrivals
        ov, hold, restarts = ip.override, ip.hold, ip.restarts
    return events, ahead, sooner


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("runs", nargs="?", type=int, default=1000)
    ap.add_argument("first_seed", nargs="?", type=int, default=0)
    ap.add_argument("--kind", choices=sorted(KINDS), default="narrow")
    args = ap.parse_args()
    make = KINDS[args.kind]
    events = ahead_runs = sooner_runs = 0
    ahead = sooner = 0.0
    t0 = time.perf_counter()
    for seed in range(args.first_seed, args.first_seed + args.runs):
        n, a, s = probe(make(seed))
        events += n
        ahead, sooner = max(ahead, a), max(sooner, s)
        if a > AHEAD_TOL or s > SOONER_TOL:
            ahead_runs += a > AHEAD_TOL
            sooner_runs += s > SOONER_TOL
            print(json.dumps({"seed": seed, "ahead_m": a, "sooner_s": s}), flush=True)
    print(json.dumps({"bench": f"event_arrivals_{args.kind}", "runs": args.runs,
                      "first_seed": args.first_seed, "events": events,
                      "runs_ahead": ahead_runs, "max_ahead_m": ahead,
                      "runs_sooner": sooner_runs, "max_sooner_s": sooner,
                      "seconds": round(time.perf_counter() - t0, 1)}))  # fmt: skip


if __name__ == "__main__":
    main()
