"""What goes into and comes out of one GEO cycle: inputs from the PLC side, the snapshot."""

from __future__ import annotations

import enum
import functools
from collections.abc import Callable
from typing import NamedTuple, cast


class ChannelState(enum.IntEnum):
    """Channel state, numbered as the KERNELV API enumerates it (isg-cnc.md §2.2)."""

    READY = 3  # no program running
    ACTIVE = 4  # program running
    HOLD = 5  # started, then stopped
    ERROR = 6


class Command(enum.IntEnum):
    """One-shot channel command from the PLC (edge, not level)."""

    NONE = 0
    START = 1  # start the program, continue after STOP or M00
    STOP = 2  # stop at a standstill (HOLD), keep the program
    RESET = 3  # abort the program (at standstill), clear errors


class LiftPhase(enum.IntEnum):
    NONE = 0
    UP = 1
    DOWN = 2
    DONE = 3
    DIRECT = 4
    HOLD_LIMIT = 5
    COUPLED = 6  # path-based Lifting: z = f(s)


class GeoInputs(NamedTuple):
    """PLC-side signals read at the start of a cycle."""

    override: float = 1.0  # requested path override, fraction (0 … 2)
    feed_hold: bool = False
    command: Command = Command.NONE
    m_ack: bool = False  # acknowledges the M function the channel waits for


class Event(NamedTuple):
    """Something that happened in a cycle; becomes a log line / trace note in the drivers."""

    name: str  # stable name, e.g. "geo.m_output", "lift.start", "geo.error"
    t: float  # exact time (s), may lie inside the cycle
    line: int
    value: float = 0.0
    text: str = ""
    channel: int = 0  # logical channel id of a machine of several channels; 0: the only one


class GeoSnapshot(NamedTuple):
    """Everything the GEO task publishes after one cycle. Positions in m, velocity in m/s."""

    cycle: int
    t: float
    state: ChannelState
    line: int  # NC source line of the block being executed
    segment: int  # motion segment index (0-based), = active block
    positions: tuple[float, ...]  # command positions of all channel axes
    v_path: float
    override: float  # in effect (fraction)
    override_requested: float
    override_max: float  # highest override the lift currently accepts
    feed_hold: bool
    lift_active: bool
    lift_suppressed: bool
    lift_phase: LiftPhase
    lift_vz: float  # lift axis command velocity (m/s)
    lift_az: float  # lift axis command acceleration (m/s²)
    m_pending: int  # M function waiting for its acknowledge, -1 for none
    error_id: int
    error_line: int
    events: tuple[Event, ...]
    v_block_max: float = 0.0  # highest path velocity of the active block (m/s), with override
    v_block_end: float = 0.0  # path velocity allowed at the end of the active block (m/s)
    lift_axis: int = -1  # channel axis index of the current (or last) lift range, -1 none yet
    lift_counts: tuple[int, ...] = ()  # lifts started per channel axis since program start


# GeoSnapshot's fields in order, for `new_snapshot`
SnapshotFields = tuple[
    int,
    float,
    ChannelState,
    int,
    int,
    tuple[float, ...],
    float,
    float,
    float,
    float,
    bool,
    bool,
    bool,
    LiftPhase,
    float,
    float,
    int,
    int,
    int,
    tuple[Event, ...],
    float,
    float,
    int,
    tuple[int, ...],
]

# The cycle's constructors: tuple.__new__ in C. Calling the NamedTuple class runs its __new__,
# a Python frame (~0.3 µs of every cycle in the compiled core).
new_snapshot = cast(
    Callable[[SnapshotFields], GeoSnapshot], functools.partial(tuple.__new__, GeoSnapshot)
)
new_inputs = cast(
    Callable[[tuple[float, bool, Command, bool]], GeoInputs],
    functools.partial(tuple.__new__, GeoInputs),
)
new_event = cast(
    Callable[[tuple[str, float, int, float, str, int]], Event],
    functools.partial(tuple.__new__, Event),
)


class LoopStats(NamedTuple):
    """Timing of the GEO loop as the runtime measures it (all zero in simulation)."""

    cycles: int = 0
    exceeded: int = 0  # cycles that finished after their deadline (TwinCAT "exceed counter")
    compute_last_us: float = 0.0
    compute_max_us: float = 0.0
    lateness_last_us: float = 0.0
    lateness_max_us: float = 0.0
    compute_over: int = 0  # cycles whose compute took more than 25 % of the period (runtime)
    # the same on the loop thread's CPU clock: a preemption inside the guest does not count
    # there; its own work, the interrupts it served and (on this VM) the hypervisor's stalls do
    compute_cpu_max_us: float = 0.0
    compute_cpu_over: int = 0


# the GEO loop's per-cycle constructor (runtime/geo_loop.py), as `new_snapshot`
new_loop_stats = cast(
    Callable[[tuple[int, int, float, float, float, float, int, float, int]], LoopStats],
    functools.partial(tuple.__new__, LoopStats),
)


class PlcSignal(enum.IntEnum):
    """A PLC input of the GEO task, written over ADS (objects/) and applied by the runtime."""

    OVERRIDE = 1  # value: fraction 0 … 2
    FEED_HOLD = 2  # value: 0 / 1
    START = 3
    STOP = 4
    RESET = 5
    M_ACK = 6


class PlcWrite(NamedTuple):
    signal: PlcSignal
    value: float = 1.0
    channel: int = 0  # machine index of the channel it is for (0: the first, channel order)
