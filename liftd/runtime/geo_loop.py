"""The GEO loop process: `GeoTask.step` once per cycle on absolute deadlines.

Started by the daemon's `GeoProcess` as `python -m liftd.runtime` (a clean interpreter that
loads the core and nothing of the daemon's: no numpy, pydantic, structlog). Per cycle, without
logging and without blocking: drain the PLC input ring (each write names its channel), step
every channel of the machine at t = k·dt (`Machine.step`, channel order), publish their
snapshots in one record through the seqlock (and the trace ring), put its events into the
shared block's event stream (no system call; dropped and counted when the daemon has not read
the last 64 KiB), update counters and the fixed-size compute and
lateness histograms. The timing policy is in cycle.py. A configuration sent by the daemon
(SIGHUP) takes effect in each channel at that channel's next program boundary. Memory is
locked once the programs are prepared and the heap trimmed (rt.lock_memory), so the lock
holds what the loop uses.

What one cycle does is bounded, whatever the PLC and the daemon send: it reads at most
INPUTS_PER_CYCLE PLC writes off the ring (levels written several times collapse to the last;
commands keep their order, at most BACKLOG of them wait per channel, the rest stays in the
ring, whose 256 records are the daemon's 0x708 BUSY when full), and it never decodes or plans
a program: what a START after a RESET, an error or a program end and what a reload need is
built by `Preparer` in the loop's idle time, the START held back until it is (preparer.py).
"""

from __future__ import annotations

import functools
import gc
import signal
import time
from typing import Final, cast

from liftd.cnc.geo_task import GeoTask
from liftd.cnc.machine import ChannelProgram, Machine
from liftd.cnc.runs import RunState
from liftd.cnc.snapshot import (
    ChannelState,
    Command,
    Event,
    GeoSnapshot,
    new_event,
    new_loop_stats,
)
from liftd.runtime import rt
from liftd.runtime.cycle import CycleClock, bucket
from liftd.runtime.loop_config import ChannelConfig, LoopConfig
from liftd.runtime.plc_inputs import PlcInputs
from liftd.runtime.preparer import Preparer
from liftd.runtime.records import INPUT_NAMES, pack_event, read_message, unpack_input
from liftd.runtime.shared import (
    COMPUTE_CPU_OVER,
    COMPUTE_OVER,
    COMPUTE_SHARE,
    COMPUTE_SUM_NS,
    CYCLES,
    EXCEEDED,
    LATENESS_SUM_NS,
    LOADING,
    REGRIDDED,
    RELOAD,
    RELOAD_TAKEN,
    STOP,
    Shared,
    SharedSpec,
)
from liftd.runtime.shm import ByteRing

OVERRUN_EVENT_EVERY_NS = 1_000_000_000  # at most one geo.overrun event per second
# geo.compute_over events: each names the cycle, its line and what the cycle did, so that a
# slow cycle of ours can be told from the machine's own stalls (bench_rt.py); a token bucket of
# COMPUTE_OVER_BURST events refilled at one per COMPUTE_OVER_EVENT_EVERY_NS
COMPUTE_OVER_EVENT_EVERY_NS = 100_000_000
COMPUTE_OVER_BURST = 10
PROGRAM_END: Final = "geo.program_end"  # the event of a program's end (a repeat starts it again)
RESET_DONE: Final = "geo.reset"  # a RESET completed: READY stands until the PLC starts
PROGRAM_START: Final = "geo.program_start"  # a START ran the program: a RESET's READY is over
# PLC writes read off the input ring in one cycle (~2 µs each with their event): 256 written at
# once (one sum write) cost a cycle ~0.5 ms before; now they take 16 cycles
INPUTS_PER_CYCLE: Final = 16
BACKLOG: Final = 8  # commands per channel waiting for the GEO task (it takes one a cycle)


class _Events:
    def __init__(self, ring: ByteRing) -> None:
        self.ring = ring

    def send(self, ev: Event, channel: int = 0) -> None:
        self.ring.put(pack_event(ev, channel))  # a full stream counts what it rejects (shared)


