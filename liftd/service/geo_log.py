"""The GEO process's events as log lines: one structlog line per event, with its level (errors,
warnings for overruns, regrids, refused RT settings and Z overloads) and the quiet ones
rate-limited or dropped (a lift's override grants, M output and acknowledge)."""

from __future__ import annotations

import time
from typing import Any

from liftd.cnc.snapshot import Event

QUIET_EVENTS = {"lift.override_limited": 1.0, "geo.m_output": 0.0, "geo.m_ack": 0.0}
ERRORS = {"geo.error", "geo.fault"}
WARNINGS = {"geo.overrun", "geo.regrid", "lift.z_acc_error"}


class GeoEventLog:
    """`GeoProcess.on_event`: log each event under its own name."""

    def __init__(self, log: Any) -> None:
        self.log = log
        self._last: dict[str, float] = {}

    def __call__(self, ev: Event) -> None:
        min_gap = QUIET_EVENTS.get(ev.name)
        if min_gap is not None:
            now = time.monotonic()
            if min_gap == 0.0 or now - self._last.get(ev.name, -1e9) < min_gap:
                return
            self._last[ev.name] = now
        level = "info"
        if ev.name in ERRORS:
            level = "error"
        elif ev.name in WARNINGS or (ev.name == "geo.rt_setting" and not ev.value):
            level = "warning"
        value = float(f"{ev.value:.9g}")  # no float noise in the log
        extra = {"channel": ev.channel} if ev.channel else {}  # a machine of several channels
        getattr(self.log, level)(
            ev.name, t=round(ev.t, 6), line=ev.line, value=value, text=ev.text or None, **extra
        )
