"""The GEO loop process: `GeoTask.step` once per cycle on absolute deadlines.

Started by the daemon with the spawn method (a clean interpreter). Per cycle, without logging
and without blocking: drain the PLC input ring, step the GEO task at t = k·dt, publish the
snapshot through the seqlock (and the trace ring), write its events to the event pipe
(non-blocking; dropped and counted when full), update counters and the fixed-size compute and
lateness histograms. The timing policy is in cycle.py. A configuration sent by the daemon
(SIGHUP) takes effect at the next program boundary.
"""

from __future__ import annotations

import gc
import os
import sys
import time
from dataclasses import dataclass, field
from multiprocessing.connection import Connection

from liftd.cnc.geo_task import GeoTask
from liftd.cnc.params import ChannelParams
from liftd.cnc.snapshot import ChannelState, Command, Event, GeoSnapshot, LoopStats
from liftd.runtime import rt
from liftd.runtime.cycle import CycleClock, bucket
from liftd.runtime.plc_inputs import PlcInputs
from liftd.runtime.records import pack_event, unpack_input
from liftd.runtime.shared import Shared, SharedSpec

EXIT_FAULT = 3
OVERRUN_EVENT_EVERY_NS = 1_000_000_000  # at most one geo.overrun event per second


@dataclass(frozen=True, slots=True)
class LoopConfig:
    """Everything the loop needs; plain picklable data (no pydantic, no files)."""

    channel: ChannelParams
    program_text: str
    program_name: str
    autostart: bool = True
    repeat: bool = False
    m_ack_auto: bool = True
    m_ack_delay_s: float = 0.02
    rt: rt.RtRequest = field(default_factory=rt.RtRequest)
    max_behind: int = 100


class _Events:
    def __init__(self, conn: Connection) -> None:
        self.fd = conn.fileno()
        os.set_blocking(self.fd, False)
        self.dropped = 0

    def send(self, ev: Event) -> None:
        try:
            os.write(self.fd, pack_event(ev))
        except (BlockingIOError, BrokenPipeError):
            self.dropped += 1