class GeoLoop:
    def __init__(self, shared: Shared, cfg: LoopConfig, events: _Events, control_fd: int):
        self.shared = shared
        self.cfg = cfg
        self.events = events
        self.control_fd = control_fd
        self.spin = False  # busy-wait between cycles (granted by rt.apply)
        self.machine = Machine(
            [ChannelProgram(c.channel, c.program_text, c.autostart) for c in cfg.channels]
        )
        if self.machine.channel_ids != tuple(c.channel.channel_id for c in cfg.channels):
            raise ValueError("LoopConfig.channels must be in channel order")
        for task, c in zip(self.machine.tasks, cfg.channels, strict=True):
            if c.repeat:
                task.prepare_next_run()  # now, not in the cycle of the first repeat
        self.current = list(cfg.channels)
        self.plcs = [PlcInputs(cfg.m_ack_auto, cfg.m_ack_delay_s) for _ in cfg.channels]
        # events of a machine of several channels say which channel they come from
        several = len(cfg.channels) > 1
        self.tags = [c.channel.channel_id if several else 0 for c in cfg.channels]
        self.pending: list[ChannelConfig | None] = [None] * len(cfg.channels)
        # the channel is READY because a RESET ended its job (or an NC error's ERROR, which
        # only a RESET leaves): nothing but the PLC's START moves it, no reload's `autostart`
        self.reset_ready = [False] * len(cfg.channels)
        self.pending_cfg = cfg
        self.reload_gen = 0
        # off the cycle (preparer.py): the job each channel waits for (a run for its next
        # START, or a reload's task), and the reload's task once built
        self.preparer = Preparer(round(cfg.cycle_time * 1e9))
        self.job_for: list[tuple[object, ...] | None] = [None] * len(cfg.channels)
        self.built: list[GeoTask | None] = [None] * len(cfg.channels)
        self.reading = False  # the daemon's configuration is being read off the pipe

    def read_inputs(self, t_next: float) -> bool:
        """Read at most INPUTS_PER_CYCLE PLC writes off the ring and stage them for the next
        cycle (t_next), each logged with it; stop early when a channel has BACKLOG commands
        waiting (the rest stays in the ring, in order). True if one changes what a channel
        gets. The ring is empty but when the PLC writes."""
        inputs, plcs, n = self.shared.inputs, self.plcs, len(self.plcs)
        changed = False
        for _ in range(INPUTS_PER_CYCLE):
            raw = inputs.get()
            if raw is None:
                break
            w = unpack_input(raw)
            if w.channel < n and plcs[w.channel].apply(w):
                changed = True
                ev = new_event(("geo.plc_input", t_next, 0, w.value, INPUT_NAMES[w.signal], 0))
                self.events.send(ev, self.tags[w.channel])
                if plcs[w.channel].backlog >= BACKLOG:
                    break
        return changed

    # -- preparation off the cycle ---------------------------------------------------------------
    def _prepare_run(self, i: int) -> bool:
        """Have the run a START of channel i would load built off the cycle; True while the
        START must wait for it (or for a reload's task). Only in READY: a START that resumes
        a HOLD loads nothing, and a reload waits for the program's end."""
        task = self.machine.tasks[i]
        if task.state is not ChannelState.READY:
            return False
        if self.job_for[i] is not None or self.pending[i] is not None:
            return True
        start = task.wants_run()
        if start is None:
            return False
        key: tuple[object, ...] = ("run", i, task)
        self.job_for[i] = key
        self.preparer.submit(key, functools.partial(task.build_run, start))
        return True

    def _take_results(self, t: float) -> bool:
        """What the preparer finished: a run for a START, the daemon's configuration, a
        reload's task. True if any (the cycle names it in a geo.compute_over event). A run
        is a geo.prepared event: how long its preparation took (ms), from where."""
        results = self.preparer.results()
        for key, result, took_ns in results:
            if isinstance(result, Exception):
                raise result  # a bug in the core, as it would have raised in the cycle
            kind = key[0]
            if kind == "message":
                self.reading = False
                self.reload_gen, cfg = cast(tuple[int, LoopConfig], result)
                self.pending_cfg = cfg
                self.pending = list(cfg.channels)
                self.built = [None] * len(cfg.channels)
                self.shared.words[RELOAD_TAKEN] = self.reload_gen
                self.shared.words[LOADING] += 1
                continue
            if kind == "reload":
                self.shared.words[LOADING] += 1  # (its submission was the first)
            i = cast(int, key[1])
            if self.job_for[i] is not key:
                continue  # superseded (a newer configuration)
            self.job_for[i] = None
            if kind == "run":
                if self.machine.tasks[i] is key[2]:
                    run = cast(RunState, result)
                    self.machine.tasks[i].offer_run(run)
                    where = " ".join(f"{1e3 * x:.3f}" for x in run.start)
                    self.events.send(Event("geo.prepared", t, run.prog.first_line,
                                           round(took_ns / 1e6, 3), f"run from {where} mm"),
                                     self.tags[i])  # fmt: skip
            elif key[2] is self.pending[i]:
                self.built[i] = cast(GeoTask, result)
        return bool(results)

    def _check_reload(self, snaps: list[GeoSnapshot]) -> bool:
        """Take a configuration the daemon sent, and apply it to each channel at its program
        boundary; True when this cycle did either. Reading it and building a channel's task
        are the preparer's (preparer.py): the swap is a few assignments."""
        words = self.shared.words
        took = False
        if words[RELOAD] != self.reload_gen and not self.reading:
            took = self.reading = True
            words[LOADING] += 1  # a large program takes a while to arrive
            # one message per reload, in order, read by the preparer's thread
            self.preparer.submit(("message",), functools.partial(read_message, self.control_fd))
        if self.pending_cfg is self.cfg:  # nothing waits for a program boundary (every cycle)
            return took
        for i, pending in enumerate(self.pending):
            snap = snaps[i]
            if pending is None or snap.state is not ChannelState.READY:
                continue
            # the channel's program boundary: its new lists and program take effect from
            # where its axes are; the other channels go on. Not in ERROR: an NC error is
            # cleared by the PLC's RESET only (as on the CNC), whose READY is the boundary.
            task = self.built[i]
            if task is None:
                job = self.job_for[i]
                if job is None or job[0] != "reload":
                    key: tuple[object, ...] = ("reload", i, pending)
                    self.job_for[i] = key
                    words[LOADING] += 1  # decoding and planning: tell the supervisor
                    self.preparer.submit(key, functools.partial(
                        build_task, pending, snap.positions))  # fmt: skip
                    took = True
                continue
            self.pending[i] = None
            self.built[i] = None
            took = True
            self.current[i] = pending
            self.machine.replace(i, task)
            common = self.pending_cfg
            plc = PlcInputs(common.m_ack_auto, common.m_ack_delay_s)
            plc.carry_over(self.plcs[i])  # the PLC's levels, and what this cycle read
            self.plcs[i] = plc
            self.events.send(Event("geo.reloaded", snap.t, 0, 0.0, pending.program_name),
                             self.tags[i])  # fmt: skip
            # autostart: as at start-up, unless a RESET made this READY: then the channel
            # stays READY, whatever it loaded, until the PLC starts it
            if pending.autostart and not self.reset_ready[i]:
                self.plcs[i].request(Command.START)
        if not any(self.pending):
            self.cfg = self.pending_cfg  # every channel has it
        return took

    def run(self) -> None:
        shared, cfg = self.shared, self.cfg
        words = shared.words
        period_ns = round(cfg.cycle_time * 1e9)
        quarter_ns = round(period_ns * COMPUTE_SHARE)
        dt = cfg.cycle_time
        codec = shared.codec
        publish = shared.snapshot.write
        trace = shared.trace
        comp_hist, late_hist = shared.compute_hist, shared.lateness_hist
        now_ns = time.perf_counter_ns
        cpu_ns = time.thread_time_ns  # a system call here (~0.5 µs), two a cycle
        clock = CycleClock(period_ns, now_ns() + period_ns, cfg.max_behind)
        k = exceeded = over = cpu_over = regridded = 0
        compute_ns = compute_max = late_max = compute_sum = late_sum = 0
        compute_cpu = compute_cpu_max = 0
        n = len(self.machine)
        channels = range(n)
        last: list[GeoSnapshot | None] = [None] * n
        last_overrun_event = -OVERRUN_EVENT_EVERY_NS
        staged = False  # a channel has PLC writes that take effect in the next cycle
        jobs_seen = 0  # the preparer's finished jobs taken
        over_tokens, over_refilled = COMPUTE_OVER_BURST, 0
        sleep_until = rt.spin_until if self.spin else rt.sleep_until
        tags, plcs, step = self.tags, self.plcs, self.machine.step
        send = self.events.send
        start = Command.START
        preparer = self.preparer
        while not words[STOP]:
            deadline = clock.deadline_ns
            if preparer.busy:  # its slice; and no spin: a spinning loop holds the GIL
                preparer.grant(deadline)
                if deadline > now_ns():
                    rt.sleep_until(deadline)
            elif deadline > now_ns():
                sleep_until(deadline)
            wake = now_ns()
            wake_cpu = cpu_ns()
            late = wake - deadline
            k += 1
            t = k * dt
            applied = staged  # what the last cycle read takes effect in this one
            if staged:
                staged = False
                for i in channels:
                    if plcs[i].staged:
                        plcs[i].take()
            prepared = preparer.running or preparer.jobs_done != jobs_seen
            if preparer.jobs_done != jobs_seen:
                jobs_seen = preparer.jobs_done
                self._take_results(t)
            read = self.read_inputs((k + 1) * dt)
            staged = staged or read
            inputs = [
                plcs[i].inputs(last[i], t, plcs[i].start_next(last[i]) and self._prepare_run(i))
                for i in channels
            ]
            # a START may decode and plan the program
            starting = any(inp.command is start for inp in inputs)
            if starting:
                words[LOADING] += 1
            step_start = now_ns()
            snaps = step(inputs, t)
            step_ns = now_ns() - step_start
            if starting:
                words[LOADING] += 1
            stats = new_loop_stats((k, exceeded, compute_ns / 1e3, compute_max / 1e3, late / 1e3,
                                    late_max / 1e3, over, compute_cpu_max / 1e3,
                                    cpu_over))  # fmt: skip
            record = codec.pack(snaps, stats)
            publish(record)
            if trace is not None:
                trace.put(record)
            ends: list[int] | None = None  # channels whose program ended in this cycle
            for i in channels:
                for ev in snaps[i].events:
                    send(ev, tags[i])
                    name = ev.name
                    if name == PROGRAM_END:  # not any way into READY: a RESET is not one
                        ends = [i] if ends is None else [*ends, i]
                    elif name == RESET_DONE:
                        self.reset_ready[i] = True
                        self._prepare_run(i)  # ahead of the PLC's START
                    elif name == PROGRAM_START:
                        self.reset_ready[i] = False
            reloaded = self._check_reload(snaps)
            if ends is not None:  # `repeat` as the configuration in effect now has it
                for i in ends:
                    if self.current[i].repeat:
                        plcs[i].request(start)
                    else:
                        self._prepare_run(i)  # ahead of a START that may come
            last = list(snaps)
            end_cpu = cpu_ns()
            end = now_ns()
            compute_ns = end - wake
            compute_cpu = end_cpu - wake_cpu
            compute_cpu_max = max(compute_cpu_max, compute_cpu)
            if compute_cpu > quarter_ns:
                cpu_over += 1
                words[COMPUTE_CPU_OVER] = cpu_over
            compute_max = max(compute_max, compute_ns)
            late_max = max(late_max, late)
            comp_hist[bucket(compute_ns)] += 1
            late_hist[bucket(late)] += 1
            compute_sum += compute_ns
            late_sum += late
            words[COMPUTE_SUM_NS] = compute_sum
            words[LATENESS_SUM_NS] = late_sum
            if compute_ns > quarter_ns:
                over += 1
                words[COMPUTE_OVER] = over
                gained = (end - over_refilled) // COMPUTE_OVER_EVENT_EVERY_NS
                if gained:
                    over_tokens = min(COMPUTE_OVER_BURST, over_tokens + gained)
                    over_refilled += gained * COMPUTE_OVER_EVENT_EVERY_NS
                if over_tokens:
                    over_tokens -= 1
                    did = cycle_kinds(snaps, applied, read, reloaded or prepared)
                    pre_us = (step_start - wake) // 1000  # the PLC inputs' drain, the inputs
                    what = (f"{did}; cpu {compute_cpu // 1000} µs; step {step_ns // 1000} µs; "
                            f"before {pre_us} µs")  # fmt: skip
                    send(Event("geo.compute_over", t, snaps[0].line, compute_ns / 1e3, what))
            if end > deadline + period_ns:
                exceeded += 1
                words[EXCEEDED] = exceeded
                if end - last_overrun_event >= OVERRUN_EVENT_EVERY_NS:
                    last_overrun_event = end
                    send(Event("geo.overrun", t, snaps[0].line, compute_ns / 1e3))
            words[CYCLES] = k
            skipped = clock.next_cycle(end)
            if skipped:
                regridded += skipped
                words[REGRIDDED] = regridded
                send(Event("geo.regrid", t, snaps[0].line, float(skipped)))


