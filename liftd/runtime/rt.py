"""Best-effort real-time settings of the GEO loop process, and its absolute-deadline sleep.

Each setting is tried once at start-up and reported (ok or why not); none is required, so the
loop also runs on a laptop or in CI (docs/reference/rt-python.md §0, §3): SCHED_FIFO, CPU affinity,
mlockall (after the heap is trimmed), timer slack 1 ns, /dev/cpu_dma_latency held at 0 (the
largest single gain measured on this VM); and PR_SET_PDEATHSIG so a dead daemon never leaves a
FIFO process spinning.
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import os
import signal
import struct
import time
from dataclasses import dataclass
from typing import NamedTuple

CLOCK_MONOTONIC = 1
TIMER_ABSTIME = 1
PR_SET_PDEATHSIG = 1
PR_SET_TIMERSLACK = 29
MCL_CURRENT, MCL_FUTURE = 1, 2

_libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)


class _Timespec(ctypes.Structure):
    _fields_ = [("tv_sec", ctypes.c_long), ("tv_nsec", ctypes.c_long)]


_clock_nanosleep = _libc.clock_nanosleep
_clock_nanosleep.argtypes = [ctypes.c_int, ctypes.c_int, ctypes.POINTER(_Timespec), ctypes.c_void_p]
_TS = _Timespec()
_TS_REF = ctypes.byref(_TS)


def spin_until(deadline_ns: int) -> None:
    """Busy-wait until the deadline (perf_counter_ns is CLOCK_MONOTONIC): the CPU never goes
    idle between cycles. On this VM an idle vCPU comes back with cold caches: a compiled
    GEO step took 16.6 µs p50 / 67 µs p99 after a 1 ms sleep, 6.3 / 46 µs after a 1 ms spin
    and 4.7 / 18.5 µs back to back (docs/service.md, "Running it as a service")."""
    now = time.perf_counter_ns
    while now() < deadline_ns:
        pass


def sleep_until(deadline_ns: int) -> None:
    """clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME) — the caller checks that the deadline
    is in the future (a past one still costs a timer round trip, ~20 µs here)."""
    _TS.tv_sec, _TS.tv_nsec = divmod(deadline_ns, 1_000_000_000)
    while _clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, _TS_REF, None) == 4:  # EINTR
        pass


@dataclass(frozen=True, slots=True)
class RtRequest:
    sched_fifo_priority: int = 80  # 0: do not ask
    cpu: int = -1  # -1: no pinning
    lock_memory: bool = True
    hold_cpu_dma_latency: bool = True
    timer_slack_ns: int = 1
    idle: str = "sleep"  # "sleep" or "spin" (the loop's wait for its next cycle)


class RtResult(NamedTuple):
    setting: str
    ok: bool
    detail: str


class RtState:
    """What was achieved; keeps /dev/cpu_dma_latency open (the request lasts while it is)."""

    def __init__(self) -> None:
        self.results: list[RtResult] = []
        self._dma_fd: int | None = None
        self.spin = False  # the loop busy-waits between cycles ([rt] idle = "spin", granted)

    def close(self) -> None:
        if self._dma_fd is not None:
            os.close(self._dma_fd)
            self._dma_fd = None


def _errno_text() -> str:
    err = ctypes.get_errno()
    return os.strerror(err) if err else "failed"


def die_with_parent() -> None:
    """SIGKILL this process when the daemon dies, so a dead daemon never leaves a SCHED_FIFO
    loop spinning (or, after the daemon's end, holding memory)."""
    _libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)


