"""The live view's drawing of a long program (`geometry.build`, as `UiHost.draw` runs it), A/B in
one run: in a worker thread (as before issue 38's review) and in a spawned process (now): how
late an event loop's 5 ms sleeps wake meanwhile (in the daemon: the ADS server's loop). One
JSON line per build.

Run: .venv/bin/python bench/bench_ui_drawing.py [RANGES=40000] [ROUNDS=2]
"""

from __future__ import annotations

import asyncio
import json
import multiprocessing
import sys
import time
from concurrent.futures import Executor, ProcessPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from liftd.settings import load_settings
from liftd.ui import geometry
from tests.support.paths import REPO
from tests.support.ui import hops_program

CH = load_settings(str(REPO / "config" / "liftd.toml")).channel


async def measure(executor: Executor | None, text: str) -> tuple[float, float, int, int]:
    loop = asyncio.get_running_loop()
    job = loop.run_in_executor(executor, geometry.build, CH, text)
    worst, n, t0 = 0.0, 0, time.perf_counter()
    while not job.done():
        a = time.perf_counter()
        await asyncio.sleep(0.005)
        worst = max(worst, time.perf_counter() - a - 0.005)
        n += 1
    g = job.result()
    return time.perf_counter() - t0, worst, n, len(g.encoded)


def main() -> None:
    ranges = int(sys.argv[1]) if len(sys.argv) > 1 else 40_000
    rounds = int(sys.argv[2]) if len(sys.argv) > 2 else 2
    text = hops_program(ranges)
    for rnd in range(rounds):
        for how in ("thread", "process"):
            ex = None
            if how == "process":
                ex = ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn"))
            took, worst, n, size = asyncio.run(measure(ex, text))
            if ex is not None:
                ex.shutdown()
            rec = {"bench": "ui_drawing_build_loop_lateness", "ranges": ranges, "round": rnd,
                   "how": how, "build_s": round(took, 2), "worst_lateness_ms": round(worst * 1e3, 1),
                   "sleeps": n, "encoded_mb": round(size / 1e6, 2)}  # fmt: skip
            print(json.dumps(rec), flush=True)


if __name__ == "__main__":
    main()
