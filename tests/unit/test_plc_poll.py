"""The simulated PLC's cycle on a virtual clock: reads first, then writes; transitions printed
once each; an overrun PLC cycle is counted and the grid kept."""

from __future__ import annotations

import io
import json
import signal
from typing import Any

import pytest

from liftd.clients.plc import ENDING_SIGNALS, WATCHED, Plc, Printer, Target, poll, signals_ignored
from liftd.cnc.plc import Schedule


class FakeClock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now

    def sleep(self, s: float) -> None:
        self.now += s


class FakePlc:
    """lift_active is 1 from t=0.045 s to t=0.075 s; the read at t≈0.03 s takes 25 ms."""

    watched = WATCHED

    def __init__(self, clock: FakeClock) -> None:
        self.clock = clock
        self.t0 = clock.now
        self.log: list[str] = []

    def read(self) -> dict[str, Any]:
        t = self.clock.now - self.t0
        self.log.append("read")
        if 0.029 < t < 0.031:
            self.clock.now += 0.025  # a slow answer: this PLC cycle overruns
        return {
            "lift_active": 0.045 <= t < 0.075,
            "lift_suppressed": False,
            "state": 4,
            "feed_hold": False,
            "error_id": 0,
            "line": 10,
            "override": 1000,
            "m_pending": -1,
        }

    def write_schedule(self, t: float) -> list[tuple[str, Any]]:
        self.log.append("write")
        return [("PLC.ch1.override", 500)] if t == 0 else []

    def acknowledge(self, t: float, m_pending: int) -> list[tuple[str, Any]]:
        return []


def test_poll_prints_each_transition_once_and_counts_overruns() -> None:
    clock = FakeClock()
    fake = FakePlc(clock)
    out = io.StringIO()
    counters = poll(fake, Printer(out, True, "Z"), 0.01, 0.2, clock, clock.sleep)  # type: ignore[arg-type]
    records = [json.loads(line) for line in out.getvalue().splitlines()]
    lift = [(r["t"], r["to"]) for r in records if r.get("object") == "Z.lift_active"]
    assert [to for _, to in lift] == [0, 1, 0]
    assert lift[1][0] == 0.055 and lift[2][0] == 0.08  # late read at once, then on the grid
    assert fake.log[:2] == ["read", "write"]  # inputs before outputs
    assert records[5] == {"t": 0.0, "write": "PLC.ch1.override", "value": 500}
    assert counters["late_cycles"] == 1
    assert counters["transitions"] == 2  # the first sample is not a transition
    assert counters["cycles"] == 18  # 20 slots of 10 ms, two lost to the overrun


class InterruptedConnection:
    """A pyads connection whose write of the feed hold lands in the daemon, and then a
    supervisor's SIGTERM (KeyboardInterrupt from the handler) arrives as the call returns."""

    def __init__(self) -> None:
        self.daemon: dict[str, Any] = {"PLC.ch1.feed_hold": False}
        self.writes: list[str] = []

    def write_by_name(self, symbol: str, value: Any, plc_type: Any) -> None:
        first = symbol not in self.writes
        self.daemon[symbol] = value
        self.writes.append(symbol)
        if first:
            raise KeyboardInterrupt


def test_a_signal_as_the_hold_write_returns_still_releases_the_hold_at_exit() -> None:
    target = Target("127.0.0.1", 1, "127.0.0.1.1.1", 551, 1, "Z")
    plc = Plc(target, Schedule(feed_hold=((0.0, 100.0),)), 1000)
    conn = InterruptedConnection()
    plc.conn = conn  # type: ignore[assignment]
    plc.found = {"PLC.ch1.feed_hold": False}
    with pytest.raises(KeyboardInterrupt):
        plc.write_schedule(0.0)
    assert conn.daemon["PLC.ch1.feed_hold"] is True  # the machine is held
    assert plc.restore() == [("PLC.ch1.feed_hold", 0)]
    assert conn.daemon["PLC.ch1.feed_hold"] is False  # released, as it was found


def test_the_restore_runs_with_ctrl_c_sigterm_and_sighup_ignored_then_handlers_as_before() -> None:
    """An operator's second Ctrl-C during the restore would leave the machine held."""
    before = {s: signal.getsignal(s) for s in ENDING_SIGNALS}
    with signals_ignored():
        assert all(signal.getsignal(s) is signal.SIG_IGN for s in ENDING_SIGNALS)
    assert {s: signal.getsignal(s) for s in ENDING_SIGNALS} == before
