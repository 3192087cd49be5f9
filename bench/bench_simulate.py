"""Simulation speed and memory: the demo program, the 120-part nesting job and a generated
10 000-block job.

Figures to reach: ≥ 50× real time at 1 ms cycles, constant memory (trace streamed), start-up
included (issue 3); on the nesting job ≥ 100× with the trace and ≥ 200× without, start-up
excluded (issue 14); ≥ 300× with the trace and ≥ 500× without (issue 39): `x_real_time_cycles`
divides the simulated time by the wall time less the start-up (`GeoTask` construction: decode
and preparation of the program, `startup_s`, the fastest of `repeat` constructions).
`simulate` runs its quiet cycles in batches (liftd/cnc/batch.py); `--single-steps` measures
the same runs cycle by cycle (`simulate(batch=False)`, as before issue 39).
Run: .venv/bin/python bench/bench_simulate.py [--single-steps]
"""

from __future__ import annotations

import io
import json
import resource
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.cli import parser  # noqa: E402
from liftd.cnc.geo_task import GeoTask  # noqa: E402
from liftd.cnc.plc import Schedule  # noqa: E402
from liftd.settings import load_settings  # noqa: E402
from liftd.sim.simulate import simulate  # noqa: E402
from tests.support.programs import count_blocks, nesting_program  # noqa: E402


class Sink(io.TextIOBase):
    """Counts what the trace writer writes (the rows are formatted, not stored)."""

    def __init__(self) -> None:
        self.chars = 0

    def write(self, s: str) -> int:
        self.chars += len(s)
        return len(s)


BATCH = {"batch": True}  # simulate's keyword: False with --single-steps


def run(
    name: str, text: str, trace: bool, schedule: Schedule | None = None, repeat: int = 3
) -> None:
    """Best of `repeat` runs (this shared 2-vCPU VM swings ±25 % between identical runs)."""
    settings = load_settings(str(ROOT / "config" / "liftd.toml"))
    startups = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        GeoTask(settings.channel, text)
        startups.append(time.perf_counter() - t0)
    startup = min(startups)
    walls = []
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    for _ in range(repeat):
        sink = Sink() if trace else None
        t0 = time.perf_counter()
        # as `liftd simulate` without --plot: no decimated series for a figure
        res = simulate(
            settings.channel, text, schedule or Schedule(), 0.02, sink, series=False, **BATCH
        )  # type: ignore[arg-type]
        walls.append(time.perf_counter() - t0)
    rss1 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    wall = min(walls)
    s = res.summary
    print(
        json.dumps(
            {
                "bench": "simulate",
                "program": name,
                "blocks": count_blocks(text),
                "trace": trace,
                "batch": BATCH["batch"],
                "cycles": s.cycles,
                "simulated_s": s.duration_s,
                "wall_s": round(wall, 3),
                "x_real_time": round(s.duration_s / wall, 1),
                "x_real_time_median": round(s.duration_s / sorted(walls)[len(walls) // 2], 1),
                "startup_s": round(startup, 3),
                "x_real_time_cycles": round(s.duration_s / (wall - startup), 1),
                "us_per_cycle": round(wall / s.cycles * 1e6, 2),
                "lifts": len(s.lifts),
                "trace_mb": round(sink.chars / 1e6, 1) if sink else 0,
                "max_rss_growth_mb": round((rss1 - rss0) / 1024, 1),
                "limits_max": round(s.limits.worst(), 9),
            }
        )
    )


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--single-steps", action="store_true", help="simulate(batch=False)")
    BATCH["batch"] = not ap.parse_args().single_steps
    demo = (ROOT / "config" / "programs" / "demo.nc").read_text()
    run("demo.nc", demo, trace=False)
    run("demo.nc", demo, trace=True)
    nesting = nesting_program(120)  # issue 14's job: 120 parts, 1 680 blocks, 119 lifts
    run("nesting-120", nesting, trace=False, repeat=5)
    run("nesting-120", nesting, trace=True, repeat=5)
    big = nesting_program(715)  # ~10 000 blocks
    run("generated-10k", big, trace=True)
    # memory over time: the demo at 10 % override runs ten times longer, same program size
    run("demo.nc at 10 %", demo, trace=True, schedule=Schedule(override=((0.0, 0.1),)), repeat=1)


if __name__ == "__main__":
    main()