class GeoLoop:
    def __init__(self, shared: Shared, cfg: LoopConfig, events: _Events, control: Connection):
        self.shared = shared
        self.cfg = cfg
        self.events = events
        self.control = control
        self.task = GeoTask(cfg.channel, cfg.program_text, autostart=cfg.autostart)
        if cfg.repeat:
            self.task.prepare_next_run()  # now, not in the cycle of the first repeat
        self.plc = PlcInputs(cfg.m_ack_auto, cfg.m_ack_delay_s)
        self.pending: LoopConfig | None = None
        self.reload_gen = 0

    def _check_reload(self, snap: GeoSnapshot) -> None:
        if self.shared.get("reload") != self.reload_gen and self.control.poll():
            self.shared.set("loading", 1)  # a large program takes a while to arrive
            self.reload_gen, self.pending = self.control.recv()  # once per SIGHUP, in order
            self.shared.set("loading", 0)
        pending = self.pending
        if pending is None or snap.state not in (ChannelState.READY, ChannelState.ERROR):
            return
        # the program boundary: the new lists and program take effect from where the axes are
        self.cfg, self.pending = pending, None
        self.shared.set("loading", 1)  # decoding and planning: tell the supervisor it works
        self.task = GeoTask(pending.channel, pending.program_text, autostart=False,
                            start_position=snap.positions)  # fmt: skip
        if pending.repeat:
            self.task.prepare_next_run()
        self.shared.set("loading", 0)
        self.plc = PlcInputs(pending.m_ack_auto, pending.m_ack_delay_s)
        self.shared.set("reloads", self.shared.get("reloads") + 1)
        self.events.send(Event("geo.reloaded", snap.t, 0, 0.0, pending.program_name))
        if pending.autostart:
            self.plc.request(Command.START)

    def run(self) -> int:
        shared, cfg = self.shared, self.cfg
        period_ns = round(cfg.channel.cycle_time * 1e9)
        dt = cfg.channel.cycle_time
        codec = shared.codec
        publish = shared.snapshot.write
        trace = shared.trace
        comp_hist, late_hist = shared.compute_hist, shared.lateness_hist
        now_ns = time.perf_counter_ns
        clock = CycleClock(period_ns, now_ns() + period_ns, cfg.max_behind)
        k = exceeded = regridded = 0
        compute_ns = compute_max = late_max = 0
        last: GeoSnapshot | None = None
        last_overrun_event = -OVERRUN_EVENT_EVERY_NS
        sleep_until = rt.sleep_until
        while not shared.get("stop"):
            deadline = clock.deadline_ns
            if deadline > now_ns():
                sleep_until(deadline)
            wake = now_ns()
            late = wake - deadline
            k += 1
            t = k * dt
            while (raw := shared.inputs.get()) is not None:  # rare: only when the PLC writes
                w = unpack_input(raw)
                if self.plc.apply(w):  # logged with the cycle it takes effect in
                    self.events.send(Event("geo.plc_input", t, 0, w.value, w.signal.name.lower()))
            inputs = self.plc.inputs(last, t)
            starting = inputs.command is Command.START  # may decode and plan the program
            if starting:
                shared.set("loading", 1)
            snap = self.task.step(inputs, t)
            if starting:
                shared.set("loading", 0)
            stats = LoopStats(k, exceeded, compute_ns / 1e3, compute_max / 1e3, late / 1e3,
                              late_max / 1e3)  # fmt: skip
            record = codec.pack(snap, stats)
            publish(record)
            if trace is not None:
                trace.put(record)
            for ev in snap.events:
                self.events.send(ev)
            if (self.cfg.repeat and snap.state is ChannelState.READY and self.task.runs
                    and (last is None or last.state is not ChannelState.READY)):  # fmt: skip
                self.plc.request(Command.START)
            self._check_reload(snap)
            last = snap
            end = now_ns()
            compute_ns = end - wake
            compute_max = max(compute_max, compute_ns)
            late_max = max(late_max, late)
            comp_hist[bucket(compute_ns)] += 1
            late_hist[bucket(late)] += 1
            if end > deadline + period_ns:
                exceeded += 1
                shared.set("exceeded", exceeded)
                if end - last_overrun_event >= OVERRUN_EVENT_EVERY_NS:
                    last_overrun_event = end
                    self.events.send(Event("geo.overrun", t, snap.line, compute_ns / 1e3))
            shared.set("cycles", k)
            skipped = clock.next_cycle(end)
            if skipped:
                regridded += skipped
                shared.set("regridded", regridded)
                self.events.send(Event("geo.regrid", t, snap.line, float(skipped)))
            if self.events.dropped:
                shared.set("events_dropped", self.events.dropped)
        return 0


def main(spec: SharedSpec, cfg: LoopConfig, events_conn: Connection, control: Connection) -> None:
    """Entry point of the GEO process (multiprocessing spawn target)."""
    shared = Shared.attach(spec)
    events = _Events(events_conn)
    state = rt.apply(cfg.rt)
    for r in state.results:
        text = f"{r.setting}: {'ok' if r.ok else 'not permitted'} ({r.detail})"
        events.send(Event("geo.rt_setting", 0.0, 0, 1.0 if r.ok else 0.0, text))
    code = 0
    try:
        loop = GeoLoop(shared, cfg, events, control)
        gc.collect()
        gc.freeze()  # nothing allocated so far is ever collected: no GC pauses in the cycle
        gc.disable()
        shared.set("ready", 1)
        code = loop.run()
    except Exception as exc:  # a bug in the core: report it, stop serving (the daemon exits)
        events.send(Event("geo.fault", 0.0, 0, 0.0, f"{type(exc).__name__}: {exc}"))
        code = EXIT_FAULT
    finally:
        state.close()
        shared.close()  # the daemon owns and unlinks the block
    sys.exit(code)
