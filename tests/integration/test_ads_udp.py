"""pyads' own UDP functions against liftd's discovery endpoint on a free loopback port
(pyads sends to PORT_REMOTE_UDP, 48899 by default; tests never use the fixed port)."""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Iterator

import pyads
import pyads.pyads_ex
import pytest

from liftd.ads.udp import UdpDiscovery

pytestmark = pytest.mark.integration
NET = bytes([127, 0, 0, 61, 1, 1])
ALLOWED = "127.0.0.62.1.1"


@pytest.fixture
def endpoint(monkeypatch: pytest.MonkeyPatch) -> Iterator[UdpDiscovery]:
    loop = asyncio.new_event_loop()
    thread = threading.Thread(target=loop.run_forever, daemon=True)
    thread.start()
    udp = UdpDiscovery(
        NET,
        lambda ip: ip.startswith("127."),
        lambda n: ".".join(map(str, n)) == ALLOWED,
        lambda *a, **k: None,
        lambda *a, **k: None,
    )
    port = asyncio.run_coroutine_threadsafe(udp.start("127.0.0.1", 0), loop).result(5)
    monkeypatch.setattr(pyads.pyads_ex, "PORT_REMOTE_UDP", port)
    try:
        yield udp
    finally:
        loop.call_soon_threadsafe(udp.close)
        loop.call_soon_threadsafe(loop.stop)
        thread.join(5)


def test_pyads_discovers_the_net_id_and_adds_a_route(endpoint: UdpDiscovery) -> None:
    assert pyads.pyads_ex.adsGetNetIdForPLC("127.0.0.1") == "127.0.0.61.1.1"
    added = pyads.pyads_ex.adsAddRouteToPLC(
        "127.0.0.62.1.1", "host", "127.0.0.1", "Administrator", "1", added_net_id=ALLOWED
    )
    assert added is True
    with pytest.raises(RuntimeError):  # refused (0x704): pyads calls any other status unexpected
        pyads.pyads_ex.adsAddRouteToPLC("10.1.1.1.1.1", "host", "127.0.0.1", "u", "p")
    assert endpoint.counters.routes_added == 1 and endpoint.counters.routes_refused == 1
