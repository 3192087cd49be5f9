"""`liftd simulate`: the GEO core on a virtual clock, as fast as possible.

Drives GeoTask.step with t = k × cycle time, applies the override / feed-hold schedules, plays a
simple PLC that acknowledges M functions (and continues after M00) after `plc.m_ack_delay_ms`,
streams the trace CSV, keeps a decimated copy for the plot, and builds the summary of
docs/reference/design.md §3.3 (summary.SimSummary). The cycles that leave the PLC nothing to
answer run in batches inside the core (`run_batched`, liftd/cnc/batch.py), bit for bit the run
of single steps.
"""

from __future__ import annotations

import bisect
import contextlib
import dataclasses
import gc
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Final, Protocol, TextIO

from liftd.cnc import batch as row
from liftd.cnc.geo_task import LIFT_LATE_ID, GeoTask
from liftd.cnc.machine import ChannelProgram, Machine
from liftd.cnc.params import ChannelParams, LiftMethod
from liftd.cnc.plc import Schedule, SimPlc
from liftd.cnc.snapshot import ChannelState, GeoInputs, GeoSnapshot
from liftd.sim.recorders import SeriesBuffer, StepTimer
from liftd.sim.summary import ErrorEntry, LiftSummary, Limits, Overload, SimSummary, StepCpu
from liftd.sim.trace import LimitMonitor, TraceWriter

# READY or ERROR: the program has ended (a C static of the compiled module; an enum attribute is
# two lookups a use)
ENDED: Final = (ChannelState.READY, ChannelState.ERROR)
ACTIVE: Final = ChannelState.ACTIVE
# quiet cycles run in one call of the core at most (liftd/cnc/batch.py; their rows: ~0.4 MB)
BATCH: Final = 1024


class Plc(Protocol):
    """What drives a channel's inputs cycle by cycle: the simulated PLC (`SimPlc`), or a test's
    own (a protocol, not the class: the compiled driver checks argument types)."""

    def inputs(self, last: GeoSnapshot | None, t: float, schedule: Schedule) -> GeoInputs: ...


@dataclass(frozen=True)
class SimResult:
    summary: SimSummary
    series: SeriesBuffer  # decimated samples for the figure
    finished: bool = True  # the program ended (READY or ERROR) within max_time

    @property
    def program_error(self) -> bool:
        return self.summary.program_error


def channel_for(ch: ChannelParams, method: str) -> ChannelParams:
    """--method: 'config' keeps what the lists enable; 'advanced'/'lifting' force one."""
    if method == "config":
        return ch
    return dataclasses.replace(ch, lift_method=LiftMethod(method))


def at_rest(snap: GeoSnapshot) -> bool:
    """The lift axis stands: a run ends with its program and the last motion it caused (after
    an NC error inside a range Z still rises to POS_LIMIT, vendor §2.4: the trace shows it)."""
    return snap.lift_vz == 0.0 and snap.lift_az == 0.0


def run_cycles(
    task: GeoTask,
    plc: Plc,
    schedule: Schedule,
    dt: float,
    max_time: float,
    timer: StepTimer | None = None,
) -> Iterator[GeoSnapshot]:
    last: GeoSnapshot | None = None
    k = 0
    limit = round(max_time / dt)
    clock = timer.clock if timer is not None else time.perf_counter_ns
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
        if snap.state in ENDED and task.runs and at_rest(snap):
            return


