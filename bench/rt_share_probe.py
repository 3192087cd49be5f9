"""How long the kernel keeps a spinning SCHED_FIFO loop off its cpu: the facts behind liftd's
refusal of `[rt] idle = "spin"` at a limited real-time share and behind the daemon keeping its
threads off a spinning loop's cpu (docs/service.md, `runtime.rt.keep_off_cpu`).

A SCHED_FIFO loop pinned to --cpu reads the monotonic clock back to back for --seconds; every
gap between two reads is time it was kept off its cpu. With --neighbour a busy SCHED_OTHER
process is pinned to the same cpu for the run. Two mechanisms show as stops of ~50 ms a second:
RT throttling (`sched_rt_runtime_us` < 1 000 000, still in force where the kernel has
RT_GROUP_SCHED, also after Linux 6.12) and the fair server (Linux >= 6.12: a SCHED_OTHER task
on the cpu gets up to 50 ms a second whatever `sched_rt_runtime_us` says). Needs root (or
RLIMIT_RTPRIO) for SCHED_FIFO; prints one JSON line.

Run: .venv/bin/python bench/rt_share_probe.py --cpu 1 --seconds 15 [--neighbour]
     (compare runs with /proc/sys/kernel/sched_rt_runtime_us at 950000 and at -1)
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from liftd.runtime.rt import rt_runtime_us  # noqa: E402


def spin(seconds: float) -> dict[str, float]:
    """The gaps of a back-to-back clock loop: counts above 250 µs, 1 ms, 10 ms and 40 ms, the
    longest and the time lost in gaps above 250 µs (ms)."""
    now = time.perf_counter_ns
    end = now() + int(seconds * 1e9)
    last = now()
    gaps: list[int] = []
    while last < end:
        t = now()
        if t - last > 250_000:
            gaps.append(t - last)
        last = t
    return {
        "over_250us": len(gaps),
        "over_1ms": sum(g > 1_000_000 for g in gaps),
        "over_10ms": sum(g > 10_000_000 for g in gaps),
        "over_40ms": sum(g > 40_000_000 for g in gaps),
        "max_ms": round(max(gaps, default=0) / 1e6, 2),
        "lost_ms": round(sum(gaps) / 1e6, 1),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cpu", type=int, default=1)
    ap.add_argument("--seconds", type=float, default=15.0)
    ap.add_argument("--priority", type=int, default=80)
    ap.add_argument("--neighbour", action="store_true", help="a busy SCHED_OTHER task there")
    args = ap.parse_args()
    neighbour = None
    if args.neighbour:
        neighbour = subprocess.Popen(
            ["taskset", "-c", str(args.cpu), sys.executable, "-c", "while True: pass"]
        )
        time.sleep(0.2)
    try:
        os.sched_setaffinity(0, {args.cpu})
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(args.priority))
        gaps = spin(args.seconds)
        os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
    finally:
        if neighbour is not None:
            neighbour.kill()
            neighbour.wait()
    print(
        json.dumps(
            {
                "bench": "rt_share_probe",
                "cpu": args.cpu,
                "seconds": args.seconds,
                "sched_rt_runtime_us": rt_runtime_us(),
                "neighbour": args.neighbour,
                "kernel": os.uname().release,
                **gaps,
            }
        ),
        flush=True,
    )


if __name__ == "__main__":
    main()
