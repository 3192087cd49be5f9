"""The PLC side of the GEO task as the loop sees it each cycle: the levels and edges written
over ADS, and the automatic PLC of `[plc] m_ack = "auto"`.

A write takes effect one cycle after the cycle that reads it off the input ring: `apply` stages
it (and says whether it changes what the GEO task gets, for the loop's log), `take` puts what
was staged into effect at the start of the next cycle. So the read and its event fall into one
cycle and the re-plan a new override or an acknowledge costs into the next, instead of both
into one (in the daemon the read was 50–130 µs of a write's cycle with cold caches, the re-plan
90–290 µs: `bench_rt`'s geo.compute_over lines).

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
        # in effect
        self.override = 1.0
        self.feed_hold = False
        self.commands: deque[Command] = deque()  # bounded by the loop's reading (BACKLOG)
        self.m_ack = False
        # written by the PLC, in effect from the next cycle (`take`)
        self.staged = False
        self.next_override = 1.0
        self.next_feed_hold = False
        self.next_commands: deque[Command] = deque()
        self.next_m_ack = False
        self.auto = SimPlc(ack_delay_s) if auto else None
        self.plc_stopped = False  # a STOP from the PLC: the automatic PLC must not continue

    def apply(self, w: PlcWrite) -> bool:
        """Stage one PLC write for the next cycle; True if it changes what the GEO task gets (a
        new override or feed-hold level, or a command), False for a level written again
        unchanged."""
        sig = w.signal
        if sig is PlcSignal.OVERRIDE:
            old, self.next_override = self.next_override, min(max(w.value, 0.0), MAX_OVERRIDE)
            changed = self.next_override != old
        elif sig is PlcSignal.FEED_HOLD:
            old_hold, self.next_feed_hold = self.next_feed_hold, w.value != 0.0
            changed = self.next_feed_hold != old_hold
        elif sig is PlcSignal.M_ACK:
            self.next_m_ack = changed = True
        else:
            self.next_commands.append(_COMMANDS[sig])
            changed = True
        self.staged = self.staged or changed
        return changed

    def take(self) -> None:
        """What the PLC wrote in the last cycle takes effect (before this cycle's `inputs`)."""
        self.staged = False
        self.override, self.feed_hold = self.next_override, self.next_feed_hold
        if self.next_m_ack:
            self.m_ack, self.next_m_ack = True, False
        while self.next_commands:
            cmd = self.next_commands.popleft()
            self.commands.append(cmd)
            self.plc_stopped = cmd is Command.STOP

    def carry_over(self, old: PlcInputs) -> None:
        """Take over the PLC's levels and what `old` staged: a reload replaces a channel's
        inputs at the end of a cycle. The override and the feed hold are levels the PLC owns
        (it wrote them once, over ADS, and reads them back as override_requested/feed_hold):
        a new configuration must not release a feed hold or put the path back to 100 %. A
        write read in that cycle was logged as taking effect in the next, so it does; a command
        already delivered to the GEO task is not repeated."""
        self.override, self.feed_hold = old.override, old.feed_hold
        self.next_override, self.next_feed_hold = old.next_override, old.next_feed_hold
        self.commands.extend(old.commands)  # written by the PLC, not yet delivered (one a cycle)
        if old.staged:
            self.staged = True
            self.next_m_ack = old.next_m_ack
            self.next_commands.extend(old.next_commands)

    @property
    def backlog(self) -> int:
        """Commands written and not yet delivered to the GEO task (one a cycle)."""
        return len(self.commands) + len(self.next_commands)

    def start_next(self, last: GeoSnapshot | None) -> bool:
        """Whether the command the next `inputs` delivers may be a START (the PLC's, or the
        automatic PLC's continuing after M00)."""
        if self.commands:
            return self.commands[0] is Command.START
        return self.auto is not None and last is not None and last.state is ChannelState.HOLD

    def request(self, cmd: Command) -> None:
        """A command of the loop itself (program repeat, autostart after a reload): once."""
        if cmd not in self.commands:
            self.commands.append(cmd)

    def inputs(self, last: GeoSnapshot | None, t: float, hold_start: bool = False) -> GeoInputs:
        """This cycle's inputs. `hold_start`: a START waits (the loop prepares the program it
        starts, preparer.py); it stays first in line, and the commands after it wait too."""
        base = _IDLE
        if self.auto is not None and not (
            self.plc_stopped and last is not None and last.state is ChannelState.HOLD
        ):
            base = self.auto.inputs(last, t, _NO_SCHEDULE)
        if hold_start:
            if base.command is Command.START:
                base = new_inputs((base.override, base.feed_hold, Command.NONE, base.m_ack))
            if self.commands and self.commands[0] is Command.START:
                ack = self.m_ack or base.m_ack
                self.m_ack = False
                return new_inputs((self.override, self.feed_hold, Command.NONE, ack))
        if self.override == 1.0 and not self.feed_hold and not self.commands and not self.m_ack:
            return base
        command = self.commands.popleft() if self.commands else base.command
        ack = self.m_ack or base.m_ack
        self.m_ack = False
        return new_inputs((self.override, self.feed_hold, command, ack))