def build_task(pending: ChannelConfig, start: tuple[float, ...]) -> GeoTask:
    """A reloaded channel's task from where its axes are (in the preparer's thread)."""
    task = GeoTask(pending.channel, pending.program_text, autostart=False,
                   start_position=start)  # fmt: skip
    if pending.repeat:
        task.prepare_next_run()
    return task


def cycle_kinds(snaps: list[GeoSnapshot], applied: bool, read: bool, reloaded: bool) -> str:
    """What a cycle did, for its geo.compute_over event (whose text is this, then the cycle's
    compute on the thread's CPU clock and the wall time of its steps alone: a CPU time far
    below the wall time is a preemption, a step time far below it is time spent outside the
    steps, `before` of it before them: the PLC inputs; the rest after them: publishing the
    snapshot, the trace, the events, a reload): the names of its channels' events
    (lift.start, geo.program_start, …), `plc_input` when a PLC write took effect in it,
    `plc_read` when it read one (which takes effect in the next cycle),
    `reload` when it took a configuration (and may have decoded a program); "" for a cycle
    that did nothing but move (its own cost is a few µs: bench_step.py)."""
    names = sorted({ev.name for s in snaps for ev in s.events})
    if applied:
        names.append("plc_input")
    if read:
        names.append("plc_read")
    if reloaded:
        names.append("reload")
    return ",".join(names)


