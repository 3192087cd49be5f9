"""The live view's data: one `Feed` for every open page, updated at `[ui] rate_hz` from the
view the ADS provider reads (the daemon's `_view`: the last published GEO snapshot, no work
in the GEO process), its deltas kept in a ring so that each page takes what it has not seen,
in order (pulses included), at its own pace; a page that fell further behind than the ring
gets the full state again. Extras beside the values: the open lift range, the NC block text,
the GEO events, the ADS peers."""

from __future__ import annotations

import asyncio
import time
from collections import deque
from collections.abc import Callable, Sequence
from typing import Any

from liftd.cnc.snapshot import Event, LiftPhase
from liftd.objects.catalog import Catalog, GeoView
from liftd.ui.feed import Feed, encode
from liftd.ui.geometry import Geometry

RING = 512  # deltas kept for pages that lag (10 s at 50 Hz)
EVENTS_KEPT = 50  # GEO events a new page gets
EVENTS_PER_TICK = 64  # the rest of a burst is counted, not sent
PEERS_EVERY_S = 1.0
QUIET = {"geo.compute_over"}  # in the log and counted on the page (GEO.timing.*), not listed

ViewSource = Callable[[], GeoView | None]
PeerSource = Callable[[], list[dict[str, Any]]]


def range_extras(geos: Sequence[Geometry | None], view: GeoView) -> dict[str, Any]:
    """Per channel id: the lift range open now (by the NC line, while a flag or phase is on)
    and the NC text of the line being executed."""
    ranges: dict[str, Any] = {}
    texts: dict[str, str] = {}
    snaps = view.channels or (view.snapshot,)
    for geo, snap in zip(geos, snaps, strict=False):
        if geo is None:
            continue
        key = str(geo.channel_id)
        on = (
            snap.lift_active
            or snap.lift_suppressed
            or snap.lift_phase not in (LiftPhase.NONE, LiftPhase.DONE)
        )
        ranges[key] = geo.open_range(snap.line) if on else None
        texts[key] = geo.block_text(snap.line)
    return {"range": ranges, "text": texts}


def times(view: GeoView) -> list[float]:
    """Each channel's GEO time (s): the page's clock for the trail and Z over time."""
    return [round(s.t, 4) for s in (view.channels or (view.snapshot,))]


