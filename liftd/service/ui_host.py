"""The live view inside `liftd run` (`[ui] enabled`): the page's server and hub (liftd/ui/) fed
from what the daemon already has, adapted here. Values come from `Daemon._view` (the published
GEO snapshot the ADS provider reads), events from the GEO process's event callback, peers and
counters from the ADS server; a control write goes to `CncProvider.write_symbol`, the path of
an ADS write of `PLC.chN.*`, so `run --trace` still equals `simulate` with the same schedule.
The GEO process does nothing for it. The program drawings are prepared and encoded in a
process of their own (`geometry.build` holds the GIL for seconds on a long program: a thread
would stall the event loop the ADS server shares) after the daemon is ready, again after a
reload, shown once the loop took the reload (`geo.reloaded`)."""

from __future__ import annotations

import asyncio
import contextlib
import multiprocessing
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from typing import Any

from liftd.ads.errors import AdsError
from liftd.ads.server import AdsServer
from liftd.cnc.snapshot import Event
from liftd.objects.catalog import Catalog, GeoView
from liftd.objects.provider import CncProvider
from liftd.runtime.loop_config import LoopConfig
from liftd.settings import Settings
from liftd.ui import geometry
from liftd.ui.hub import LiveHub, LiveSession
from liftd.ui.web import Refused, UiServer, WebConfig

# programs up to this size (all channels) are drawn in a thread: ~8 KB, ~300 blocks, hold the
# GIL for 5-25 ms (hops_program(60): 4.7 KB in 5.6 ms alone, 25 ms under load); larger ones
# in a process of their own (40 000 ranges: a thread stalls the loop 150-170 ms)
THREAD_MAX_CHARS = 8_192


class UiHost:
    def __init__(
        self,
        settings: Settings,
        catalog: Catalog,
        provider: CncProvider,
        server: AdsServer,
        view: Callable[[], GeoView | None],
        log: Any,
    ) -> None:
        ui = settings.config.ui
        self.settings = settings
        self.provider = provider
        self.ads = server
        self.log = log
        self.hub = LiveHub(catalog, view, self._peers, ui.rate_hz)
        cfg = WebConfig(
            ui.host,
            ui.port,
            ui.control,
            settings.ui_token,
            ui.hosts,
            ui.max_connections,
            ui.max_message_bytes,
        )
        self.server = UiServer(
            cfg, lambda: LiveSession(self.hub), log, self._write, self._policy, self.hub.drawing
        )
        self._task: asyncio.Task[None] | None = None
        self._jobs: set[asyncio.Future[Any]] = set()
        self._staged: dict[int, geometry.Geometry] = {}
        self._pools: set[ProcessPoolExecutor] = set()

    @property
    def url(self) -> str:
        host = self.settings.config.ui.host
        shown = "127.0.0.1" if host in ("0.0.0.0", "") else "[::1]" if host == "::" else host
        shown = f"[{shown}]" if ":" in shown and not shown.startswith("[") else shown
        return f"http://{shown}:{self.server.port}/"

    def on_event(self, ev: Event) -> None:
        self.hub.on_event(ev)
        if ev.name == "geo.reloaded":
            index = self.hub.catalog.index_of(ev.channel) if ev.channel else 0
            staged = self._staged.pop(index or 0, None)
            if staged is not None:
                self.hub.set_geometry(index or 0, staged)

    async def start(self, cfg: LoopConfig) -> None:
        """Listen (OSError when the port is taken), then update the pages and draw."""
        await self.server.start()
        self._task = asyncio.create_task(self.hub.run())
        self.draw(cfg, staged=False)
        self.check_token_file()
        ui = self.settings.config.ui
        self.log.info(
            "ui.listening", url=self.url, control=ui.control and self.settings.ui_token is not None
        )

    def draw(self, cfg: LoopConfig, staged: bool = True) -> None:
        """Each channel's program drawn in a process (spawned: no fork of a process with
        threads; it ends with the drawing), small programs in a worker thread (a spawn costs
        more than their build); a reload's (`staged`) waits for the loop to take it."""
        loop = asyncio.get_running_loop()
        todo = [(i, ch) for i, ch in enumerate(cfg.channels) if ch.program_name != "(none)"]
        if not todo:
            return
        small = sum(len(ch.program_text) for _, ch in todo) <= THREAD_MAX_CHARS
        pool: ProcessPoolExecutor | None = None
        if not small:
            pool = ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn"))
            self._pools.add(pool)
        left = [len(todo)]
        for i, ch in todo:
            job = loop.run_in_executor(pool, geometry.build, ch.channel, ch.program_text)

            def done(fut: asyncio.Future[geometry.Geometry], i: int = i) -> None:
                self._jobs.discard(fut)
                left[0] -= 1
                if not left[0] and pool is not None:
                    self._pools.discard(pool)
                    pool.shutdown(wait=False)
                if fut.cancelled() or fut.exception() is not None:
                    return
                if staged:
                    self._staged[i] = fut.result()
                else:
                    self.hub.set_geometry(i, fut.result())

            self._jobs.add(job)
            job.add_done_callback(done)

    def reloaded(self, settings: Settings, cfg: LoopConfig) -> None:
        """A reload: the new programs drawn; a new control token (`[ui] token`, or what
        `[ui] token_file` holds now) applies at once, the old one unlocks nothing more."""
        if settings.ui_token != self.settings.ui_token:
            self.server.set_token(settings.ui_token)
            self.log.info("ui.token_changed", detail="pages unlocked with the old one are locked")
        self.settings = settings
        self.check_token_file()
        self.draw(cfg)

    def check_token_file(self) -> None:
        """Warn when `[ui] token_file` is readable by others than its owner (the token
        unlocks control of the machine's channels)."""
        name = self.settings.config.ui.token_file
        if name is None:
            return
        path = self.settings.path.parent / name
        try:
            mode = path.stat().st_mode & 0o777
        except OSError:
            return  # (read at load: gone since)
        if mode & 0o077:
            self.log.warning("ui.token_file_permissions", file=str(path), mode=f"{mode:03o}",
                             detail=f"readable beyond its owner: chmod 600 {path}")  # fmt: skip

    async def close(self) -> None:
        for job in list(self._jobs):
            job.cancel()
        for pool in self._pools:  # a drawing still being built is not waited for at exit
            procs: dict[int, Any] = getattr(pool, "_processes", None) or {}  # (no public kill)
            for proc in list(procs.values()):
                proc.terminate()
            pool.shutdown(wait=False, cancel_futures=True)
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task
        await self.server.close()

    # -- adapters ---------------------------------------------------------------------------------
    def _peers(self) -> list[dict[str, Any]]:
        return [
            {"peer": p, "net_id": n, "requests": r, "notifications": k}
            for p, n, r, k in self.ads.peers()
        ]

    def _policy(self, ip: str) -> str:
        """The ADS access policy for a writing peer: its IP in `[ads] allow_ips`; with
        `[ads] write_net_ids` writes are for those NetIds, which a browser does not have."""
        if not self.ads.ip_allowed(ip):
            return f"{ip} is not in [ads] allow_ips"
        if self.ads.config.write_net_ids:
            return "[ads] write_net_ids limits writes to PLCs with those NetIds"
        return ""

    def _write(self, symbol: str, value: bool | int) -> None:
        if not symbol.upper().startswith("PLC."):
            raise Refused(f"{symbol[:80]}: only PLC.chN.* is written")
        try:
            self.provider.write_symbol(symbol, value)
        except AdsError as exc:
            raise Refused(f"ADS error 0x{int(exc.code):X}: {exc}") from None
        self.log.info("ui.write", symbol=symbol, value=value)