class ChannelRun:
    """What one channel's run records, cycle by cycle: its trace, the limit monitor, the
    decimated series for the plot, its errors and step CPU time."""

    def __init__(
        self,
        ch: ChannelParams,
        trace: TextIO | None = None,
        on_cycle: Callable[[GeoSnapshot], None] | None = None,
        step_clock: Callable[[], int] = time.perf_counter_ns,
        series: bool = True,
        on_rows: Callable[[list[float], int, int], None] | None = None,
    ) -> None:
        """`series`: keep the decimated samples for a figure (--plot); without, `series` stays
        empty (~0.3 µs a cycle saved). `on_rows(rows, axes_at, width)`: `on_cycle` for the
        rows of quiet cycles (`add_rows`)."""
        self.ch = ch
        self.writer = TraceWriter(trace, ch.axis_names) if trace is not None else None
        self.monitor = LimitMonitor(len(ch.axes), ch.cycle_time)
        self.series = SeriesBuffer(len(ch.axes) + 6)
        self.keep_series = series
        self.errors: list[ErrorEntry] = []
        self.last: GeoSnapshot | None = None
        self.cycles = 0
        self.timer = StepTimer(step_clock)
        self.on_cycle = on_cycle
        self.on_rows = on_rows
        self.width = row.row_width(len(ch.axes))  # a quiet cycle's row (`add_rows`)

    def add(self, snap: GeoSnapshot) -> None:
        self.cycles += 1
        self.last = snap
        if self.writer is not None:
            self.writer.write(snap)
        self.monitor.add(snap.positions, snap.segment)
        if self.on_cycle is not None:
            self.on_cycle(snap)
        if self.keep_series and self.series.wants():
            self.series.add(
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
                self.errors.append(ErrorEntry(int(ev.value), ev.line, ev.text))
            elif ev.name == "lift.late":
                self.errors.append(ErrorEntry(LIFT_LATE_ID, ev.line, ev.text))

    def add_rows(self, rows: list[float]) -> None:
        """The rows of quiet cycles (liftd/cnc/batch.py: no event, nothing for `on_cycle`),
        recorded as `add` records their snapshots."""
        width = self.width
        self.cycles += len(rows) // width
        if self.writer is not None:
            self.writer.write_rows(rows, row.POSITIONS, width)
        self.monitor.add_rows(rows, row.POSITIONS, width)
        if self.on_rows is not None:
            self.on_rows(rows, row.POSITIONS, width)
        if self.keep_series:
            n_axes = width - row.POSITIONS
            for base in range(0, len(rows), width):
                if self.series.wants():
                    at = base + row.POSITIONS
                    self.series.add(
                        (
                            rows[base + row.T],
                            *rows[at : at + n_axes],
                            rows[base + row.V_PATH],
                            rows[base + row.OVERRIDE],
                            rows[base + row.LIFT_ACTIVE],
                            rows[base + row.LIFT_SUPPRESSED],
                            rows[base + row.LINE],
                        )
                    )

    def result(self, task: GeoTask) -> SimResult:
        if self.writer is not None:
            self.writer.flush()
        snap = self.last
        finished = snap is not None and snap.state in ENDED
        # the NC error's file: its line may be a subroutine file's (the event carries the line)
        err = task.prog.error
        errors = tuple(
            dataclasses.replace(e, file=err.file)
            if err is not None and err.file and (e.error_id, e.line) == (err.id, err.line)
            else e
            for e in self.errors
        )
        summary = build_summary(self.ch, task, self.monitor, self.cycles, snap, errors,
                                self.timer.summary())  # fmt: skip
        return SimResult(summary, self.series, finished)


@contextlib.contextmanager
def collector_off() -> Iterator[None]:
    """The cycles of a run with the garbage collector frozen and off, as the GEO process runs
    them (runtime/geo_loop.py): the core makes no reference cycles, and the collector's passes
    over the prepared program were ~4 % of a run."""
    enabled = gc.isenabled()
    gc.freeze()
    gc.disable()
    try:
        yield
    finally:
        gc.unfreeze()
        if enabled:
            gc.enable()


def simulate(
    ch: ChannelParams,
    text: str,
    schedule: Schedule,
    m_ack_delay: float,
    trace: TextIO | None = None,
    max_time: float = 3600.0,
    on_cycle: Callable[[GeoSnapshot], None] | None = None,
    step_clock: Callable[[], int] = time.perf_counter_ns,
    series: bool = True,
    batch: bool = True,
    on_rows: Callable[[list[float], int, int], None] | None = None,
) -> SimResult:
    """`batch`: the quiet cycles in batches (`run_batched`; with an `on_cycle` only when
    `on_rows` takes their rows); the same run, trace and summary bit for bit except
    `step_cpu_us`, which then counts each cycle of a batch at the batch's average (single
    steps: `batch=False`)."""
    task = GeoTask(ch, text)
    run = ChannelRun(ch, trace, on_cycle, step_clock, series, on_rows)
    plc = SimPlc(m_ack_delay)
    with collector_off():
        if batch and (on_cycle is None or on_rows is not None):
            run_batched(task, plc, schedule, ch.cycle_time, max_time, run)
        else:
            for snap in run_cycles(task, plc, schedule, ch.cycle_time, max_time, run.timer):
                run.add(snap)
    return run.result(task)


def run_batched(
    task: GeoTask, plc: SimPlc, schedule: Schedule, dt: float, max_time: float, run: ChannelRun
) -> None:
    """`run_cycles` recorded by `run`, the quiet cycles in batches: after a cycle that leaves
    the PLC nothing to answer (ACTIVE, no M function waiting), the next cycles run in one
    call of the core (`batch.run_quiet`) with the inputs the PLC gives the first of them, up
    to the next override or feed-hold step of the schedule, which the PLC would read."""
    last: GeoSnapshot | None = None
    k = 0
    limit = round(max_time / dt)
    timer = run.timer
    clock = timer.clock
    # the schedule's steps as `Schedule.override_at`/`hold_at` compare them
    edges = sorted({e - 1e-12 for e in schedule_times(schedule)})
    rows: list[float] = []
    width = run.width
    while k < limit:
        k += 1
        t = k * dt
        inputs = plc.inputs(last, t, schedule)
        n = 1
        if last is not None and last.state is ACTIVE and last.m_pending < 0:
            n = quiet_span(k, dt, limit, edges)
        c0 = clock()
        if n == 1:
            snap = task.step(inputs, t)
            timer.add(clock() - c0)
        else:
            snap = row.run_quiet(task, inputs, k, n, dt, rows)
            ns = clock() - c0
            m = len(rows) // width
            timer.add_many(ns, m + 1)
            if m:
                run.add_rows(rows)
                rows.clear()
                k += m
        run.add(snap)
        last = snap
        if snap.state in ENDED and task.runs and at_rest(snap):
            return


def schedule_times(schedule: Schedule) -> list[float]:
    """The times at which the schedule's override or feed hold changes."""
    times = [t for t, _ in schedule.override]
    for t0, t1 in schedule.feed_hold:
        times.append(t0)
        times.append(t1)
    return times


def quiet_span(k: int, dt: float, limit: int, edges: list[float]) -> int:
    """How many cycles from k (t = k·dt) see the schedule's values of cycle k: those before
    the next step (with 1 ns to spare), at most BATCH and up to cycle `limit`; at least 1."""
    n = min(BATCH, limit - k + 1)
    i = bisect.bisect_right(edges, k * dt)
    if i < len(edges):
        before = edges[i] - 1e-9
        j = k + n - 1
        while j > k and j * dt >= before:
            j -= 1
        n = j - k + 1
    return n


def simulate_machine(
    channels: Sequence[tuple[ChannelParams, str]],
    schedules: Sequence[Schedule],
    m_ack_delay: float,
    traces: Sequence[TextIO | None],
    max_time: float = 3600.0,
    series: bool = True,
) -> list[SimResult]:
    """All channels in one GEO task (`Machine`), each with its program ("" : it idles), its
    own automatic PLC and schedule, and its trace; in channel order. Runs until every channel
    with a program has ended it (READY or ERROR) or max_time; a channel's trace and summary
    end with its program, so each channel's result is what it would be alone."""
    machine = Machine([ChannelProgram(ch, text) for ch, text in channels])
    order = sorted(range(len(channels)), key=lambda i: channels[i][0].channel_id)
    runs = [ChannelRun(channels[i][0], traces[i], series=series) for i in order]
    plcs = [SimPlc(m_ack_delay) for _ in order]
    sched = [schedules[i] for i in order]
    active = [bool(channels[i][1].strip()) for i in order]
    dt = machine.cycle_time
    limit = round(max_time / dt)
    clock = time.perf_counter_ns
    k = 0
    with collector_off():
        while k < limit and any(active):
            k += 1
            t = k * dt
            for i, run in enumerate(runs):  # one GEO cycle: every channel, in channel order
                inputs = plcs[i].inputs(run.last, t, sched[i])
                c0 = clock()
                snap = machine.step_channel(i, inputs, t)
                ns = clock() - c0
                if not active[i]:
                    continue
                run.timer.add(ns)
                run.add(snap)
                if snap.state in ENDED and machine.tasks[i].runs and at_rest(snap):
                    active[i] = False
    results = [run.result(task) for run, task in zip(runs, machine.tasks, strict=True)]
    back = [0] * len(order)
    for pos, i in enumerate(order):
        back[i] = pos
    return [results[back[i]] for i in range(len(channels))]


def plan_lifts(
    ch: ChannelParams, text: str, m_ack_delay: float, max_time: float
) -> dict[int, tuple[int, float, float]]:
    """What `liftd check` prints per lift range: the program run by the GEO core for at most
    `max_time` simulated seconds at 100 % override with the automatic PLC; per range (1-based,
    in the order they start) its LIFT_START line, the peak the lift reached (m) and the
    range's nominal path time (s). Ranges beyond `max_time` are missing."""
    task = GeoTask(ch, text)
    for _ in run_cycles(task, SimPlc(m_ack_delay), Schedule(), ch.cycle_time, max_time):
        pass
    return {i: (rec.range.start.line, rec.peak, rec.nominal_time)
            for i, rec in enumerate(task.lift.records, start=1)}  # fmt: skip


def build_summary(
    ch: ChannelParams,
    task: GeoTask,
    monitor: LimitMonitor,
    cycles: int,
    last: GeoSnapshot | None,
    errors: tuple[ErrorEntry, ...],
    step_cpu: StepCpu,
) -> SimSummary:
    """The run's summary (`last`: its last cycle). A lift range still open at the end of the
    run (the program stopped inside it) is listed last, as it was at the stop."""
    mon = task.z_monitor
    method = ch.lift_method
    duration = last.t if last is not None else 0.0
    lifts = [LiftSummary.closed(r, method) for r in task.lift.records]
    rec = task.lift.record
    if rec is not None:
        stops = [e.line for e in errors if e.stops_program]
        line = stops[0] if stops else last.line if last is not None else 0
        lifts.append(LiftSummary.at_stop(rec, method, duration, task.lift.z, line))
    return SimSummary(
        cycle_time_s=ch.cycle_time,
        duration_s=round(duration, 6),
        cycles=cycles,
        method=method.value,
        lifts=tuple(lifts),
        limits=Limits.of(
            ch, *monitor.result(), segments=monitor.segments(), transitions=monitor.transitions()
        ),
        z_overload=Overload(mon.warn_ratio, mon.err_ratio, mon.warning_cycles, mon.error_cycles),
        errors=errors,
        step_cpu_us=step_cpu,
    )
