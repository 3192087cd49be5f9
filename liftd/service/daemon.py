"""`liftd run`: the composition root. The daemon process runs asyncio (ADS server, logs,
sd_notify, metrics, trace writer thread) and supervises the GEO loop process.

Lifecycle (rt-python.md §5, style-anchors rule 9): spawn the GEO process → wait until it
cycles → listen → READY=1. WATCHDOG=1 only while the GEO cycle counter advances. SIGTERM/SIGINT:
STOPPING=1, close the listener and connections, stop the loop at a cycle boundary, join it,
exit 0. SIGHUP: reload liftd.toml and the lists; a valid configuration goes to the loop and takes
effect at the next program boundary, an invalid one is logged and the running one kept. If the
GEO process dies, ADS reports ERROR (reads 0x707) and the daemon exits 3 for systemd to restart.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import multiprocessing
import os
import signal
import time
from pathlib import Path
from typing import Any, TextIO

import structlog

from liftd.ads.constants import AdsErr, AdsState
from liftd.ads.errors import AdsError
from liftd.ads.server import AdsServer
from liftd.ads.service import AdsService, DeviceInfo
from liftd.cnc.nc import DecoderContext, Severity, decode
from liftd.cnc.snapshot import PlcWrite
from liftd.objects.catalog import AdsStats, Catalog, GeoView
from liftd.objects.provider import CncProvider
from liftd.runtime import geo_loop
from liftd.runtime.cycle import percentile_us
from liftd.runtime.records import EventReader, pack_input
from liftd.runtime.rt import RtRequest
from liftd.runtime.shared import Shared
from liftd.service import systemd
from liftd.service.adsconfig import server_config, service_limits
from liftd.service.trace_recorder import TraceRecorder
from liftd.settings import ConfigError, Settings, load_settings
from liftd.settings.programs import program_channel

EXIT_OK, EXIT_CONFIG, EXIT_RUNTIME = 0, 2, 3
READY_CYCLES = 10
START_TIMEOUT_S = 20.0
STOP_JOIN_S = 1.5
LOAD_TIMEOUT_S = 60.0  # a cycle that decodes and plans a program (START, reload) may take this
TRACE_CAPACITY_S = 10.0  # trace ring: this many seconds of cycles
QUIET_EVENTS = {"lift.override_limited": 1.0, "geo.m_output": 0.0, "geo.m_ack": 0.0}


class StartError(Exception):
    """The daemon cannot start (occupied port, unwritable trace, GEO process failed)."""


def loop_config(settings: Settings, program: Path | None) -> geo_loop.LoopConfig:
    cfg = settings.config
    text = program.read_text(encoding="utf-8", errors="replace") if program else "M30\n"
    rt = cfg.rt
    return geo_loop.LoopConfig(
        channel=program_channel(settings, program, text),  # with its subroutine files
        program_text=text,
        program_name=str(program) if program else "(none)",
        autostart=cfg.program.autostart,
        repeat=cfg.program.repeat,
        m_ack_auto=cfg.plc.m_ack == "auto",
        m_ack_delay_s=cfg.plc.m_ack_delay_ms * 1e-3,
        rt=RtRequest(**rt.model_dump(exclude={"stall_timeout_ms"})),
    )


class Daemon:
    def __init__(
        self, settings: Settings, config_arg: str | None, program_arg: str | None,
        trace_path: str | None, duration_s: float | None = None,
    ) -> None:  # fmt: skip
        self.settings = settings
        self.duration_s = duration_s
        self.config_arg = config_arg
        self.program_arg = program_arg
        self.trace_path = trace_path
        self.log = structlog.get_logger("liftd")
        self.stopping = asyncio.Event()
        self.exit_code = EXIT_OK
        cycle = settings.channel.cycle_time
        capacity = round(TRACE_CAPACITY_S / cycle) if trace_path else 0
        self.shared = Shared(len(settings.channel.axes), capacity)
        self.catalog = Catalog(settings.channel)
        self.provider = CncProvider(self.catalog, self._view, self._submit)
        self.service = AdsService(self.provider, service_limits(settings.config.ads),
                                  DeviceInfo())  # fmt: skip
        self.server = AdsServer(server_config(settings.config.ads), self.service,
                                self.log.bind(part="ads"))  # fmt: skip
        self.proc: Any = None
        self.alive = False
        self._cache: tuple[int, GeoView | None] = (-1, None)
        self.reload_gen = 0
        self._reload_lock = asyncio.Lock()
        self._control: Any = None
        self._events_conn: Any = None
        self._event_reader = EventReader()
        self._event_times: dict[str, float] = {}
        self._trace: TraceRecorder | None = None
        self._metrics: asyncio.Server | None = None
        self._rss_mb: tuple[float | None, float | None] = (None, None)

    # -- what the ADS provider sees -------------------------------------------------------------
    def _view(self) -> GeoView | None:
        if not self.alive:
            return None
        seq = self.shared.snapshot.sequence
        if seq == self._cache[0]:
            return self._cache[1]
        snap, stats = self.shared.codec.unpack(self.shared.snapshot.read())
        c = self.server.counters
        ads = AdsStats(len(self.server.connections), c.requests,
                       c.closed_for_errors + c.internal_errors, c.notifications_sent)  # fmt: skip
        view = GeoView(snap, stats, ads)
        self._cache = (seq, view)
        return view

    def _submit(self, w: PlcWrite) -> None:
        if not self.shared.inputs.put(pack_input(w)):
            raise AdsError(AdsErr.BUSY, "the GEO input queue is full")

    # -- start ------------------------------------------------------------------------------------
    async def run(self) -> int:
        loop = asyncio.get_running_loop()
        t0 = time.monotonic()
        trace_file = self._open_trace()
        program = Path(self.program_arg) if self.program_arg else self.settings.program
        self._report_program(program)
        ctx = multiprocessing.get_context("spawn")
        events_r, events_w = ctx.Pipe(duplex=False)
        control_r, control_w = ctx.Pipe(duplex=False)
        self._control, self._events_conn = control_w, events_r
        self.proc = ctx.Process(
            target=geo_loop.main,
            args=(self.shared.spec, loop_config(self.settings, program), events_w, control_r),
            name="liftd-geo",
        )
        self.proc.start()
        events_w.close()
        control_r.close()
        os.set_blocking(events_r.fileno(), False)
        loop.add_reader(events_r.fileno(), self._on_events)
        loop.add_reader(self.proc.sentinel, self._on_geo_exit)
        for sig in (signal.SIGTERM, signal.SIGINT):
            loop.add_signal_handler(sig, self.stopping.set)
        loop.add_signal_handler(signal.SIGHUP, lambda: asyncio.ensure_future(self.reload()))
        try:
            await self._wait_cycling()
            self.alive = True
            await self._listen()
            if trace_file is not None:
                ring = self.shared.trace
                assert ring is not None
                self._trace = TraceRecorder(trace_file, ring, self.shared.codec,
                                            self.settings.channel.axis_names, self.log)  # fmt: skip
                self._trace.start()
            await self._start_metrics()
        except StartError as exc:
            self.log.error("daemon.start_failed", reason=str(exc))
            await self.shutdown()
            return EXIT_RUNTIME
        ads = self.settings.config.ads
        systemd.notify(
            f"READY=1\nSTATUS=GEO cycling, ADS on {ads.host}:{self.server.port} port "
            f"{','.join(map(str, ads.ams_ports))}"
        )
        self.log.info("daemon.ready", seconds=round(time.monotonic() - t0, 3),
                      ads_port=self.server.port, net_id=ads.net_id)  # fmt: skip
        watchdog = asyncio.create_task(self._watchdog())
        supervisor = asyncio.create_task(self._supervise())
        with contextlib.suppress(TimeoutError):
            await asyncio.wait_for(self.stopping.wait(), self.duration_s)
        watchdog.cancel()
        supervisor.cancel()
        await self.shutdown()
        return self.exit_code

    def _open_trace(self) -> TextIO | None:
        if not self.trace_path:
            return None
        try:
            return open(self.trace_path, "w", encoding="utf-8", newline="")
        except OSError as exc:
            raise StartError(f"{self.trace_path}: cannot write the trace: {exc.strerror}") from None

    def _report_program(self, program: Path | None) -> None:
        if program is None:
            self.log.warning("daemon.no_program", detail="no [program] file: the channel idles")
            return
        text = program.read_text(encoding="utf-8", errors="replace")
        ch = program_channel(self.settings, program, text)
        result = decode(text, DecoderContext.from_channel(ch, tuple(0.0 for _ in ch.axes)))
        for err in result.errors:
            level = "warning" if err.severity is Severity.WARNING else "error"
            getattr(self.log, level)("nc.problem", file=err.file or str(program), line=err.line,
                                     id=err.id, message=err.message)  # fmt: skip
        self.log.info("daemon.program", file=str(program), blocks=len(result.blocks))

    async def _wait_cycling(self) -> None:
        end = time.monotonic() + START_TIMEOUT_S
        while self.shared.get("cycles") < READY_CYCLES:
            if not self.proc.is_alive():
                raise StartError(f"the GEO process exited with {self.proc.exitcode}")
            if time.monotonic() > end:
                raise StartError("the GEO process did not start cycling")
            await asyncio.sleep(0.005)

    async def _listen(self) -> None:
        try:
            await self.server.start()
        except OSError as exc:
            ads = self.settings.config.ads
            raise StartError(f"cannot listen on {ads.host}:{ads.port}: {exc.strerror}") from None

    # -- supervision ------------------------------------------------------------------------------
    def _on_events(self) -> None:
        fd = self._events_conn.fileno()
        try:
            data = os.read(fd, 65536)
        except BlockingIOError:
            return
        except OSError:
            data = b""
        if not data:  # the GEO process closed its end
            asyncio.get_running_loop().remove_reader(fd)
            return
        for ev in self._event_reader.feed(data):
            min_gap = QUIET_EVENTS.get(ev.name)
            now = time.monotonic()
            if min_gap is not None:
                if min_gap == 0.0 or now - self._event_times.get(ev.name, -1e9) < min_gap:
                    continue
                self._event_times[ev.name] = now
            level = "error" if ev.name in ("geo.error", "geo.fault") else "info"
            if ev.name in ("geo.overrun", "geo.regrid", "lift.z_acc_error") or (
                ev.name == "geo.rt_setting" and not ev.value
            ):
                level = "warning"
            value = float(f"{ev.value:.9g}")  # no float noise in the log
            getattr(self.log, level)(ev.name, t=round(ev.t, 6), line=ev.line, value=value,
                                     text=ev.text or None)  # fmt: skip

    def _on_geo_exit(self) -> None:
        loop = asyncio.get_running_loop()
        loop.remove_reader(self.proc.sentinel)
        if self.stopping.is_set():
            return
        self.alive = False
        self.provider.down_state = AdsState.ERROR
        self.log.error("geo.process_died", exitcode=self.proc.exitcode,
                       detail="ADS now reports ERROR; exiting for a restart")  # fmt: skip
        self.exit_code = EXIT_RUNTIME
        self.stopping.set()

    async def _supervise(self) -> None:
        """A GEO loop that lives but no longer cycles serves stale data: stop serving, exit 3."""
        timeout = self.settings.config.rt.stall_timeout_ms * 1e-3
        last, since = self.shared.get("cycles"), time.monotonic()
        while not self.stopping.is_set():
            await asyncio.sleep(min(0.05, timeout / 4))
            cycles = self.shared.get("cycles")
            now = time.monotonic()
            limit = LOAD_TIMEOUT_S if self.shared.get("loading") else timeout
            if cycles != last:
                last, since = cycles, now
            elif now - since > limit and self.alive:
                self.alive = False
                self.provider.down_state = AdsState.ERROR
                self.log.error("geo.stalled", cycles=cycles, seconds=round(now - since, 3),
                               detail="ADS now reports ERROR; exiting for a restart")  # fmt: skip
                self.exit_code = EXIT_RUNTIME
                self.proc.kill()  # hung: there is no cycle boundary to wait for
                self.stopping.set()

    async def _watchdog(self) -> None:
        interval = systemd.watchdog_interval_s()
        if interval is None:
            return
        last = -1
        while True:
            cycles = self.shared.get("cycles")
            # only while the control loop really runs (or prepares a program at a START)
            if (cycles != last or self.shared.get("loading")) and self.alive:
                systemd.notify("WATCHDOG=1")
                last = cycles
            await asyncio.sleep(interval)

    # -- SIGHUP ------------------------------------------------------------------------------------
    async def reload(self) -> None:
        loop = asyncio.get_running_loop()
        try:
            new = await loop.run_in_executor(None, load_settings, self.config_arg, self.program_arg)
        except ConfigError as exc:
            self.log.error("config.reload_rejected", problems=[str(p) for p in exc.problems],
                           detail="the running configuration is kept")  # fmt: skip
            return
        old = self.settings
        if len(new.channel.axes) != len(old.channel.axes) or (
            new.channel.cycle_time != old.channel.cycle_time
        ):
            self.log.error("config.reload_rejected", detail="axes or cycle time changed: restart")
            return
        program = Path(self.program_arg) if self.program_arg else new.program
        try:
            cfg = loop_config(new, program)
        except OSError as exc:
            self.log.error("config.reload_rejected", detail=f"program: {exc.strerror}")
            return
        restart_keys = [k for k in ("host", "port", "net_id", "extra_net_ids", "ams_ports")
                        if getattr(new.config.ads, k) != getattr(old.config.ads, k)]  # fmt: skip
        if restart_keys:
            self.log.warning("config.reload_partial", needs_restart=restart_keys)
        fresh = server_config(new.config.ads)
        self.server.config = dataclasses.replace(
            self.server.config, allow_ips=fresh.allow_ips, allow_net_ids=fresh.allow_net_ids,
            write_net_ids=fresh.write_net_ids, reject=fresh.reject,
        )  # fmt: skip
        async with self._reload_lock:  # one message at a time, in generation order
            self.reload_gen += 1
            self.shared.set("reload", self.reload_gen)  # the loop reads the pipe from now on
            # a program above the pipe buffer (64 KiB) blocks the send until the loop reads it:
            # off the event loop (a dead GEO process breaks the pipe and ends the send)
            try:
                await loop.run_in_executor(None, self._control.send, (self.reload_gen, cfg))
            except OSError as exc:
                self.log.error("config.reload_rejected", detail=f"GEO process: {exc}")
                return
        self.settings = new
        self.log.info("config.reload_accepted", files=list(new.files),
                      detail="takes effect at the next program boundary")  # fmt: skip

    # -- trace ------------------------------------------------------------------------------------
    # -- metrics ----------------------------------------------------------------------------------
    async def _start_metrics(self) -> None:
        m = self.settings.config.metrics
        if not m.prometheus_port:
            return
        from liftd.service.metrics import serve  # noqa: PLC0415

        try:
            self._metrics = await serve(m.prometheus_host, m.prometheus_port, self)
        except OSError as exc:
            raise StartError(
                f"cannot listen on {m.prometheus_host}:{m.prometheus_port}: {exc.strerror}"
            ) from None

    # -- stop -------------------------------------------------------------------------------------
    async def shutdown(self) -> None:
        t0 = time.monotonic()
        systemd.notify("STOPPING=1")
        self.stopping.set()
        await self.server.close()
        if self._metrics is not None:
            self._metrics.close()
        self._rss_mb = (rss_mb(os.getpid()), rss_mb(self.proc.pid) if self.proc else None)
        self.shared.set("stop", 1)
        if self.proc is not None and self.proc.is_alive():
            loop = asyncio.get_running_loop()
            await loop.run_in_executor(None, self.proc.join, STOP_JOIN_S)
            if self.proc.is_alive():
                self.log.warning("geo.killed", detail="did not stop at a cycle boundary in time")
                self.proc.kill()
                await loop.run_in_executor(None, self.proc.join, 1.0)
        self.alive = False
        if self._trace is not None:
            self._trace.stop()
        self._log_summary(time.monotonic() - t0)
        self.shared.close()

    def _log_summary(self, stop_s: float) -> None:
        sh = self.shared
        comp, late = list(sh.compute_hist), list(sh.lateness_hist)
        cycles = sh.get("cycles")
        self.log.info(
            "daemon.stopped",
            cycles=cycles,
            exceeded=sh.get("exceeded"),
            exceed_rate=round(sh.get("exceeded") / cycles, 6) if cycles else 0.0,
            regridded=sh.get("regridded"),
            lateness_us={q: percentile_us(late, q) for q in (0.5, 0.99, 0.999)},
            compute_us={q: percentile_us(comp, q) for q in (0.5, 0.99, 0.999)},
            events_dropped=sh.get("events_dropped"),
            stop_seconds=round(stop_s, 3),
            rss_mb=self._rss_mb[0],
            geo_rss_mb=self._rss_mb[1],
        )


def rss_mb(pid: int) -> float | None:
    """Resident set size of a process in MiB (Linux /proc), None where unavailable."""
    try:
        with open(f"/proc/{pid}/status", encoding="ascii") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return round(int(line.split()[1]) / 1024, 1)
    except OSError:
        return None
    return None


def run(settings: Settings, config_arg: str | None, program_arg: str | None,
        trace_path: str | None, duration_s: float | None = None) -> int:  # fmt: skip
    """Run the daemon until SIGTERM/SIGINT (or for duration_s); the exit code for the CLI."""
    import uvloop  # noqa: PLC0415  # the ADS server's loop (measured: pyproject.toml)

    try:
        daemon = Daemon(settings, config_arg, program_arg, trace_path, duration_s)
    except OSError as exc:
        structlog.get_logger("liftd").error("daemon.start_failed", reason=str(exc))
        return EXIT_RUNTIME
    try:
        return uvloop.run(daemon.run())
    except StartError as exc:
        structlog.get_logger("liftd").error("daemon.start_failed", reason=str(exc))
        daemon.shared.close()
        return EXIT_RUNTIME
