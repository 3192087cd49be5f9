"""`liftd study --scheduler` on a Dask cluster on this machine (issue 39), against the local
process pool in the same session (the VM is shared: every figure is stated against the local
`--jobs 1` run measured here, minutes before or after it):

1. throughput on N generated CAM-shaped jobs (bench/gen_library.py, default 200): local
   `--jobs 1` and `--jobs 2`, then a cluster (`dask scheduler` + `dask worker --nthreads 1`
   processes, tests/support/dask_cluster.py) with 1 worker and with 2 workers; programs per
   second, per worker, and the ratio to local `--jobs 1`;
2. the client's peak RSS over a library of M one-lift programs (default 10 000) on the
   2-worker cluster, and over M / 10, to show it does not grow with the library (results are
   streamed and submitted in windows);
3. an estimate for 100 000 of the CAM jobs on N workers, from the measured rate per worker.

Each run is the CLI as a user starts it (a subprocess); RSS is the report's "run" figure
(ru_maxrss of the client). One JSON line per figure.
Run: .venv/bin/python bench/bench_study_cluster.py [--jobs-library 200] [--small 10000]
"""

from __future__ import annotations

import json
import os
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.bench_study import run_study  # noqa: E402
from bench.cli import parser  # noqa: E402
from bench.gen_library import write_library  # noqa: E402
from tests.support.dask_cluster import DaskCluster  # noqa: E402

CONFIG = str(ROOT / "config" / "liftd.toml")
TINY = "G90 G17 G94\nG00 X10 Y10 Z1\nZ[LIFT_START POS=1 POS_LIMIT=30]\nG00 X{x} Y20\nZ[LIFT_END]\nM30\n"


def study(library: Path, out: Path, *extra: str) -> dict[str, object]:
    wall, report = run_study(library, out, *extra)
    n = report["summary"]["programs"]
    return {
        "programs": n,
        "wall_s": round(wall, 1),
        "study_wall_s": report["run"]["wall_s"],
        "programs_per_s": round(n / report["run"]["wall_s"], 2),
        "max_rss_client_mib": report["run"]["max_rss_mib"]["parent"],
        "max_rss_worker_mib": report["run"]["max_rss_mib"]["worker"],
        "csv": (out / "report.csv").read_text(),
    }


def wait_workers(cluster: DaskCluster, n: int) -> None:
    import distributed  # noqa: PLC0415

    with distributed.Client(cluster.address, timeout=120, set_as_default=False) as client:
        client.wait_for_workers(n, timeout=300)


def main() -> None:
    args = parser(__doc__)
    args.add_argument("--jobs-library", type=int, default=200, metavar="N")
    args.add_argument("--small", type=int, default=10000, metavar="M")
    opts = args.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(tmp)
        library = base / "library"
        write_library(library, opts.jobs_library)
        print(json.dumps({"bench": "study_cluster_setup", "programs": opts.jobs_library,
                          "cores": len(os.sched_getaffinity(0)),
                          "load_avg_1min": os.getloadavg()[0]}), flush=True)  # fmt: skip
        figures: dict[str, dict[str, object]] = {}
        for jobs in (1, 2):
            fig = study(library, base / f"local{jobs}", "--jobs", str(jobs))
            figures[f"local_{jobs}"] = fig
        cluster = DaskCluster(base / "cluster")
        try:
            for workers in (1, 2):
                cluster.add_worker()
                wait_workers(cluster, workers)
                fig = study(library, base / f"cluster{workers}", "--scheduler", cluster.address)
                figures[f"cluster_{workers}"] = fig
            ref = figures["local_1"]
            for name, fig in figures.items():
                workers = int(name.rsplit("_", 1)[1])
                same = fig["csv"] == ref["csv"]
                print(json.dumps({
                    "bench": f"study_{name}", **{k: v for k, v in fig.items() if k != "csv"},
                    "per_worker_programs_per_s": round(float(str(fig["programs_per_s"])) / workers, 3),
                    "vs_local_jobs_1": round(float(str(fig["programs_per_s"]))
                                             / float(str(ref["programs_per_s"])), 2),
                    "report_csv_equals_local_jobs_1": same,
                }), flush=True)  # fmt: skip
            per_worker = float(str(figures["cluster_2"]["programs_per_s"])) / 2
            for n in (1, 2, 8, 32, 128):
                hours = 100_000 / (per_worker * n) / 3600
                print(json.dumps({"bench": "study_estimate_100000_jobs", "workers": n,
                                  "hours": round(hours, 2),
                                  "from_programs_per_s_per_worker": round(per_worker, 3)}),
                      flush=True)  # fmt: skip
            for m in (opts.small // 10, opts.small):
                small = base / f"small{m}"
                small.mkdir()
                for i in range(m):
                    (small / f"t{i:05d}.nc").write_text(TINY.format(x=20 + i % 500))
                fig = study(small, base / f"small_out{m}", "--scheduler", cluster.address)
                print(json.dumps({"bench": "study_cluster_client_rss", "workers": 2,
                                  **{k: v for k, v in fig.items() if k != "csv"}}),
                      flush=True)  # fmt: skip
        finally:
            cluster.stop()


if __name__ == "__main__":
    main()
