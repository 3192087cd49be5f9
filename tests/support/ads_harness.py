"""The real ADS server in a background event loop on a free loopback port, serving the CNC
objects of a test channel from a snapshot the test sets (no GEO loop)."""

from __future__ import annotations

import asyncio
import dataclasses
import itertools
import threading
from typing import Any

import structlog

from liftd.ads.constants import AdsErr
from liftd.ads.errors import AdsError
from liftd.ads.server import AdsServer, ServerConfig
from liftd.ads.service import AdsService, ServiceLimits
from liftd.ads.wire import net_id_bytes
from liftd.cnc.params import ChannelParams
from liftd.cnc.snapshot import ChannelState, GeoSnapshot, LiftPhase, LoopStats, PlcWrite
from liftd.objects.catalog import Catalog, GeoView
from liftd.objects.provider import CncProvider

_net = itertools.count(10)


def snapshot(**kw: Any) -> GeoSnapshot:
    base = GeoSnapshot(
        cycle=1,
        t=0.001,
        state=ChannelState.ACTIVE,
        line=7,
        segment=2,
        positions=(0.1, 0.02, 0.04),
        v_path=0.25,
        override=1.0,
        override_requested=1.0,
        override_max=2.0,
        feed_hold=False,
        lift_active=False,
        lift_suppressed=False,
        lift_phase=LiftPhase.NONE,
        lift_vz=0.0,
        lift_az=0.0,
        m_pending=-1,
        error_id=0,
        error_line=0,
        events=(),
        v_block_max=0.4,
        v_block_end=0.1,
        lift_axis=2,
        lift_counts=(0, 0, 4),
    )
    return base._replace(**kw)


class Harness:
    def __init__(
        self,
        ch: ChannelParams,
        limits: ServiceLimits | None = None,
        **config: Any,
    ) -> None:
        self.net_id = f"127.0.0.{next(_net) % 250 + 1}.1.1"  # AdsLib routes one NetId per IP
        cfg = ServerConfig(host="127.0.0.1", port=0, net_ids=frozenset({net_id_bytes(self.net_id)}))
        self.config = dataclasses.replace(cfg, **config)
        self.view: GeoView | None = GeoView(snapshot(), LoopStats(cycles=1))  # after one cycle
        self.writes: list[PlcWrite] = []
        self.logs = structlog.testing.CapturingLogger()  # the server's log lines, kept here
        self.busy = False
        self.catalog = Catalog(ch)
        self.provider = CncProvider(self.catalog, lambda: self.view, self._sink)
        self.service = AdsService(self.provider, limits or ServiceLimits())
        self.loop = asyncio.new_event_loop()
        self.thread = threading.Thread(target=self.loop.run_forever, daemon=True)
        self.server: AdsServer | None = None
        self.port = 0

    def _sink(self, w: PlcWrite) -> None:
        if self.busy:
            raise AdsError(AdsErr.BUSY, "queue full")
        self.writes.append(w)

    def set(self, **kw: Any) -> None:
        assert self.view is not None
        self.view = self.view._replace(snapshot=self.view.snapshot._replace(**kw))

    def __enter__(self) -> Harness:
        self.thread.start()

        async def start() -> int:
            log = structlog.wrap_logger(self.logs, processors=[])  # not the global config
            self.server = AdsServer(self.config, self.service, log)
            return await self.server.start()

        self.port = asyncio.run_coroutine_threadsafe(start(), self.loop).result(5)
        return self

    def __exit__(self, *exc: object) -> None:
        if self.server is not None:
            asyncio.run_coroutine_threadsafe(self.server.close(), self.loop).result(5)
        self.loop.call_soon_threadsafe(self.loop.stop)
        self.thread.join(5)

    @property
    def address(self) -> str:
        return f"127.0.0.1:{self.port}"
