"""A null GEO loop: a fixed workload on the GEO loop's 1 ms grid, to tell this machine's own
compute stalls from ours (issue 14: "0 cycles whose compute exceeded 25 % of the period …
next to a baseline of this machine measured in the same run").

cyclictest (rt-tests) measures how late a real-time task *wakes up*; this measures how long a
constant piece of work takes once it is awake, the way the GEO loop measures its compute
(perf_counter from wake-up to the end of the cycle's work; and, as it also does, on the
thread's CPU clock, which on this Firecracker VM counts the hypervisor's stalls too: steal is
not accounted to it, so only the wall clock of this probe tells the machine's share). The
work is pure Python over a
64 KiB copy (every cache line of two buffers, at C speed) and an arithmetic loop, calibrated
back to back at start to `--hot-us` (its median when the caches are warm); it never
changes, so every cycle above 25 % of the period is the machine's doing: a VM stall,
another tenant's cache traffic, an interrupt. Sleeps as the GEO loop sleeps
(`clock_nanosleep` to absolute deadlines, `liftd.runtime.rt.sleep_until`), with SCHED_FIFO
at --priority, memory locked and `/dev/cpu_dma_latency` held at 0 when permitted (as
`[rt]` does; skipped silently otherwise, and the JSON says which were taken).

Prints one JSON line: the calibrated hot cost, compute p50/p99/p99.9/max and mean in µs, the
compute summed over the run (s), the cycles above 25 % of the period and their share (and those
on the CPU clock), as bench_rt.py records beside the loop's own.

Run: .venv/bin/python bench/noise_probe.py --seconds 60 [--priority 80] [--hot-us 10] [--cpu N]
"""

from __future__ import annotations

import argparse
import ctypes
import gc
import json
import os
import struct
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from liftd.runtime.rt import sleep_until  # noqa: E402

SRC = bytes(range(256)) * 256  # 64 KiB
BUF = bytearray(len(SRC))


def work(iterations: int) -> int:
    """The constant workload: copy 64 KiB (every cache line of two buffers read or written,
    at C speed), then `iterations` multiply-adds in the interpreter."""
    BUF[:] = SRC
    acc = 0
    for i in range(iterations):
        acc = (acc + i * i) & 0xFFFF
    return acc


PAGE = 4096
SPREAD = bytearray(24 << 20)  # `--pages`: one byte of each of N pages spread over 24 MiB


def touch(pages: int) -> None:
    """Write one byte in each of `pages` pages spread evenly over SPREAD: the memory side of a
    cycle that touches many objects (the GEO step reads and writes hundreds of pages), which a
    64 KiB copy does not have."""
    step = len(SPREAD) // PAGE // max(pages, 1) * PAGE
    for i in range(0, pages * step, step):
        SPREAD[i] ^= 1


def calibrate(hot_us: float) -> tuple[int, float]:
    """Iterations whose warm median is `hot_us`, and that median (µs)."""

    def median_us(n: int) -> float:
        samples = []
        for _ in range(400):
            t0 = time.perf_counter_ns()
            work(n)
            samples.append(time.perf_counter_ns() - t0)
        samples.sort()
        return samples[len(samples) // 2] / 1e3

    base = median_us(0)
    per = (median_us(2000) - base) / 2000
    n = max(0, round((hot_us - base) / per)) if per > 0 else 0
    return n, median_us(n)


def take_rt(priority: int, cpu: int) -> list[str]:
    taken = []
    if cpu >= 0:
        os.sched_setaffinity(0, {cpu})
        taken.append(f"cpu{cpu}")
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
        taken.append("sched_fifo")
    except (PermissionError, OSError):
        pass
    libc = ctypes.CDLL(None, use_errno=True)
    if libc.mlockall(3) == 0:  # MCL_CURRENT | MCL_FUTURE
        taken.append("mlockall")
    try:
        fd = os.open("/dev/cpu_dma_latency", os.O_WRONLY)
        os.write(fd, struct.pack("i", 0))  # held until the process exits
        taken.append("cpu_dma_latency")
    except OSError:
        pass
    return taken


def run(
    seconds: float,
    priority: int,
    hot_us: float,
    cpu: int = -1,
    period_ns: int = 1_000_000,
    pages: int = 0,
) -> dict[str, object]:
    for _ in range(3):
        touch(len(SPREAD) // PAGE)  # every page of SPREAD mapped before mlockall
    taken = take_rt(priority, cpu) if priority > 0 else []
    iterations, hot = calibrate(hot_us)
    gc.collect()
    gc.freeze()
    gc.disable()
    now, cpu_now = time.perf_counter_ns, time.thread_time_ns
    n = int(seconds * 1e9 / period_ns)
    times = [0] * n
    cpu_over = 0
    deadline = now() + period_ns
    for k in range(n):
        if deadline > now():
            sleep_until(deadline)
        wake = now()
        wake_cpu = cpu_now()
        work(iterations)
        if pages:
            touch(pages)
        end_cpu = cpu_now()
        end = now()
        times[k] = end - wake
        if end_cpu - wake_cpu > period_ns // 4:
            cpu_over += 1
        deadline += period_ns
        while deadline < end:  # behind: the next deadline still ahead, as the loop regrids
            deadline += period_ns
    total_ns = sum(times)
    times.sort()
    quarter = period_ns // 4
    over = sum(1 for t in times if t > quarter)

    def q(p: float) -> float:
        return round(times[min(n - 1, int(p * n))] / 1e3, 1)

    return {
        "tool": "noise_probe",
        "cycles": n,
        "hot_us": round(hot, 1),
        "iterations": iterations,
        "pages": pages,
        "compute_us": {
            "0.5": q(0.5),
            "0.99": q(0.99),
            "0.999": q(0.999),
            "max": round(times[-1] / 1e3, 1),
        },
        "compute_mean_us": round(total_ns / 1e3 / max(n, 1), 2),
        "compute_s": round(total_ns / 1e9, 3),
        "over_25pct": over,
        "over_25pct_pct": round(100 * over / max(n, 1), 4),
        "cpu_over_25pct": cpu_over,
        "rt": taken,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--priority", type=int, default=80, help="SCHED_FIFO priority (0: none)")
    ap.add_argument("--hot-us", type=float, default=10.0, help="warm cost of the workload")
    ap.add_argument("--cpu", type=int, default=-1, help="pin to this cpu (-1: any)")
    ap.add_argument(
        "--pages",
        type=int,
        default=0,
        help="also write a byte in each of this many pages spread over 24 MiB",
    )
    args = ap.parse_args()
    print(
        json.dumps(run(args.seconds, args.priority, args.hot_us, args.cpu, pages=args.pages)),
        flush=True,
    )


if __name__ == "__main__":
    main()
