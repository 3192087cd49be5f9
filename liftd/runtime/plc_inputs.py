"""The PLC side of the GEO task as the loop sees it each cycle: the levels and edges written
over ADS, and the automatic PLC of `[plc] m_ack = "auto"`.

With no ADS writes the inputs are exactly those `liftd simulate` feeds (the same `SimPlc`), so
a real-time run reproduces a simulation cycle for cycle. A PLC STOP is not undone by the
automatic PLC (it only continues after M00).
"""

from __future__ import annotations

from collections import deque

from liftd.cnc.plc import MAX_OVERRIDE, Schedule, SimPlc
from liftd.cnc.snapshot import (
    ChannelState,
    Command,
    GeoInputs,
    GeoSnapshot,
    PlcSignal,
    PlcWrite,
    new_inputs,
)

_COMMANDS = {PlcSignal.START: Command.START, PlcSignal.STOP: Command.STOP,
             PlcSignal.RESET: Command.RESET}  # fmt: skip
_NO_SCHEDULE = Schedule()
_IDLE = GeoInputs()


class PlcInputs:
    def __init__(self, auto: bool, ack_delay_s: float) -> None:
        self.override = 1.0
        self.feed_hold = False
        self.commands: deque[Command] = deque(maxlen=16)
        self.m_ack = False
        self.auto = SimPlc(ack_delay_s) if auto else None
        self.plc_stopped = False  # a STOP from the PLC: the automatic PLC must not continue

    def apply(self, w: PlcWrite) -> bool:
        """Take one PLC write; True if it changes what the GEO task gets (a new override or
        feed-hold level, or a command), False for a level written again unchanged."""
        sig = w.signal
        if sig is PlcSignal.OVERRIDE:
            old, self.override = self.override, min(max(w.value, 0.0), MAX_OVERRIDE)
            return self.override != old
        if sig is PlcSignal.FEED_HOLD:
            old_hold, self.feed_hold = self.feed_hold, w.value != 0.0
            return self.feed_hold != old_hold
        if sig is PlcSignal.M_ACK:
            self.m_ack = True
        else:
            cmd = _COMMANDS[sig]
            self.commands.append(cmd)
            self.plc_stopped = cmd is Command.STOP
        return True

    def request(self, cmd: Command) -> None:
        """A command of the loop itself (program repeat)."""
        self.commands.append(cmd)

    def inputs(self, last: GeoSnapshot | None, t: float) -> GeoInputs:
        base = _IDLE
        if self.auto is not None and not (
            self.plc_stopped and last is not None and last.state is ChannelState.HOLD
        ):
            base = self.auto.inputs(last, t, _NO_SCHEDULE)
        if self.override == 1.0 and not self.feed_hold and not self.commands and not self.m_ack:
            return base
        command = self.commands.popleft() if self.commands else base.command
        ack = self.m_ack or base.m_ack
        self.m_ack = False
        return new_inputs((self.override, self.feed_hold, command, ack))
