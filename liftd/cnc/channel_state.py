"""The channel's state machine: its state, the PLC's STOP and RESET requests, the M function
waiting for its acknowledge, and every transition with its event. `GeoTask` asks it what a
command does and does what the transition means for the path and the lift; no other module
sets the channel's state.

The rules (the KERNELV channel states, numbered as `ChannelState`):

* READY --START--> ACTIVE (geo.program_start): a run of the program starts. The READY a RESET
  left (`ready_after_reset`) ends here, and only here: a reload's task takes it over.
* HOLD --START--> ACTIVE (geo.resume). A START in ACTIVE cancels a STOP under way. START does
  nothing in ERROR (only a RESET leaves it) or while a RESET is under way.
* ACTIVE --STOP--> a STOP request; once the path is at rest: HOLD (geo.stopped).
* ACTIVE --M00--> HOLD (geo.m00).
* ACTIVE --the program's end--> READY (geo.program_end); --an NC error--> ERROR (geo.error,
  with its ISG id and line).
* any --RESET--> a RESET request (and a STOP request in ACTIVE: the path brakes); once every
  axis is at rest, the lift axis too: READY (geo.reset), errors and the pending M function
  cleared, `ready_after_reset` set.
* An M function with an acknowledging synchronisation (MVS_SVS, MVS_SNS, MNS_SNS, MNE_SNS) is
  pending (`m_pending`) until the PLC acknowledges it (geo.m_ack); a later wait for it passes
  once it was acknowledged, from the time of that acknowledge.
"""

from __future__ import annotations

from typing import Final

from liftd.cnc import events
from liftd.cnc.events import EventLog
from liftd.cnc.snapshot import ChannelState, Command

# enum members as C statics of the compiled module (a dict and a type lookup each otherwise)
READY: Final = ChannelState.READY
ACTIVE: Final = ChannelState.ACTIVE
HOLD: Final = ChannelState.HOLD
ERROR: Final = ChannelState.ERROR
START: Final = Command.START
STOP: Final = Command.STOP
RESET: Final = Command.RESET


class ChannelStateMachine:
    """One channel's state and the PLC's requests on it (the rules: module docstring)."""

    def __init__(self, log: EventLog) -> None:
        self.log = log
        self.state = READY
        self.runs = 0  # runs started (a START after the first loads the next one)
        self.stop_requested = False  # a PLC STOP under way: HOLD once the path is at rest
        self.reset_requested = False  # a PLC RESET under way: READY once every axis rests
        self.ready_after_reset = False  # READY since a RESET completed, no START since
        self.m_pending = -1  # M function waiting for its acknowledge, -1 for none
        self.m_acked: set[int] = set()  # acknowledged, not yet waited for
        self.ack_time = 0.0  # time of the last acknowledge
        self.error_id = 0
        self.error_line = 0

    def carry_over(self, old: ChannelStateMachine) -> None:
        """A reload's task takes over the channel at READY: the READY a RESET left stands
        (the new task is not started by the reload's autostart either)."""
        self.ready_after_reset = old.ready_after_reset

    # -- the PLC's commands ----------------------------------------------------------------------
    def takes_start(self, cmd: Command) -> bool:
        """Whether a PLC command is a START the channel takes now (not in ERROR, not while a
        RESET is under way: the RESET ends the program first)."""
        return cmd is START and self.state is not ERROR and not self.reset_requested

    def request(self, cmd: Command) -> bool:
        """A STOP or a RESET from the PLC: its request; True for a RESET (the task sends the
        lift of a range it is in to POS_LIMIT)."""
        if cmd is STOP:
            if self.state is ACTIVE:
                self.stop_requested = True
            return False
        if cmd is RESET:
            self.reset_requested = True
            self.stop_requested = self.state is ACTIVE
            return True
        return False

    def program_start(self, t: float, line: int) -> None:
        """READY → ACTIVE: a run starts (the task loaded it)."""
        self.runs += 1
        self.state = ACTIVE
        self.ready_after_reset = False
        self.stop_requested = False
        self.log.emit(events.PROGRAM_START, t, line)

    def resume(self, t: float, line: int) -> None:
        """HOLD → ACTIVE."""
        self.state = ACTIVE
        self.stop_requested = False
        self.log.emit(events.RESUME, t, line)

    def cancel_stop(self) -> None:
        """A START while ACTIVE: a STOP under way is cancelled."""
        self.stop_requested = False

    def stop_due(self, at_rest: bool) -> bool:
        """A STOP completes: its request stands, the path is at rest, no RESET under way."""
        return self.stop_requested and at_rest and self.state is ACTIVE and not self.reset_requested

    def stopped(self, t: float, line: int) -> None:
        """ACTIVE → HOLD, the STOP done."""
        self.stop_requested = False
        self.state = HOLD
        self.log.emit(events.STOPPED, t, line)

    def reset_due(self, at_rest: bool) -> bool:
        """A RESET may complete once the path is at rest (or it was not moving); the lift axis
        must be at rest too (the task's part of the condition)."""
        return self.reset_requested and (at_rest or self.state is not ACTIVE)

    def reset_done(self, t: float, line: int) -> None:
        """→ READY, the RESET done (the task ended the lift first)."""
        self.reset_requested = self.stop_requested = False
        self.state = READY
        self.ready_after_reset = True
        self.error_id = self.error_line = 0
        self.m_pending = -1
        self.log.emit(events.RESET, t, line)

    # -- what the program does -------------------------------------------------------------------
    def may_move(self) -> bool:
        """Whether the path may leave where it rests: ACTIVE, no RESET under way (a resume
        inside a range set the lift rising for the rest of it again)."""
        return self.state is ACTIVE and not self.reset_requested

    def holding(self, feed_hold: bool) -> bool:
        """Whether the path brakes to (or stays at) rest in this cycle."""
        return feed_hold or self.stop_requested or self.state is not ACTIVE

    def m00(self, t: float, line: int) -> None:
        """ACTIVE → HOLD at an M00."""
        self.log.emit(events.M00, t, line)
        self.state = HOLD

    def program_end(self, t: float, line: int) -> None:
        """ACTIVE → READY at the program's end."""
        self.state = READY
        self.log.emit(events.PROGRAM_END, t, line)

    def error(self, t: float, error_id: int, line: int, message: str) -> None:
        """ACTIVE → ERROR: an NC error stops the program."""
        self.state = ERROR
        self.error_id, self.error_line = error_id, line
        self.log.emit(events.ERROR, t, line, float(error_id), message)

    # -- M functions -----------------------------------------------------------------------------
    def new_run(self) -> None:
        """A run is loaded: no M function pending or acknowledged from the last one."""
        self.m_acked.clear()
        self.m_pending = -1

    def m_output(self, t: float, line: int, number: int, acknowledged: bool) -> None:
        """An M function is output; `acknowledged`: it waits for the PLC's acknowledge."""
        self.log.emit(events.M_OUTPUT, t, line, float(number))
        if acknowledged:
            self.m_pending = number
            self.m_acked.discard(number)

    def acknowledge(self, t: float, line: int) -> int:
        """The PLC acknowledges the pending M function (there is one): its number."""
        number = self.m_pending
        self.m_pending = -1
        self.m_acked.add(number)
        self.ack_time = t
        self.log.emit(events.M_ACK, t, line, float(number))
        return number

    def take_ack(self, number: int) -> bool:
        """A wait for M function `number`: whether it was acknowledged (then used up)."""
        if number not in self.m_acked:
            return False
        self.m_acked.discard(number)
        return True
