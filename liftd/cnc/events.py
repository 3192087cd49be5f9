"""The names of the events a GEO task and its loop emit (`snapshot.Event.name`), one constant
each, and the cycle's `EventLog`. The core emits them, the runtime numbers them in its event
records (`RECORDED`), the daemon logs them. A name is part of the log and trace contract
(docs/architecture.md): change none, add new ones at the end of `RECORDED`."""

from __future__ import annotations

from typing import Final

from liftd.cnc.snapshot import Event, new_event

# the channel (cnc/channel_state.py, cnc/actions.py)
PROGRAM_START: Final = "geo.program_start"
PROGRAM_END: Final = "geo.program_end"
RESUME: Final = "geo.resume"
STOPPED: Final = "geo.stopped"
RESET: Final = "geo.reset"
ERROR: Final = "geo.error"
M_OUTPUT: Final = "geo.m_output"
M_ACK: Final = "geo.m_ack"
M00: Final = "geo.m00"
# the lift (cnc/actions.py, cnc/geo_task.py, cnc/lift/guard.py)
LIFT_START: Final = "lift.start"
LIFT_END: Final = "lift.end"
LIFT_LATE: Final = "lift.late"
LIFT_PATH_WAITS: Final = "lift.path_waits"
LIFT_OVERRIDE_LIMITED: Final = "lift.override_limited"
LIFT_FALLBACK: Final = "lift.fallback"
LIFT_GUARD_CLAMPED: Final = "lift.guard_clamped"
LIFT_Z_ACC_WARNING: Final = "lift.z_acc_warning"
LIFT_Z_ACC_ERROR: Final = "lift.z_acc_error"
LIFT_ABORTED: Final = "lift.aborted"
# the GEO loop (runtime/geo_loop.py)
OVERRUN: Final = "geo.overrun"
COMPUTE_OVER: Final = "geo.compute_over"
REGRID: Final = "geo.regrid"
RELOADED: Final = "geo.reloaded"
PLAN_ERROR: Final = "geo.plan_error"
PLC_INPUT: Final = "geo.plc_input"
PREPARED: Final = "geo.prepared"
RT_SETTING: Final = "geo.rt_setting"
FAULT: Final = "geo.fault"

# The names an event record numbers (runtime/records.py): the id is the index, 0 meaning "the
# name travels in the record's text". The order is the record format: append only.
RECORDED: Final[tuple[str, ...]] = (
    "",
    PROGRAM_START,
    PROGRAM_END,
    RESUME,
    STOPPED,
    RESET,
    ERROR,
    M_OUTPUT,
    M_ACK,
    M00,
    LIFT_START,
    LIFT_END,
    LIFT_LATE,
    LIFT_PATH_WAITS,
    LIFT_OVERRIDE_LIMITED,
    LIFT_FALLBACK,
    LIFT_GUARD_CLAMPED,
    LIFT_Z_ACC_WARNING,
    LIFT_Z_ACC_ERROR,
    OVERRUN,
    COMPUTE_OVER,
    REGRID,
    RELOADED,
    PLAN_ERROR,
    PLC_INPUT,
    LIFT_ABORTED,
)


class EventLog:
    """The events of the current cycle, which every part of a GEO task adds to; the snapshot
    takes them (`items`), the next cycle starts empty (`clear`)."""

    def __init__(self) -> None:
        self.items: list[Event] = []

    def emit(self, name: str, t: float, line: int, value: float = 0.0, text: str = "") -> None:
        self.items.append(new_event((name, t, line, value, text, 0)))

    def clear(self) -> None:
        self.items.clear()
