"""The automatic PLC of the GEO task and its override / feed-hold schedule.

`SimPlc` acknowledges synchronised M functions and continues after M00 after a delay; with a
`Schedule` it also sets the override and the feed hold at given GEO times. `liftd simulate` and
the GEO loop of `liftd run` (`[plc] m_ack = "auto"`) use the same class, so a real-time run
reproduces a simulation cycle for cycle. Pure: time is passed in.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Final

from liftd.cnc.snapshot import ChannelState, Command, GeoInputs, GeoSnapshot, new_inputs

MAX_OVERRIDE = 2.0  # 200 %: the highest path override a PLC may request (fraction)


def clamp_override(requested: float) -> float:
    """A requested path override as the channel takes it: 0 … MAX_OVERRIDE (a fraction). The
    one place of this rule: the GEO task's inputs and the runtime's staged PLC writes."""
    return min(max(requested, 0.0), MAX_OVERRIDE)


# enum members as C statics of the compiled module (an enum attribute is two lookups a use)
HOLD: Final = ChannelState.HOLD
NO_COMMAND: Final = Command.NONE
START: Final = Command.START


class SpecError(ValueError):
    """A schedule given as text (command line) cannot be read."""


def _pairs(spec: str, what: str, example: str) -> list[tuple[str, float, float]]:
    pairs = []
    for item in filter(None, (p.strip() for p in spec.split(","))):
        try:
            a_text, b_text = item.split(":")
            a, b = float(a_text), float(b_text)
        except ValueError:
            raise SpecError(f"{what} {item!r}: expected {example}") from None
        pairs.append((item, a, b))
    return pairs


def parse_override_spec(spec: str) -> list[tuple[float, float]]:
    """ "T:PERCENT,T:PERCENT" → [(t_s, fraction)], steps in time order (docs/reference/design.md
    §3.1)."""
    steps = []
    for item, t, pct in _pairs(spec, "override step", "T:PERCENT, e.g. 0.4:150"):
        if not (math.isfinite(t) and t >= 0.0 and 0.0 <= pct <= MAX_OVERRIDE * 100.0):
            raise SpecError(f"override step {item!r}: T >= 0 s and 0 <= PERCENT <= 200")
        steps.append((t, pct / 100.0))
    return sorted(steps)


def parse_feedhold_spec(spec: str) -> list[tuple[float, float]]:
    """ "T:DURATION,..." → [(t_from, t_to)]."""
    windows = []
    for item, t, d in _pairs(spec, "feed hold", "T:DURATION, e.g. 0.3:0.2"):
        if not (math.isfinite(t) and t >= 0.0 and math.isfinite(d) and d > 0.0):
            raise SpecError(f"feed hold {item!r}: T >= 0 s and DURATION > 0 s")
        windows.append((t, t + d))
    return sorted(windows)


@dataclass(frozen=True, slots=True)
class Schedule:
    override: tuple[tuple[float, float], ...] = ()
    feed_hold: tuple[tuple[float, float], ...] = ()

    def override_at(self, t: float) -> float:
        value = 1.0
        for t_step, fraction in self.override:
            if t >= t_step - 1e-12:
                value = fraction
        return value

    def hold_at(self, t: float) -> bool:
        return any(t0 - 1e-12 <= t < t1 - 1e-12 for t0, t1 in self.feed_hold)


class SimPlc:
    """A PLC that acknowledges every M function and continues after M00 after a delay."""

    def __init__(self, delay: float) -> None:
        self.delay = delay
        self.since: float | None = None
        self._idle = GeoInputs()

    def inputs(self, last: GeoSnapshot | None, t: float, schedule: Schedule) -> GeoInputs:
        if (
            not schedule.override
            and not schedule.feed_hold
            and self.since is None
            and (last is None or (last.m_pending < 0 and last.state is not HOLD))
        ):
            return self._idle  # nothing to say: the common case, no allocation
        ack = False
        command = NO_COMMAND
        waiting = last is not None and (
            last.m_pending >= 0 or (last.state is HOLD and not last.feed_hold)
        )
        if waiting:
            assert last is not None
            if self.since is None:
                self.since = t
            if t - self.since >= self.delay - 1e-12:
                self.since = None
                if last.m_pending >= 0:
                    ack = True
                else:
                    command = START
        else:
            self.since = None
        return new_inputs((schedule.override_at(t), schedule.hold_at(t), command, ack))
