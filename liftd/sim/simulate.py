"""`liftd simulate`: the GEO core on a virtual clock, as fast as possible.

Drives GeoTask.step with t = k × cycle time, applies the override / feed-hold schedules, plays a
simple PLC that acknowledges M functions (and continues after M00) after `plc.m_ack_delay_ms`,
streams the trace CSV, keeps a decimated copy for the plot, and builds the JSON summary of
DESIGN.md §3.3.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any, TextIO

import numpy as np

from liftd.cnc.geo_task import LIFT_LATE_ID, GeoTask
from liftd.cnc.lift.controller import LiftRecord
from liftd.cnc.params import ChannelParams, LiftMethod
from liftd.cnc.plc import Schedule, SimPlc
from liftd.cnc.snapshot import ChannelState, GeoSnapshot
from liftd.sim.trace import LimitMonitor, TraceWriter

MM = 1e3


class SeriesBuffer:
    """Decimated copy of the run for plotting, constant memory: when full, every other sample
    is dropped and the stride doubles."""

    def __init__(self, columns: int, capacity: int = 20000) -> None:
        self.data = np.zeros((capacity, columns))
        self.n = 0
        self.stride = 1
        self.count = 0

    def wants(self) -> bool:
        """Count a sample; True if it is kept (build the row only then)."""
        self.count += 1
        return not (self.count - 1) % self.stride

    def add(self, row: tuple[float, ...]) -> None:
        """Store a sample that `wants()` accepted."""
        if self.n == self.data.shape[0]:
            self.data[: self.n // 2] = self.data[: self.n : 2]
            self.n //= 2
            self.stride *= 2
            if (self.count - 1) % self.stride:
                return
        self.data[self.n] = row
        self.n += 1

    @property
    def rows(self) -> np.ndarray:
        return self.data[: self.n]


@dataclass
class SimResult:
    summary: dict[str, Any]
    series: SeriesBuffer
    records: list[LiftRecord] = field(default_factory=list)
    program_error: bool = False
    finished: bool = True


def channel_for(ch: ChannelParams, method: str) -> ChannelParams:
    """--method: 'config' keeps what the lists enable; 'advanced'/'lifting' force one."""
    if method == "config":
        return ch
    return dataclasses.replace(ch, lift_method=LiftMethod(method))


class StepTimer:
    """Compute time of `GeoTask.step` measured as the GEO loop measures it (perf_counter: the
    thread's CPU time plus any preemption, so an upper bound; the thread CPU clock is a system
    call costing ~3 µs on this VM): a histogram of 1 µs buckets up to 10 ms and the exact
    maximum, constant memory."""

    BUCKETS = 10_000

    def __init__(self) -> None:
        self.counts = [0] * (self.BUCKETS + 1)
        self.n = 0
        self.max_ns = 0

    def add(self, ns: int) -> None:
        self.n += 1
        self.max_ns = max(self.max_ns, ns)
        us = ns // 1000
        self.counts[us if us < self.BUCKETS else self.BUCKETS] += 1

    def percentile(self, q: float) -> float:
        """The q-quantile in µs (upper edge of its 1 µs bucket)."""
        if self.n == 0:
            return 0.0
        rank = q * self.n
        seen = 0
        for us, c in enumerate(self.counts):
            seen += c
            if seen >= rank:
                return float(min(us + 1, self.max_ns / 1e3))
        return self.max_ns / 1e3

    def summary(self) -> dict[str, float]:
        return {
            "p50": self.percentile(0.5),
            "p99": self.percentile(0.99),
            "p999": self.percentile(0.999),
            "max": round(self.max_ns / 1e3, 1),
        }


def run_cycles(
    task: GeoTask,
    plc: SimPlc,
    schedule: Schedule,
    dt: float,
    max_time: float,
    timer: StepTimer | None = None,
) -> Iterator[GeoSnapshot]:
    last: GeoSnapshot | None = None
    k = 0
    limit = round(max_time / dt)
    clock = time.perf_counter_ns
    while k < limit:
        k += 1
        t = k * dt
        inputs = plc.inputs(last, t, schedule)
        if timer is not None:
            c0 = clock()
            snap = task.step(inputs, t)
            timer.add(clock() - c0)
        else:
            snap = task.step(inputs, t)
        yield snap
        last = snap
        if snap.state in (ChannelState.READY, ChannelState.ERROR) and task.runs:
            return


def simulate(
    ch: ChannelParams,
    text: str,
    schedule: Schedule,
    m_ack_delay: float,
    trace: TextIO | None = None,
    max_time: float = 3600.0,
    on_cycle: Callable[[GeoSnapshot], None] | None = None,
) -> SimResult:
    dt = ch.cycle_time
    task = GeoTask(ch, text)
    plc = SimPlc(m_ack_delay)
    writer = TraceWriter(trace, ch.axis_names) if trace is not None else None
    monitor = LimitMonitor(len(ch.axes), dt)
    series = SeriesBuffer(len(ch.axes) + 6)
    errors: list[dict[str, Any]] = []
    snap: GeoSnapshot | None = None
    cycles = 0
    timer = StepTimer()
    for snap in run_cycles(task, plc, schedule, dt, max_time, timer):
        cycles += 1
        if writer is not None:
            writer.write(snap)
        monitor.add(snap.positions)
        if on_cycle is not None:
            on_cycle(snap)
        if series.wants():
            series.add(
                (
                    snap.t,
                    *snap.positions,
                    snap.v_path,
                    snap.override,
                    float(snap.lift_active),
                    float(snap.lift_suppressed),
                    float(snap.line),
                )
            )
        for ev in snap.events:
            if ev.name == "geo.error":
                errors.append({"id": int(ev.value), "line": ev.line, "message": ev.text})
            elif ev.name == "lift.late":
                errors.append({"id": LIFT_LATE_ID, "line": ev.line, "message": ev.text})
    if writer is not None:
        writer.flush()
    finished = snap is not None and snap.state in (ChannelState.READY, ChannelState.ERROR)
    summary = build_summary(ch, task, monitor, cycles, snap.t if snap else 0.0, errors)
    summary["step_cpu_us"] = timer.summary()
    program_error = any(e["id"] != LIFT_LATE_ID for e in errors)
    return SimResult(summary, series, list(task.lift.records), program_error, finished)


def lift_summary(rec: LiftRecord, method: LiftMethod) -> dict[str, Any]:
    spec = rec.range.start
    duration = rec.t_end - rec.t_start
    return {
        "start_line": spec.line,
        "end_line": rec.range.end_line,
        "method": method.value,
        "suppressed": rec.range.suppressed,
        "z_start": round(rec.z_start * MM, 6),
        "z_target": round(spec.target * MM, 6),
        "pos_limit": round(spec.pos_limit * MM, 6),
        "peak": round(rec.peak * MM, 6),
        "mean_clearance": round(rec.area / duration * MM, 6) if duration > 0 else 0.0,
        "t_start": round(rec.t_start, 6),
        "t_end": round(rec.t_end, 6),
        "arrival_error": round(rec.arrival_error * MM, 6),
        "path_delay_s": round(rec.path_delay, 6),
        "duration_s": round(duration, 6),
        "z_a_max_ratio": round(rec.z_a_max_ratio, 6),
        "premature": rec.premature,
    }


def build_summary(
    ch: ChannelParams,
    task: GeoTask,
    monitor: LimitMonitor,
    cycles: int,
    duration: float,
    errors: list[dict[str, Any]],
) -> dict[str, Any]:
    max_v, max_a, max_j = monitor.result()
    limits: dict[str, float] = {}
    z = ch.lift_axis_index
    order = [z] + [i for i in range(len(ch.axes)) if i != z]
    for i in order:
        ax = ch.axes[i]
        prefix = "z" if i == z else ax.name.lower()
        limits[f"{prefix}_v_max_ratio"] = float(max_v[i] / ax.v_max)
        limits[f"{prefix}_a_max_ratio"] = float(max_a[i] / ax.a_max)
        limits[f"{prefix}_j_max_ratio"] = (
            float(max_j[i] / ax.j_max) if ax.j_max != math.inf else 0.0
        )
    return {
        "cycle_time_s": ch.cycle_time,
        "duration_s": round(duration, 6),
        "cycles": cycles,
        "method": ch.lift_method.value,
        "lifts": [lift_summary(r, ch.lift_method) for r in task.lift.records],
        "limits": limits,
        "z_overload": {
            "warning_ratio": task.z_monitor.warn_ratio,
            "error_ratio": task.z_monitor.err_ratio,
            "warning_cycles": task.z_monitor.warning_cycles,
            "error_cycles": task.z_monitor.error_cycles,
        },
        "errors": errors,
    }