def apply(req: RtRequest) -> RtState:
    """Take each requested setting and report it. Call it once everything the loop needs is
    allocated: the heap is trimmed first, so mlockall locks what the loop uses, not what
    start-up left free (MCL_FUTURE then locks what the loop still maps, e.g. a reload)."""
    state = RtState()
    res = state.results
    if req.timer_slack_ns > 0:
        ok = _libc.prctl(PR_SET_TIMERSLACK, req.timer_slack_ns, 0, 0, 0) == 0
        res.append(RtResult("timer_slack", ok, f"{req.timer_slack_ns} ns" if ok else _errno_text()))
    if req.cpu >= 0:
        try:
            os.sched_setaffinity(0, {req.cpu})
            res.append(RtResult("cpu_affinity", True, f"cpu {req.cpu}"))
        except OSError as exc:
            res.append(RtResult("cpu_affinity", False, exc.strerror or str(exc)))
    if req.lock_memory:
        _libc.malloc_trim(0)  # give back the free heap pages start-up left behind
        ok = _libc.mlockall(MCL_CURRENT | MCL_FUTURE) == 0
        res.append(RtResult("mlockall", ok, "current and future pages" if ok else _errno_text()))
    if req.hold_cpu_dma_latency:
        try:
            fd = os.open("/dev/cpu_dma_latency", os.O_WRONLY)
            os.write(fd, struct.pack("<i", 0))
            state._dma_fd = fd
            res.append(RtResult("cpu_dma_latency", True, "held at 0 µs"))
        except OSError as exc:
            res.append(RtResult("cpu_dma_latency", False, exc.strerror or str(exc)))
    if req.sched_fifo_priority > 0:
        try:
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(req.sched_fifo_priority))
            res.append(RtResult("sched_fifo", True, f"priority {req.sched_fifo_priority}"))
        except OSError as exc:
            res.append(RtResult("sched_fifo", False, exc.strerror or str(exc)))
    if req.idle == "spin":
        fifo = any(r.setting == "sched_fifo" and r.ok for r in res)
        refusal = spin_refusal(fifo, rt_runtime_us())
        state.spin = refusal is None
        where = f"cpu {req.cpu}" if req.cpu >= 0 else "unpinned: set [rt] cpu"
        detail = f"busy-waits between cycles ({where})" if refusal is None else refusal
        res.append(RtResult("idle_spin", refusal is None, detail))
    return state


def keep_off_cpu(cpu: int) -> RtResult:
    """Move every thread of this process (the daemon) off `cpu`, the one the GEO loop spins
    on; threads started later inherit the main thread's set. A SCHED_OTHER task on the
    spinning loop's CPU is not starved: the kernel's fair server (Linux >= 6.12) gives it up to
    50 ms of every second, also with sched_rt_runtime_us = -1, and the loop stands still that
    long (measured on this VM's 6.18 kernel: a SCHED_FIFO spinner beside a busy SCHED_OTHER
    task lost 14 stretches of ~50 ms in 15 s, alone none; `bench/rt_share_probe.py`).
    The machine's other processes are the operator's to keep off (isolcpus=, systemd's
    CPUAffinity=, taskset)."""
    others = os.sched_getaffinity(0) - {cpu}
    if not others:
        return RtResult("daemon_cpus", False, f"kept: no cpu but {cpu} to move to")
    try:
        for tid in os.listdir("/proc/self/task"):
            with contextlib.suppress(ProcessLookupError):  # a thread that just ended
                os.sched_setaffinity(int(tid), others)
    except OSError as exc:
        return RtResult("daemon_cpus", False, exc.strerror or str(exc))
    return RtResult("daemon_cpus", True, f"cpus {','.join(map(str, sorted(others)))}, off {cpu}")


def rt_runtime_us() -> int | None:
    """/proc/sys/kernel/sched_rt_runtime_us: the real-time tasks' share of each second of a
    CPU (-1: unlimited); None where it cannot be read."""
    try:
        with open("/proc/sys/kernel/sched_rt_runtime_us") as f:
            return int(f.read().strip())
    except (OSError, ValueError):
        return None


def spin_refusal(fifo: bool, runtime_us: int | None) -> str | None:
    """Why the loop must not busy-wait, or None. A SCHED_FIFO task that never sleeps uses up
    the kernel's real-time share of its CPU and is stopped for the rest of each second:
    measured here with the default 950000 µs, the loop stood still ~50 ms every second (5 %
    of its cycles exceeded, `bench/bench_rt.py --mode spin`, 2026-12-01). Linux 6.12 replaced
    that throttling by the fair server only where RT_GROUP_SCHED is off (commit "sched/rt:
    Remove default bandwidth control"); this VM's 6.18 kernel has it on and still throttles (a
    spinner alone on its cpu: 13–15 stops of ~50 ms in 15 s at 950000, none at -1,
    `bench/rt_share_probe.py`, 2026-12-03), so the share is read, not the kernel's version."""
    if fifo and runtime_us is not None and runtime_us >= 0:
        return (
            f"refused, the loop sleeps: sched_rt_runtime_us is {runtime_us}, so the kernel "
            f"would stop a spinning SCHED_FIFO loop for {(1_000_000 - runtime_us) // 1000} ms "
            "every second; spin needs -1 there (a CPU the machine can spare)"
        )
    return None
