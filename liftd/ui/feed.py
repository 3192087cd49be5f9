"""The page's values: every object of the catalogue read from a `GeoView` with the same getter
the ADS provider uses, keyed by its ADS symbol name, in its ADS unit (BOOL as true/false), as
versioned deltas.

Sampling alone would miss a lift whose flags were TRUE between two updates (a range of one
GEO cycle: 1 ms, the page updates every 20 ms). The lift counters (`GEO.chN.<axis>.lift_count`)
say how many ranges started: when one started and its flags are FALSE again by the next
update, the update is preceded by a pulse, a delta with the flag TRUE (`lift_suppressed` when
the range was suppressed, as the caller saw it: the GEO events live, the skipped rows of a
trace), so the page's element goes TRUE and FALSE as the GEO task's did. Pure: no IO, no clock.
"""

from __future__ import annotations

import json
import math
from collections import deque
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from liftd.objects.catalog import Catalog, CncObject, GeoView

Value = bool | int | float | None
MAX_PULSES = 4  # pulses per axis and update: enough to show each of a burst, bounded
HISTORY_S = 10.0  # seconds of samples a new page gets (the trail, Z over time)


def _rounder(obj: CncObject) -> Callable[[Any], Value]:
    if obj.type.isg == "BOOLEAN":
        return bool
    if obj.type.isg == "REAL64":
        return lambda v: round(float(v), 2) if math.isfinite(v) else None
    return int


@dataclass(frozen=True, slots=True)
class LiftFlags:
    """The symbols of one lift axis (the pulse rule's inputs)."""

    channel: int  # machine index
    axis: int  # channel axis index
    count: str
    active: str
    suppressed: str


@dataclass(slots=True)
class Sample:
    """One update's point of the history (t in s of the GEO task, positions in mm)."""

    t: float
    positions: tuple[float, ...]
    on: bool  # a lift flag of the channel is TRUE

    def as_json(self) -> list[Any]:
        return [round(self.t, 3), [round(p, 3) for p in self.positions], self.on]


@dataclass
class Feed:
    """The values last published and their deltas. `missing`: symbols the source cannot give
    (a trace has no ADS counters); they stay null."""

    catalog: Catalog
    missing: frozenset[str] = frozenset()
    values: dict[str, Value] = field(default_factory=dict)
    version: int = 0
    history: list[deque[Sample]] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.objects = [
            (o.symbol, o.get, _rounder(o))
            for o in self.catalog.objects
            if o.symbol not in self.missing
        ]
        self.lifts = [
            LiftFlags(
                i,
                a,
                f"GEO.ch{c.channel_id}.{ax.name}.lift_count",
                f"GEO.ch{c.channel_id}.{ax.name}.lift_active",
                f"GEO.ch{c.channel_id}.{ax.name}.lift_suppressed",
            )
            for i, c in enumerate(self.catalog.channels)
            for a, ax in enumerate(c.axes)
        ]
        self.values = {o.symbol: None for o in self.catalog.objects}
        self.history = [deque() for _ in self.catalog.channels]

    def read(self, view: GeoView) -> dict[str, Value]:
        """Every symbol's value (null for what the source does not have)."""
        out: dict[str, Value] = dict.fromkeys(self.missing)
        out.update((sym, rnd(get(view))) for sym, get, rnd in self.objects)
        return out

    def update(
        self, view: GeoView, started: Mapping[int, Sequence[bool]] | None = None
    ) -> list[dict[str, Value]]:
        """The deltas (symbol → value) that bring the published values to `view`, pulses
        first; empty when nothing changed. `started`: per machine index, the ranges that
        started since the last update, in order, each as suppressed (True) or not; a range
        the caller did not see is taken as the flag it shows now, else `lift_active`."""
        now = self.read(view)
        out: list[dict[str, Value]] = []
        shown = dict(self.values)
        kinds = started or {}
        lifted: set[int] = set()  # channels with a range that came and went: shaded in history
        for lf in self.lifts:
            before, after = shown.get(lf.count), now.get(lf.count)
            if not isinstance(before, int) or not isinstance(after, int) or after == before:
                continue
            count = after - before if after > before else after  # a new program: from 0
            if count <= 0:
                continue
            running = lf.suppressed if now[lf.suppressed] else lf.active if now[lf.active] else ""
            seen = [lf.suppressed if s else lf.active for s in kinds.get(lf.channel, ())]
            flags = seen[-count:] + [running or lf.active] * (count - len(seen))
            if running:  # the last one started is the one running now
                flags[-1] = running
            pulsed = flags[:-1] if running else flags
            for flag in (lf.active, lf.suppressed):  # the range shown before it has ended
                if shown[flag]:
                    out.append({flag: False})
                    shown[flag] = False
            if pulsed:
                lifted.add(lf.channel)
            for flag in pulsed[-MAX_PULSES:]:  # each range that came and went, its own flag
                out.append({flag: True})
                out.append({flag: False})
        delta = {k: v for k, v in now.items() if shown.get(k) != v}
        if delta:
            out.append(delta)
        self.values = now
        self.version += len(out)
        self.sample(view, lifted)
        return out

    def sample(self, view: GeoView, lifted: set[int] | frozenset[int] = frozenset()) -> None:
        snaps = view.channels or (view.snapshot,)
        for i, snap in enumerate(snaps):
            hist = self.history[i]
            on = bool(snap.lift_active or snap.lift_suppressed) or i in lifted
            hist.append(Sample(snap.t, tuple(p * 1e3 for p in snap.positions), on))
            while hist and (snap.t - hist[0].t > HISTORY_S or hist[0].t > snap.t):
                hist.popleft()

    def reset_history(self) -> None:
        for hist in self.history:
            hist.clear()

    def full(self) -> dict[str, Any]:
        """What a page gets first: every value and the history."""
        return {"values": self.values, "history": [[s.as_json() for s in h] for h in self.history]}


def encode(message: dict[str, Any]) -> str:
    return json.dumps(message, separators=(",", ":"), allow_nan=False)
