"""`liftd run`: the composition root. Builds the parts from the settings, starts them in
dependency order and stops them in reverse (rt-python.md §5, style-anchors rule 9).

The daemon process runs asyncio: the ADS server, logs, sd_notify, metrics, the reload control
socket and the trace writer thread. The GEO loop runs in its own process behind `GeoProcess`
(runtime/geo_process.py), which starts, supervises, reloads and stops it.

Lifecycle: the GEO process → wait until it cycles → listen → READY=1; WATCHDOG=1 only while
the GEO cycle counter advances. SIGTERM/SIGINT: STOPPING=1, close the listener and
connections, stop the loop at a cycle boundary, log the summary. SIGHUP (or `liftd reload` on
the control socket): RELOADING=1, reload liftd.toml and the lists; a valid configuration goes
to the loop and takes effect at the next program boundary, an invalid one is rejected and the
running one kept; then READY=1. If the GEO process dies or stalls, ADS reports ERROR (reads
0x707) and `run` returns False, which the CLI maps to its exit code for systemd to restart.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import os
import signal
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, TextIO

import structlog

from liftd.ads.constants import AdsErr, AdsState
from liftd.ads.errors import AdsError
from liftd.ads.server import AdsServer
from liftd.ads.service import AdsService, DeviceInfo
from liftd.ads.udp import UdpDiscovery
from liftd.cnc.snapshot import PlcWrite
from liftd.objects.catalog import AdsStats, Catalog, GeoView
from liftd.objects.provider import CncProvider
from liftd.runtime.core import core_build
from liftd.runtime.geo_process import GeoFailure, GeoGone, GeoProcess, GeoStartError, rss_mb
from liftd.runtime.loop_config import LoopConfig
from liftd.runtime.records import pack_input
from liftd.runtime.rt import keep_off_cpu
from liftd.runtime.shared import Shared
from liftd.service import control, logs, systemd
from liftd.service.adsconfig import server_config, service_limits
from liftd.service.control import Verdict
from liftd.service.geo_log import GeoEventLog
from liftd.service.loop_settings import (
    log_programs,
    loop_config,
    needs_restart,
    shape,
    trace_names,
)
from liftd.settings import ConfigError, Settings, load_settings
from liftd.settings.load import program_problem

if TYPE_CHECKING:
    from liftd.cnc.snapshot import Event
    from liftd.service.metrics import Sample
    from liftd.service.trace_recorder import TraceRecorder
    from liftd.service.ui_host import UiHost

TRACE_CAPACITY_S = 10.0  # trace ring: this many seconds of cycles


class StartError(Exception):
    """The daemon cannot start (occupied port, unwritable trace, GEO process failed)."""


class Daemon:
    def __init__(
        self, settings: Settings, config_arg: str | None, program_arg: str | None,
        trace_path: str | None, duration_s: float | None = None,
    ) -> None:  # fmt: skip
        self.settings = settings
        self.started = settings  # what the listener, the loop's RT settings and logs run with
        self.duration_s = duration_s
        self.config_arg = config_arg
        self.program_arg = program_arg
        self.trace_path = trace_path
        self.log = structlog.get_logger("liftd")
        self.stopping = asyncio.Event()
        cycle = settings.channel.cycle_time
        capacity = round(TRACE_CAPACITY_S / cycle) if trace_path else 0
        self.shared = Shared([len(c.params.axes) for c in settings.machine], capacity)
        try:
            self.catalog = Catalog([c.params for c in settings.machine])
            self.provider = CncProvider(self.catalog, self._view, self._submit)
            self.service = AdsService(self.provider, service_limits(settings.config.ads),
                                      DeviceInfo())  # fmt: skip
            self.server = AdsServer(server_config(settings.config.ads), self.service,
                                    self.log.bind(part="ads"))  # fmt: skip
            self.ui = self._ui(settings)
            events: Callable[[Event], None] = GeoEventLog(self.log)
            if self.ui is not None:
                events = _tee(events, self.ui.on_event)
            self.geo = GeoProcess(self.shared, events,
                                  settings.config.rt.stall_timeout_ms * 1e-3)  # fmt: skip
        except BaseException:
            self.shared.close()
            raise
        self._view_cache: tuple[int, GeoView | None] = (-1, None)
        self._reload_lock = asyncio.Lock()
        self._trace: TraceRecorder | None = None
        self._servers: list[asyncio.Server] = []
        self.udp: UdpDiscovery | None = None
        self._control_path: Path | None = None
        self._control_inode = 0  # the socket file it bound (removed at stop only if still it)

    def _ui(self, settings: Settings) -> UiHost | None:
        """The live view (`[ui] enabled`): aiohttp only when asked for."""
        if not settings.config.ui.enabled:
            return None
        from liftd.service.ui_host import UiHost  # noqa: PLC0415

        return UiHost(settings, self.catalog, self.provider, self.server, self._view,
                      self.log.bind(part="ui"))  # fmt: skip

    # -- what the ADS provider sees -------------------------------------------------------------
    def _view(self) -> GeoView | None:
        """The provider's source: the last published cycle (unpacked once per cycle) with the
        ADS server's counters; None while the GEO process does not serve."""
        if not self.geo.alive:
            return None
        seq = self.shared.snapshot.sequence
        if seq != self._view_cache[0]:
            snaps, stats = self.shared.codec.unpack(self.shared.snapshot.read())
            self._view_cache = (seq, GeoView(snaps[0], stats, self._ads_stats(), snaps))
        return self._view_cache[1]

    def _ads_stats(self) -> AdsStats:
        c = self.server.counters
        return AdsStats(len(self.server.connections), c.requests,
                        c.closed_for_errors + c.internal_errors, c.notifications_sent,
                        logs.dropped())  # fmt: skip

    def _submit(self, w: PlcWrite) -> None:
        if not self.shared.inputs.put(pack_input(w)):
            raise AdsError(AdsErr.BUSY, "the GEO input queue is full")

    # -- run --------------------------------------------------------------------------------------
    async def run(self) -> bool:
        """Serve until SIGTERM/SIGINT or the duration; False when the daemon could not start or
        the GEO process failed."""
        try:
            return await self._run()
        finally:
            self.shared.close()

    async def _run(self) -> bool:
        t0 = time.monotonic()
        try:
            trace_file = self._open_trace()
            cfg = self._loop_config(self.settings)
            self._install_signals()
            await self.geo.start(cfg)
            self._keep_off_geo_cpu()
            await self._listen()
            await self._start_ui(cfg)
            self._start_trace(trace_file)
            await self._start_metrics()
            await self._start_control()
        except (StartError, GeoStartError) as exc:
            self.log.error("daemon.start_failed", reason=str(exc))
            await self.shutdown()
            return False
        ads = self.settings.config.ads
        systemd.notify(
            f"READY=1\nSTATUS=GEO cycling, ADS on {ads.host}:{self.server.port} port "
            f"{','.join(map(str, ads.ams_ports))}"
        )
        core = core_build()
        ui = {"ui": self.ui.url} if self.ui is not None else {}
        self.log.info("daemon.ready", seconds=round(time.monotonic() - t0, 3),
                      ads_port=self.server.port, net_id=ads.net_id, core=core, **ui)  # fmt: skip
        if core == "stale":
            self.log.warning("geo.core_stale", hint="a compiled module is older than its "
                             "source, which does not run until `make core`")  # fmt: skip
        failure = await self._serve()
        if failure is not None:
            self.provider.down_state = AdsState.ERROR
            self.log.error(failure.event, **failure.detail,
                           detail="ADS now reports ERROR; exiting for a restart")  # fmt: skip
        await self.shutdown()
        return failure is None

    def _keep_off_geo_cpu(self) -> None:
        """A loop that spins on its cpu owns it: the daemon's threads go to the others (the GEO
        process has pinned itself already; README "Running it as a service")."""
        rt = self.settings.config.rt
        if rt.idle != "spin" or rt.cpu < 0:
            return
        res = keep_off_cpu(rt.cpu)
        (self.log.info if res.ok else self.log.warning)(
            "daemon.rt_setting", text=f"{res.setting}: {'ok' if res.ok else 'skipped'} "
            f"({res.detail})")  # fmt: skip

    async def _serve(self) -> GeoFailure | None:
        keep_alive = asyncio.create_task(systemd.keep_alive(self.geo.advancing))
        supervise = asyncio.create_task(self.geo.supervise())
        stop = asyncio.create_task(self.stopping.wait())
        done, _ = await asyncio.wait({supervise, stop}, timeout=self.duration_s,
                                     return_when=asyncio.FIRST_COMPLETED)  # fmt: skip
        for task in (keep_alive, supervise, stop):
            task.cancel()
        return supervise.result() if supervise in done else None

    def _install_signals(self) -> None:
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGTERM, signal.SIGINT):
            loop.add_signal_handler(sig, self.stopping.set)
        loop.add_signal_handler(signal.SIGHUP, lambda: asyncio.ensure_future(self.reload()))

    def _open_trace(self) -> list[TextIO] | None:
        if not self.trace_path:
            return None
        files: list[TextIO] = []
        for name in trace_names(self.trace_path, self.settings):
            try:
                files.append(open(name, "w", encoding="utf-8", newline=""))  # noqa: SIM115
            except OSError as exc:
                for f in files:
                    f.close()
                raise StartError(f"{name}: cannot write the trace: {exc.strerror}") from None
        return files

    def _start_trace(self, trace_files: list[TextIO] | None) -> None:
        if trace_files is None or self.shared.trace is None:
            return
        # only here: the trace writer brings numpy (sim.trace), which a daemon without --trace
        # does not need in memory
        from liftd.service.trace_recorder import TraceRecorder  # noqa: PLC0415

        names = [c.params.axis_names for c in self.settings.machine]
        recorder = TraceRecorder(trace_files, self.shared.trace, self.shared.codec, names,
                                 self.log)  # fmt: skip
        recorder.start()
        self._trace = recorder

    def _loop_config(self, settings: Settings) -> LoopConfig:
        """The GEO process's configuration; the programs' problems logged (nc.problem)."""
        try:
            cfg = loop_config(settings)
        except OSError as exc:
            raise StartError(f"{exc.filename}: cannot read the program: {exc.strerror}") from None
        log_programs(settings, cfg, self.log)
        return cfg

    async def _listen(self) -> None:
        ads = self.settings.config.ads
        try:
            await self.server.start()
        except OSError as exc:
            raise StartError(f"cannot listen on {ads.host}:{ads.port}: {exc.strerror}") from None
        if not ads.udp_discovery:
            return
        srv = self.server
        self.udp = UdpDiscovery(srv.ports.net_id, srv.ip_allowed, srv.net_id_allowed, srv.warn,
                                srv.note)  # fmt: skip
        try:
            port = await self.udp.start(ads.host, ads.udp_port)
        except OSError as exc:
            raise StartError(f"cannot listen on UDP {ads.host}:{ads.udp_port}: {exc.strerror}"
                             ) from None  # fmt: skip
        self.log.info("ads.udp_listening", host=ads.host, port=port)

    async def _start_ui(self, cfg: LoopConfig) -> None:
        if self.ui is None:
            return
        ui = self.settings.config.ui
        try:
            await self.ui.start(cfg)
        except OSError as exc:
            raise StartError(f"cannot listen on {ui.host}:{ui.port} ([ui]): {exc.strerror}"
                             ) from None  # fmt: skip

    async def _start_metrics(self) -> None:
        m = self.settings.config.metrics
        if not m.prometheus_port:
            return
        from liftd.service import metrics  # noqa: PLC0415  # prometheus_client only when asked

        try:
            self._servers.append(await metrics.serve(
                m.prometheus_host, m.prometheus_port, self.metrics_sample,
                lambda: self.geo.alive, lambda: self.geo.pid,
            ))  # fmt: skip
        except OSError as exc:
            raise StartError(
                f"cannot listen on {m.prometheus_host}:{m.prometheus_port}: {exc.strerror}"
            ) from None

    def metrics_sample(self) -> Sample:
        """What a scrape reads: the loop's counters and histograms, the ADS server's."""
        from liftd.service.metrics import Sample  # noqa: PLC0415

        return Sample(self.shared.totals(), list(self.shared.compute_hist),
                      list(self.shared.lateness_hist), self.geo.alive,
                      self._ads_stats())  # fmt: skip

    async def _start_control(self) -> None:
        path = control.socket_path()
        if path is None:
            return
        try:
            self._servers.append(await control.serve(path, self.reload))
            self._control_inode = path.stat().st_ino
        except OSError as exc:
            raise StartError(f"{path}: cannot open the control socket: {exc.strerror}") from None
        self._control_path = path

    # -- reload -----------------------------------------------------------------------------------
    async def reload(self) -> Verdict:
        """SIGHUP or `liftd reload`: RELOADING=1, the reload, READY=1 (with the verdict as
        STATUS). One at a time, in the order asked."""
        async with self._reload_lock:
            systemd.notify(systemd.reloading_message())
            verdict = await self._reload()
            state = "applied" if verdict.applied else "rejected"
            systemd.notify(f"READY=1\nSTATUS=reload {state}: {verdict.detail}"[:1000])
            return verdict

    async def _reload(self) -> Verdict:
        loop = asyncio.get_running_loop()
        try:
            new = await loop.run_in_executor(None, load_settings, self.config_arg, self.program_arg)
            problem = program_problem(new, self.program_arg)
            if problem is not None:
                raise ConfigError([problem])
        except ConfigError as exc:
            problems = [str(p) for p in exc.problems]
            self.log.error("config.reload_rejected", problems=problems,
                           detail="the running configuration is kept")  # fmt: skip
            return Verdict(False, "; ".join(problems))
        old = self.settings
        if shape(new) != shape(old) or new.channel.cycle_time != old.channel.cycle_time:
            detail = "channels, axes or cycle time changed: restart"
            self.log.error("config.reload_rejected", detail=detail)
            return Verdict(False, detail)
        try:  # reads and decodes every program (~12 µs a block): off the event loop, which
            # would otherwise answer no ADS request and send no WATCHDOG=1 for that long
            cfg = await loop.run_in_executor(None, self._loop_config, new)
        except StartError as exc:
            self.log.error("config.reload_rejected", detail=str(exc))
            return Verdict(False, str(exc))
        # against what runs (the configuration the daemon started with), not the last reload
        restart_keys = needs_restart(self.started.config, new.config)
        if restart_keys:
            self.log.warning("config.reload_partial", needs_restart=restart_keys)
        try:
            await self.geo.reload(cfg)
        except GeoGone as exc:
            self.log.error("config.reload_rejected", detail=str(exc))
            return Verdict(False, str(exc))
        fresh = server_config(new.config.ads)
        self.server.config = dataclasses.replace(
            self.server.config, allow_ips=fresh.allow_ips, allow_net_ids=fresh.allow_net_ids,
            write_net_ids=fresh.write_net_ids, reject=fresh.reject,
        )  # fmt: skip
        self.settings = new
        if self.ui is not None:
            self.ui.reloaded(new, cfg)
        self.log.info("config.reload_accepted", files=list(new.files),
                      detail="takes effect at the next program boundary")  # fmt: skip
        detail = "GEO process has it; it takes effect at the next program boundary"
        return Verdict(True, f"{new.path}: {detail}" + (
            f" (restart for {', '.join(restart_keys)})" if restart_keys else ""))  # fmt: skip

    # -- stop -------------------------------------------------------------------------------------
    async def shutdown(self) -> None:
        t0 = time.monotonic()
        systemd.notify("STOPPING=1")
        self.stopping.set()
        if self.ui is not None:
            await self.ui.close()
        await self.server.close()
        if self.udp is not None:
            self.udp.close()
        for server in self._servers:
            server.close()
        daemon_rss = rss_mb(os.getpid())
        await self.geo.stop()
        if self._trace is not None:
            self._trace.stop()
        if self._control_path is not None and control.owns(self._control_path,
                                                           self._control_inode):  # fmt: skip
            with contextlib.suppress(OSError):
                self._control_path.unlink()
        self.log.info("daemon.stopped", **self.geo.summary().as_log(),
                      stop_seconds=round(time.monotonic() - t0, 3), rss_mb=daemon_rss)  # fmt: skip


def _tee(first: Callable[[Event], None], second: Callable[[Event], None]
         ) -> Callable[[Event], None]:  # fmt: skip
    def both(ev: Event) -> None:
        first(ev)
        second(ev)

    return both


def run(settings: Settings, config_arg: str | None, program_arg: str | None,
        trace_path: str | None, duration_s: float | None = None) -> bool:  # fmt: skip
    """Run the daemon until SIGTERM/SIGINT (or for duration_s); False on a runtime failure."""
    import uvloop  # noqa: PLC0415  # the ADS server's loop (measured: pyproject.toml)

    try:
        try:
            daemon = Daemon(settings, config_arg, program_arg, trace_path, duration_s)
        except OSError as exc:
            structlog.get_logger("liftd").error("daemon.start_failed", reason=str(exc))
            return False
        return uvloop.run(daemon.run())
    finally:
        logs.flush(2.0)  # what the writer thread still holds, unless stderr stays blocked
