"""`liftd view`: one page's player over a recorded trace. Each page has its own timeline
(play, pause, seek, speed) and its own `Feed`, advanced by the wall time between its updates
× the speed; the rows skipped between two updates still show each lift (the feed's pulses,
with the suppressed flag as the rows had it)."""

from __future__ import annotations

import asyncio
import math
import time
from collections.abc import Sequence
from typing import Any

from liftd.ui.feed import HISTORY_S, Feed, encode
from liftd.ui.geometry import Geometry
from liftd.ui.hub import describe, range_extras, times
from liftd.ui.trace import TraceViews

SPEEDS = (0.1, 0.25, 0.5, 1.0, 2.0, 5.0, 10.0)


class TraceSession:
    def __init__(
        self, views: TraceViews, geometry: Sequence[Geometry | None], rate_hz: int = 50
    ) -> None:
        self.views = views
        self.geometry = list(geometry)
        self.period: float | None = 1.0 / rate_hz
        self.feed = Feed(views.catalog, views.missing)
        self.t = views.t0
        self.playing = False
        self.speed = 1.0
        self.version = 0
        self._last = time.monotonic()
        self._jumped = False
        self._moved = False

    def _position(self) -> dict[str, Any]:
        return {
            "t": round(self.t, 6),
            "t0": self.views.t0,
            "t1": self.views.t1,
            "playing": self.playing,
            "speed": self.speed,
        }

    def hello(self) -> dict[str, Any]:
        """The page's full state at the current time (its history rebuilt from the rows)."""
        self.feed.reset_history()
        step = self.period or 0.02
        n = int(min(HISTORY_S, self.t - self.views.t0) / step)
        for i in range(n, 0, -1):
            self.feed.sample(self.views.view(self.t - i * step))
        view = self.views.view(self.t)
        self.feed.sample(view)
        self.feed.values = self.feed.read(view)
        self._last = time.monotonic()
        extras = {
            **range_extras(self.geometry, view),
            "geo": "trace",
            "trace": self._position(),
            "peers": [],
            "events": [],
            "geometry": [1 if g else None for g in self.geometry],  # GET /drawing/<i>/1
        }
        state = {"v": self.version, **self.feed.full(), "x": extras}
        missing = sorted(self.views.missing)
        return {
            "op": "hello",
            "mode": "trace",
            **describe(self.views.catalog),
            "state": state,
            "missing": missing,
        }

    def drawing(self, index: int, version: int) -> bytes | None:
        """The encoded drawing of channel `index` (a trace's drawings are version 1)."""
        geo = self.geometry[index] if version == 1 and 0 <= index < len(self.geometry) else None
        return geo.encoded if geo is not None else None

    def take(self) -> list[str] | None:
        if self._jumped:
            self._jumped = False
            return None
        now = time.monotonic()
        elapsed, self._last = now - self._last, now
        before = self.t
        if self.playing:
            self.t = min(self.t + elapsed * self.speed, self.views.t1)
            if self.t >= self.views.t1:
                self.playing = False
                self._moved = True
        elif not self._moved:
            return []
        view = self.views.view(self.t)
        deltas = self.feed.update(view, self.views.starts_between(before, self.t))
        frames: list[dict[str, Any]] = [{"c": d} for d in deltas] or [{"c": {}}]
        frames[-1]["x"] = {
            **range_extras(self.geometry, view),
            "trace": self._position(),
            "t": times(view),
        }
        self._moved = False
        out = []
        for frame in frames:
            self.version += 1
            frame["v"] = self.version
            out.append(encode(frame))
        return out

    def command(self, msg: dict[str, Any]) -> dict[str, Any] | None:
        op = msg["op"]
        if op == "play":
            if self.t >= self.views.t1:
                self.t = self.views.t0
                self._jumped = True
            self.playing = True
            self._last = time.monotonic()
        elif op == "pause":
            self.playing = False
        elif op == "seek":
            t = msg.get("t")
            if isinstance(t, bool) or not isinstance(t, int | float) or not math.isfinite(t):
                raise ValueError("t: seconds of the trace")
            self.t = min(max(float(t), self.views.t0), self.views.t1)
            self._jumped = True
        elif op == "speed":
            x = msg.get("x")
            if x not in SPEEDS or isinstance(x, bool):
                raise ValueError(f"x: one of {', '.join(map(str, SPEEDS))}")
            self.speed = float(x)
        else:
            return None
        self._moved = True
        return {"op": "trace", **self._position()}

    def attach(self, wake: asyncio.Event) -> None:
        self._wake = wake

    def detach(self, wake: asyncio.Event) -> None:
        return None
