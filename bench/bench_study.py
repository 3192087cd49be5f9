"""`liftd study` on a generated library (issue 18): wall time with --jobs 1 and --jobs 2 on 200
CAM-shaped jobs (bench/gen_library.py), and peak memory of the parent and of the largest
worker; then 2000 one-lift programs, to show that the parent's memory does not grow with
the size of the library (results streamed, aggregates bounded).

Each run is the CLI as a user starts it (a subprocess); the memory figures are the ones the
study writes into report.json ("run": ru_maxrss of the parent, and the largest any worker
reported with its results). `programs_per_core_s` is the programs over the core-seconds the
study held (`--jobs` × the report's wall time; the workers' own CPU time is out of reach: the
pool's forkserver, not the study, waits for them): a study's cost, which the simulation's
speed sets (issue 39). One JSON line per figure.
`--jobs 1` runs only that study of the 200 jobs, `--no-small` leaves out the 2000 small
programs. `liftd` is imported from the current directory when it has one (`python -m`):
run from another worktree to measure that tree's liftd with the same library.
Run: .venv/bin/python bench/bench_study.py [--jobs N ...] [--no-small]   (~8 min on 2 cores)
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.cli import parser  # noqa: E402
from bench.gen_library import write_library  # noqa: E402

CONFIG = str(ROOT / "config" / "liftd.toml")
TINY = "G90 G17 G94\nG00 X10 Y10 Z1\nZ[LIFT_START POS=1 POS_LIMIT=30]\nG00 X{x} Y20\nZ[LIFT_END]\nM30\n"


def run_study(library: Path, out: Path, *extra: str) -> tuple[float, dict]:
    """`liftd study LIBRARY --out OUT EXTRA…` as a subprocess: its wall time and report.json
    (exits when the study does not exit 0)."""
    t0 = time.perf_counter()
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "liftd",
            "study",
            str(library),
            "-c",
            CONFIG,
            "--out",
            str(out),
            *extra,
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    wall = time.perf_counter() - t0
    if r.returncode != 0:
        raise SystemExit(f"liftd study exited {r.returncode}: {r.stderr[-3000:]}")
    return wall, json.loads((out / "report.json").read_text())


def study(library: Path, jobs: int, out: Path) -> dict[str, object]:
    wall, report = run_study(library, out, "--jobs", str(jobs))
    rows, summary, run = report["programs"], report["summary"], report["run"]
    simulated = sum(row["duration_advanced_s"] + row["duration_lifting_s"] for row in rows)
    return {
        "programs": summary["programs"],
        "lifts": summary["lifts"],
        "jobs": jobs,
        "wall_s": round(wall, 1),
        "study_wall_s": run["wall_s"],
        "simulated_s": round(simulated, 1),
        "x_real_time": round(simulated / wall, 1),
        "programs_per_core_s": round(summary["programs"] / (jobs * run["wall_s"]), 2),
        "liftd": str(Path.cwd()) if (Path.cwd() / "liftd").is_dir() else "installed",
        "max_rss_parent_mib": run["max_rss_mib"]["parent"],
        "max_rss_worker_mib": run["max_rss_mib"]["worker"],
        "clearance_ratio_of_means": summary["clearance_ratio_of_means"],
        "time_difference_pct": summary["time_difference_pct"],
    }


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--jobs", type=int, nargs="+", default=[1, 2], help="the studies of 200")
    ap.add_argument("--no-small", action="store_true", help="without the 2000 small programs")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(tmp)
        library = base / "library"
        paths = write_library(library, 200)
        blocks = sum(len(p.read_text().splitlines()) for p in paths)
        print(
            json.dumps(
                {
                    "bench": "study_library",
                    "programs": len(paths),
                    "lines": blocks,
                    "cores": len(os.sched_getaffinity(0)),
                }
            ),
            flush=True,
        )
        walls = {}
        for jobs in args.jobs:
            fig = study(library, jobs, base / f"out{jobs}")
            walls[jobs] = fig["wall_s"]
            print(json.dumps({"bench": "study_200", **fig}), flush=True)
        if 1 in walls and 2 in walls:
            speedup = round(walls[1] / walls[2], 2)
            print(json.dumps({"bench": "study_speedup", "jobs_2_vs_1": speedup}))
        if args.no_small:
            return
        tiny = base / "tiny"
        tiny.mkdir()
        for i in range(2000):
            (tiny / f"t{i:04d}.nc").write_text(TINY.format(x=20 + i % 500))
        fig = study(tiny, 2, base / "out_tiny")
        print(json.dumps({"bench": "study_2000_small", **fig}), flush=True)


if __name__ == "__main__":
    main()