def main(control_fd: int, shm_fd: int) -> bool:
    """The GEO process (`python -m liftd.runtime`): read the configuration from the control
    pipe, map the shared block, prepare the task, then lock memory, take the RT settings and
    cycle until told to stop. True after a requested stop, False after a fault (reported as
    a geo.fault event)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is for the daemon; it stops the loop
    rt.die_with_parent()
    try:
        spec, cfg = read_message(control_fd)
    except EOFError:  # the daemon died before it sent the configuration
        return False
    assert isinstance(spec, SharedSpec) and isinstance(cfg, LoopConfig)
    shared = Shared.attach(spec, shm_fd)
    events = _Events(shared.events)
    ok = True
    state: rt.RtState | None = None
    loop: GeoLoop | None = None
    try:
        loop = GeoLoop(shared, cfg, events, control_fd)
        gc.collect()
        state = rt.apply(cfg.rt)  # after preparing: mlockall locks what the loop really uses
        loop.preparer.follow_affinity()
        loop.spin = state.spin
        for r in state.results:
            text = f"{r.setting}: {'ok' if r.ok else 'not permitted'} ({r.detail})"
            events.send(Event("geo.rt_setting", 0.0, 0, 1.0 if r.ok else 0.0, text))
        gc.freeze()  # nothing allocated so far is ever collected: no GC pauses in the cycle
        gc.disable()
        loop.run()
    except Exception as exc:  # a bug in the core: report it, stop serving (the daemon exits)
        events.send(Event("geo.fault", 0.0, 0, 0.0, f"{type(exc).__name__}: {exc}"))
        ok = False
    finally:
        if loop is not None:
            loop.preparer.close()
        if state is not None:
            state.close()
        shared.close()
    return ok
