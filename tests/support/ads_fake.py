"""One real AdsConnection without a socket: the server objects of a test channel and a fake
transport that records what the server writes (for the fuzz machine and the malformed corpus)."""

from __future__ import annotations

from typing import Any

import structlog

from liftd.ads.server import AdsServer, ServerConfig
from liftd.ads.service import AdsService, ServiceLimits
from liftd.ads.wire import net_id_bytes
from liftd.cnc.snapshot import LoopStats
from liftd.objects.catalog import Catalog, GeoView
from liftd.objects.provider import CncProvider
from tests.support.ads_harness import snapshot
from tests.support.channel import make_channel

NET = net_id_bytes("127.0.0.1.1.1")
FRAME = 4096  # the server's max_frame_bytes; the service's reply cap follows from it
LIMITS = ServiceLimits(max_handles=8, max_notifications=6, max_sum_subcommands=500,
                       max_notification_payload=FRAME - 32, max_reply_payload=FRAME - 32)  # fmt: skip
QUEUE = 32


class FakeTransport:
    def __init__(self) -> None:
        self.out = bytearray()
        self.aborted = False
        self.reading = True

    def write(self, data: bytes) -> None:
        self.out += data

    def get_write_buffer_size(self) -> int:
        return 0  # what the server wrote went to the peer (`out`); pause_writing says otherwise

    def abort(self) -> None:
        self.aborted = True

    def close(self) -> None:  # a graceful close (after a router port close)
        self.aborted = True

    def pause_reading(self) -> None:
        self.reading = False

    def resume_reading(self) -> None:
        self.reading = True

    def get_extra_info(self, name: str) -> Any:
        return ("127.0.0.1", 40000) if name == "peername" else None


class Silent:
    def __getattr__(self, name: str) -> Any:
        return lambda *a, **k: None


def make_server() -> AdsServer:
    catalog = Catalog(make_channel())
    view = GeoView(snapshot(), LoopStats(cycles=1))  # the loop after its first cycle
    provider = CncProvider(catalog, lambda: view, lambda w: None)
    cfg = ServerConfig(host="127.0.0.1", port=0, net_ids=frozenset({NET}),
                       max_frame_bytes=FRAME, write_queue_frames=QUEUE)  # fmt: skip
    return AdsServer(cfg, AdsService(provider, LIMITS), structlog.wrap_logger(Silent()))
