"""The live hub without a server: what a page gets from a GEO view, the GEO events and the
ADS peers, and what a page that lags gets."""

from __future__ import annotations

import json

from liftd.cnc.snapshot import ChannelState, Event
from liftd.objects.catalog import Catalog, GeoView
from liftd.ui.hub import RING, LiveHub
from tests.unit.ui.test_feed import CH, view


def errored(cycle: int, error_id: int) -> GeoView:
    v = view(cycle)
    snap = v.snapshot._replace(state=ChannelState.ERROR, error_id=error_id, error_line=14)
    return v._replace(snapshot=snap)


def frames(hub: LiveHub, since: int) -> list[dict[str, object]]:
    got = hub.since(since)
    assert got is not None
    return [json.loads(f) for f in got]


def test_an_error_shows_its_text_while_the_channel_shows_its_id() -> None:
    current = [view(1)]
    hub = LiveHub(Catalog(CH), lambda: current[0], list)
    hub.tick()
    hub.on_event(Event("geo.error", 0.5, 14, 21558.0, "motion beyond the software limit"))
    current[0] = errored(2, 21558)
    v = hub.version
    hub.tick()
    (last,) = [f for f in frames(hub, v) if "x" in f]
    assert last["x"]["error"] == {"1": "motion beyond the software limit"}  # type: ignore[index]
    current[0] = view(3)  # RESET: the error is gone
    v = hub.version
    hub.tick()
    (last,) = [f for f in frames(hub, v) if "x" in f]
    assert last["x"]["error"] == {"1": ""}  # type: ignore[index]


def test_a_lagging_page_gets_the_full_state_again() -> None:
    k = [0]

    def source() -> GeoView:
        k[0] += 1
        return view(k[0], x=k[0] * 1e-3)

    hub = LiveHub(Catalog(CH), source, list)
    hub.tick()
    start = hub.version
    for _ in range(RING + 5):
        hub.tick()
    assert hub.since(start) is None  # the ring no longer holds what it missed
    assert hub.full()["values"]["GEO.cycle"] == k[0]
    assert len(frames(hub, hub.version - 3)) == 3


def test_peers_and_events_reach_the_page() -> None:
    peers = [{"peer": "127.0.0.1:5000", "net_id": "1.2.3.4.1.1", "requests": 7,
              "notifications": 0}]  # fmt: skip
    hub = LiveHub(Catalog(CH), lambda: view(1), lambda: peers)
    hub.on_event(Event("lift.start", 0.1, 19, 0.001, ""))
    hub.on_event(Event("geo.compute_over", 0.1, 19, 300.0, ""))  # counted, not listed
    hub.tick()
    full = hub.full()["x"]
    assert full["peers"] == peers
    assert [e["name"] for e in full["events"]] == ["lift.start"]
