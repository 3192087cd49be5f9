"""The PLC's commands on a channel (`PlcCommands`, between `LiftAhead` and `GeoTask`): START,
STOP, RESET and the M acknowledge, and how STOP and RESET complete once the axes are at rest.
Changes with the channel's state machine; the cycle itself stays in `geo_task.py`."""

from __future__ import annotations

from typing import Final

from liftd.cnc import events
from liftd.cnc.lift_ahead import LiftAhead
from liftd.cnc.path.program import ActionKind, PathProgram
from liftd.cnc.snapshot import ChannelState, Command, LiftPhase

# enum members as C statics of the compiled module (a dict and a type lookup each otherwise)
READY: Final = ChannelState.READY
ACTIVE: Final = ChannelState.ACTIVE
HOLD: Final = ChannelState.HOLD
ERROR: Final = ChannelState.ERROR
START: Final = Command.START
STOP: Final = Command.STOP
RESET: Final = Command.RESET
HOLD_LIMIT: Final = LiftPhase.HOLD_LIMIT


class PlcCommands(LiftAhead):
    """START, STOP, RESET and the M acknowledge on `GeoTask`'s state."""

    path: PathProgram  # self.prog.path
    runs: int  # runs started (a START after the first loads the next one)
    stop_requested: bool  # a PLC STOP under way: HOLD once the path is at rest
    error_id: int
    error_line: int
    _started: bool  # a START in this cycle: no deferred work in it

    def _load(self, start: tuple[float, ...]) -> None:
        """Load a run of the program from `start`: `GeoTask`'s."""
        raise NotImplementedError

    def _positions(self) -> tuple[float, ...]:
        """The command positions of this cycle: `GeoTask`'s."""
        raise NotImplementedError

    def _start(self, t: float) -> None:
        if self.state is READY:
            if self.runs:
                self._load(self._positions())  # a new run from where the last one ended
                self.z_hold = None  # the new run starts there
            self.runs += 1
            self._started = True
            self.state = ACTIVE
            self.interp.start(t)
            self.waiting = list(self.prog.path.boundaries[0].actions)
            self.wait_since = t
            self._emit(events.PROGRAM_START, t, self.prog.first_line)
        elif self.state is HOLD:
            if self.waiting and self.waiting[0].kind is ActionKind.M00:
                self.waiting.pop(0)
            # a path held at a boundary leaves it no earlier than now: its waits may have
            # ended while it was held (Z arrived, an M function was acknowledged), and left
            # at their time it jumped ahead by the time it was held (a dwell under way
            # starts again)
            self.wait_since = max(self.wait_since, t)
            self.state = ACTIVE
            self._emit(events.RESUME, t, self.line)
        self.stop_requested = False

    def _command(self, cmd: Command, t: float) -> None:
        if cmd is START and self.state is not ERROR and not self.reset_requested:
            self._start(t)  # (a RESET under way ends the program first)
        elif cmd is STOP and self.state is ACTIVE:
            self.stop_requested = True
        elif cmd is RESET:
            if self.lift.current is not None and self.state is not ERROR:
                # the program ends inside a lift range: Z rises to POS_LIMIT and stays, the
                # vendor's reaction to an error in a range (§2.4), never down onto the path
                # it leaves between LIFT_START and LIFT_END
                self.lift.error_in_range(t)
            self.reset_requested = True
            self.stop_requested = self.state is ACTIVE

    def _settle(self, t: float) -> None:
        """STOP and RESET complete once the path is at rest."""
        at_rest = self.interp.v == 0.0 and self.interp.a == 0.0
        if self.stop_requested and at_rest and self.state is ACTIVE and not self.reset_requested:
            self.stop_requested = False
            self.state = HOLD
            self._emit(events.STOPPED, t, self.line)
        lift = self.lift
        if (
            self.reset_requested
            and (at_rest or self.state is not ACTIVE)
            and (
                lift.current is None
                or (
                    not lift.error_pending  # Z still follows the path to rest, then rises
                    and lift.vz == 0.0
                    and lift.az == 0.0
                    # at POS_LIMIT, not at the start of its rise from rest (path-based)
                    and (lift.phase is not HOLD_LIMIT or lift.needed_time() == 0.0)
                )
            )
        ):
            # every axis at rest, the lift axis too: a lift it was in ends where Z is
            # (at POS_LIMIT: `_command`)
            self.reset_requested = self.stop_requested = False
            self.state = READY
            self.error_id = self.error_line = 0
            self.m_pending = -1
            self.waiting = []
            line = self.line
            if lift.current is not None:
                # Z stays there (not the path's Z inside the range) until the next START
                # loads the program from the current positions
                self.z_hold = (lift.axis_index, lift.z)
                lift.abort()
                self._emit(events.LIFT_ABORTED, t, line, self.z_hold[1])
            lift.active = lift.suppressed = False
            self._emit(events.RESET, t, line)

    def _acknowledge(self, number: int, t: float) -> None:
        self.m_pending = -1
        self.m_acked.add(number)
        self.ack_time = t
        self._emit(events.M_ACK, t, self.line, float(number))
        # the dict, not GeoProgram.conditional_for: a Python frame in an M acknowledge's cycle
        for k in self.prog.conditional.get(number, ()):
            self.interp.acknowledge_conditional(k)

    @property
    def line(self) -> int:
        if self.waiting:
            return self.waiting[0].line
        k = self.interp.stopped_at
        if k is not None:
            return self.path.boundaries[k].line or self.prog.first_line
        segs = self.path.segments
        return segs[min(self.interp.segment, len(segs) - 1)].line if segs else 0
