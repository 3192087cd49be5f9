"""Ruckig solves per GEO cycle on bench_step.py's programs and schedules (issue 36): the work a
path-tracker change adds or saves, counted by the core itself (the producer's calculator,
`Ruckig1.calls`), so it reads the same on any machine. This VM's speed swings 2–7× between
hours (docs/measurements.md), so a step-time A/B of a change that adds a profile here and
there cannot tell it from the machine; this can, and bench_step.py then says what the
solves cost in µs when the VM is quiet.

One JSON line per program: cycles, solves in all, and per cycle p50 / p99 / p99.9 / max.
The schedule is bench_step.py's for the program's duration (override steps and holds where the
program's name says so). The nominal run's own tracker is not counted.

Run: .venv/bin/python bench/bench_solves.py [NAME ...]   (all of bench_step.py's programs by
default; ~1 min)
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.bench_step import programs  # noqa: E402
from bench.cli import parser  # noqa: E402
from liftd.cnc.geo_task import GeoTask  # noqa: E402
from liftd.cnc.plc import Schedule, SimPlc  # noqa: E402
from liftd.settings import load_settings  # noqa: E402
from liftd.sim.simulate import simulate  # noqa: E402


def solves(name: str, text: str, schedule: Schedule) -> dict[str, object]:
    """The run's ruckig solves, cycle by cycle, as percentiles (a new program run has a new
    interpolator: its first cycle counts 0)."""
    ch = load_settings(str(ROOT / "config" / "liftd.toml")).channel
    task, plc = GeoTask(ch, text), SimPlc(0.02)
    last = None
    per: list[int] = []
    for k in range(1, 10_000_000):
        t = k * ch.cycle_time
        inputs = plc.inputs(last, t, schedule)
        before = task.interp
        calls = before.prod.calc.calls
        last = task.step(inputs, t)
        per.append(task.interp.prod.calc.calls - calls if task.interp is before else 0)
        if last.state.name in ("READY", "ERROR") and task.runs:
            break
    per.sort()
    n = len(per)
    return {
        "bench": "solves",
        "program": name,
        "cycles": n,
        "solves": sum(per),
        "p50": per[n // 2],
        "p99": per[int(0.99 * n)],
        "p999": per[int(0.999 * n)],
        "max": per[-1],
    }


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("names", nargs="*", metavar="NAME", help="programs to run (all by default)")
    args = ap.parse_args()
    progs = programs()
    wanted: list[str] = args.names
    if unknown := [n for n in wanted if n not in progs]:
        ap.error(f"no program {', '.join(map(repr, unknown))}; there are: {', '.join(progs)}")
    ch = load_settings(str(ROOT / "config" / "liftd.toml")).channel
    for name, (text, schedule_for) in progs.items():
        if wanted and name not in wanted:
            continue
        first = simulate(ch, text, Schedule(), 0.02, max_time=3600.0)  # its duration
        print(json.dumps(solves(name, text, schedule_for(first.summary.duration_s))), flush=True)


if __name__ == "__main__":
    main()