class LiveHub:
    def __init__(
        self, catalog: Catalog, view: ViewSource, peers: PeerSource, rate_hz: int = 50
    ) -> None:
        self.catalog = catalog
        self.view = view
        self.peers = peers
        self.period = 1.0 / rate_hz
        self.feed = Feed(catalog)
        self.ring: deque[tuple[int, str]] = deque(maxlen=RING)
        self.geometry: list[Geometry | None] = [None] * len(catalog.channels)
        self.drawn: list[int] = [0] * len(catalog.channels)  # each drawing's version
        self._drawn = 0
        self.extras: dict[str, Any] = {
            "range": {},
            "text": {},
            "peers": [],
            "geo": "starting",
            "error": {},
        }
        self.events: deque[dict[str, Any]] = deque(maxlen=EVENTS_KEPT)
        self._pending: deque[Event] = deque()
        self.events_dropped = 0
        self.waiters: set[asyncio.Event] = set()  # the open pages' wake-ups
        self.errors: dict[int, tuple[int, str]] = {}  # machine index → (error id, text)
        self._peers_at = 0.0
        self.ticks = 0
        self._v = 0  # the last frame's version

    # -- inputs -----------------------------------------------------------------------------------
    def on_event(self, ev: Event) -> None:
        """A GEO event (the daemon's event callback): kept for the next update, bounded; an
        error's text kept for as long as the channel shows its id."""
        if ev.name == "geo.error":
            self.errors[self._index(ev.channel)] = (int(ev.value), ev.text)
        if len(self._pending) < EVENTS_PER_TICK:
            self._pending.append(ev)
        else:
            self.events_dropped += 1

    def set_geometry(self, index: int, geo: Geometry | None) -> None:
        self._drawn += 1
        self.geometry[index] = geo
        self.drawn[index] = self._drawn
        self._publish([], {"geometry": self.drawings()})

    def drawings(self) -> list[int | None]:
        """Per channel, the version of its drawing (the page GETs /drawing/<index>/<version>:
        the drawing is never in a hello or a frame)."""
        pairs = zip(self.geometry, self.drawn, strict=True)
        return [v if g is not None else None for g, v in pairs]

    def drawing(self, index: int, version: int) -> bytes | None:
        """The encoded drawing of channel `index`, if `version` is still its own."""
        if not 0 <= index < len(self.geometry) or self.drawn[index] != version:
            return None
        geo = self.geometry[index]
        return geo.encoded if geo is not None else None

    # -- updates ----------------------------------------------------------------------------------
    async def run(self) -> None:
        """Update while a page is open; with none the hub costs the daemon nothing but the
        GEO events it keeps for the next page."""
        while True:
            if self.waiters:
                self.tick()
            else:
                self.events.extend(self._event(ev) for ev in self._pending if ev.name not in QUIET)
                self._pending.clear()
            await asyncio.sleep(self.period)

    def tick(self) -> None:
        self.ticks += 1
        view = self.view()
        extras: dict[str, Any] = {}
        events = [self._event(ev) for ev in self._pending if ev.name not in QUIET]
        started: dict[int, list[bool]] = {}  # per channel, each range started: suppressed?
        for ev in self._pending:
            if ev.name == "lift.start":
                started.setdefault(self._index(ev.channel), []).append(ev.text == "suppressed")
        self._pending.clear()
        if events:
            self.events.extend(events)
            extras["events"] = events
        geo = "running" if view is not None else "down"
        if geo != self.extras["geo"]:
            extras["geo"] = geo
        now = time.monotonic()
        if now - self._peers_at >= PEERS_EVERY_S:
            self._peers_at = now
            peers = self.peers()
            if peers != self.extras["peers"]:
                extras["peers"] = peers
        deltas: list[dict[str, Any]] = []
        if view is not None:
            deltas = self.feed.update(view, started)
            for key, value in range_extras(self.geometry, view).items():
                if value != self.extras[key]:
                    extras[key] = value
            extras["t"] = times(view)
            errors = self._error_texts(view)
            if errors != self.extras["error"]:
                extras["error"] = errors
        self._publish(deltas, extras)

    def _publish(self, deltas: list[dict[str, Any]], extras: dict[str, Any]) -> None:
        self.extras.update({k: v for k, v in extras.items() if k not in ("events", "t")})
        if not deltas and not extras:
            return
        frames: list[dict[str, Any]] = [{"c": d} for d in deltas] or [{"c": {}}]
        frames[-1]["x"] = extras
        for frame in frames:
            self._v += 1
            frame["v"] = self._v
            self.ring.append((self._v, encode(frame)))
        for wake in self.waiters:
            wake.set()

    def _error_texts(self, view: GeoView) -> dict[str, str]:
        """Per channel id: the text of the error the channel shows (geo.error's message)."""
        out = {}
        for i, snap in enumerate(view.channels or (view.snapshot,)):
            known = self.errors.get(i)
            text = known[1] if known is not None and known[0] == snap.error_id else ""
            out[str(self.catalog.channels[i].channel_id)] = text if snap.error_id else ""
        return out

    def _index(self, channel_id: int) -> int:
        return self.catalog.index_of(channel_id) or 0 if channel_id else 0

    @staticmethod
    def _event(ev: Event) -> dict[str, Any]:
        value = float(f"{ev.value:.9g}")
        return {
            "name": ev.name,
            "t": round(ev.t, 6),
            "line": ev.line,
            "value": value,
            "text": ev.text,
            "channel": ev.channel,
        }

    # -- what a page takes ------------------------------------------------------------------------
    @property
    def version(self) -> int:
        return self._v

    def full(self) -> dict[str, Any]:
        return {
            "v": self.version,
            **self.feed.full(),
            "x": {**self.extras, "events": list(self.events), "geometry": self.drawings()},
        }

    def since(self, version: int) -> list[str] | None:
        """The encoded frames after `version`, None when the ring no longer has them all."""
        if version >= self._v:
            return []
        if not self.ring or version < self.ring[0][0] - 1:
            return None
        return [f for v, f in self.ring if v > version]


def describe(catalog: Catalog) -> dict[str, Any]:
    """The objects a page shows (symbol, unit, type, writable, comment) and the channels."""
    return {
        "objects": [
            {
                "symbol": o.symbol,
                "unit": o.unit,
                "type": o.type.isg,
                "writable": o.writable,
                "comment": o.comment,
            }
            for o in catalog.objects
        ],
        "channels": [
            {
                "id": c.channel_id,
                "axes": list(c.axis_names),
                "lift_axis": c.lift_axis,
                "method": c.lift_method.value,
            }
            for c in catalog.channels
        ],
        "cycle_time_s": catalog.channel.cycle_time,
    }


class LiveSession:
    """One page of the live view: what it has of the hub's frames."""

    period: float | None = None

    def __init__(self, hub: LiveHub) -> None:
        self.hub = hub
        self.version = hub.version
        self.wake: asyncio.Event | None = None

    def hello(self) -> dict[str, Any]:
        if not self.hub.waiters - {self.wake}:  # the hub was idle: bring it up to date first
            self.hub.tick()
        full = self.hub.full()
        self.version = full["v"]
        return {"op": "hello", "mode": "live", **describe(self.hub.catalog), "state": full}

    def take(self) -> list[str] | None:
        frames = self.hub.since(self.version)
        self.version = self.hub.version
        return frames

    def command(self, msg: dict[str, Any]) -> dict[str, Any] | None:
        return None

    def attach(self, wake: asyncio.Event) -> None:
        self.wake = wake
        self.hub.waiters.add(wake)

    def detach(self, wake: asyncio.Event) -> None:
        self.hub.waiters.discard(wake)
