"""What goes into and comes out of one GEO cycle: inputs from the PLC side, the snapshot."""

from __future__ import annotations

import enum
import functools
from collections.abc import Callable
from typing import Annotated, NamedTuple, cast, get_args, get_origin, get_type_hints


class ChannelState(enum.IntEnum):
    """Channel state, numbered as the KERNELV API enumerates it (docs/reference/isg-cnc.md §2.2)."""

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
    """The lift axis's phase in its range: the set-point generator's (lift/advanced.py), COUPLED
    for path-based Lifting."""

    NONE = 0  # no lift under way (the generator idle)
    UP = 1
    DOWN = 2
    DONE = 3  # at the target, at rest
    DIRECT = 4  # time-optimal straight to the target (suppressed, or POS beyond POS_LIMIT)
    HOLD_LIMIT = 5  # program error inside the range: rise to POS_LIMIT and stay
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


class Rec(NamedTuple):
    """How a `GeoSnapshot` field travels in the binary record of a cycle (runtime/records.py)."""

    code: str  # its struct format character; "" for a field the record leaves out
    per_axis: bool = False  # one value per channel axis (an empty tuple packs as zeros)


# The snapshot's one layout: each field's name, type, default and record format in one place.
# `runtime/records.py` builds the record format and pack/unpack from it (`record_layout`); the
# GEO task builds the tuple by position through `new_snapshot`, typed by `SnapshotFields`
# (tests/unit/cnc/test_snapshot_layout.py checks that both follow this class).
class GeoSnapshot(NamedTuple):
    """Everything the GEO task publishes after one cycle. Positions in m, velocity in m/s."""

    cycle: Annotated[int, Rec("q")]
    t: Annotated[float, Rec("d")]
    state: Annotated[ChannelState, Rec("i")]
    line: Annotated[int, Rec("i")]  # NC source line of the block being executed
    segment: Annotated[int, Rec("i")]  # motion segment index (0-based), = active block
    # command positions of all channel axes
    positions: Annotated[tuple[float, ...], Rec("d", per_axis=True)]
    v_path: Annotated[float, Rec("d")]
    override: Annotated[float, Rec("d")]  # in effect (fraction)
    override_requested: Annotated[float, Rec("d")]
    override_max: Annotated[float, Rec("d")]  # highest override the lift currently accepts
    feed_hold: Annotated[bool, Rec("?")]
    lift_active: Annotated[bool, Rec("?")]
    lift_suppressed: Annotated[bool, Rec("?")]
    lift_phase: Annotated[LiftPhase, Rec("i")]
    lift_vz: Annotated[float, Rec("d")]  # lift axis command velocity (m/s)
    lift_az: Annotated[float, Rec("d")]  # lift axis command acceleration (m/s²)
    m_pending: Annotated[int, Rec("i")]  # M function waiting for its acknowledge, -1 for none
    error_id: Annotated[int, Rec("i")]
    error_line: Annotated[int, Rec("i")]
    events: Annotated[tuple[Event, ...], Rec("")]  # travel as event records of their own
    # highest path velocity of the active block (m/s), with override
    v_block_max: Annotated[float, Rec("d")] = 0.0
    # path velocity allowed at the end of the active block (m/s)
    v_block_end: Annotated[float, Rec("d")] = 0.0
    # channel axis index of the current (or last) lift range, -1 none yet
    lift_axis: Annotated[int, Rec("i")] = -1
    # lifts started per channel axis since program start
    lift_counts: Annotated[tuple[int, ...], Rec("I", per_axis=True)] = ()


# GeoSnapshot's field types in order, for `new_snapshot` (mypy checks the GEO task's tuple
# against it; a unit test checks it against the class)
SnapshotFields = tuple[
    int, float, ChannelState, int, int, tuple[float, ...], float, float, float, float, bool,
    bool, bool, LiftPhase, float, float, int, int, int, tuple[Event, ...], float, float, int,
    tuple[int, ...],
]  # fmt: skip # one type per field, in the order of the class above: 5 lines, not 26


def record_layout() -> tuple[tuple[str, Rec, type], ...]:
    """(name, record format, runtime type) of each GeoSnapshot field, in order: the type an
    enum field is made of again when a record is read."""
    hints = get_type_hints(GeoSnapshot, include_extras=True)
    rows = []
    for name in GeoSnapshot._fields:
        hint = hints[name]
        base, rec = get_args(hint)[:2]
        rows.append((name, rec, get_origin(base) or base))
    return tuple(rows)


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
