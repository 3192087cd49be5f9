"""CNC parameters as the core sees them: frozen, validated, SI units.

Built from the ISG lists by `liftd.settings`; the core never sees the list files or pydantic.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field

# Every planner uses the axis limits scaled by (1 − PLANNING_MARGIN), so that the sampled
# command positions stay strictly within the limits when differentiated by finite differences
# despite floating-point rounding (seen: 20 ulp of position = 6e-9 of the jerk limit).
PLANNING_MARGIN = 1e-6


class LiftMethod(enum.Enum):
    """Resulting lift method of a channel (activation rules, docs/reference/design.md §3.4)."""

    ADVANCED = "advanced"  # time-based, FCT_LIFT_UP_TIME + P-CHAN-00345 = 1
    LIFTING = "lifting"  # path-based, FCT_LIFT_UP + P-CHAN-00345 = 0
    NONE = "none"


class SlopeType(enum.IntEnum):
    """Path slope profile, P-CHAN-00071 values and #SLOPE[TYPE=..] keywords."""

    STEP = 0  # acceleration-limited (no jerk limit)
    TRAPEZ = 1  # jerk-limited, trapezoidal acceleration
    SIN2 = 2  # sine² acceleration; emulated as jerk-limited like TRAPEZ
    HSC = 3  # HSC slope; not allowed with Advanced Lifting (ID 120711)


class MSync(enum.Enum):
    """Synchronisation type of an M function (P-CHAN-00041 m_synch[i])."""

    NO_SYNCH = 0x0  # not output to the PLC
    MOS = 0x1  # output before motion, no synchronisation
    MVS_SVS = 0x2  # output before the block, motion waits for the acknowledge
    MVS_SNS = 0x4  # output before the block, stop at block end if not acknowledged
    MNS_SNS = 0x8  # output after the motion, wait at block end
    MNE_SNS = 0x20  # output at block end, wait at block end


@dataclass(frozen=True, slots=True)
class AxisParams:
    """One channel axis. Positions in m, velocity m/s, acceleration m/s², jerk m/s³."""

    name: str
    log_axis_nr: int  # P-AXIS-00016 kopf.achs_nr
    v_max: float  # P-AXIS-00212 vb_max
    a_max: float  # P-AXIS-00008 a_max
    j_max: float  # a_max / tr_min (P-AXIS-00201); inf when tr_min = 0
    sw_limit_neg: float  # P-AXIS-00177 swe_neg
    sw_limit_pos: float  # P-AXIS-00178 swe_pos
    dyn_a_warn: float = 0.5  # P-AXIS-00441 as a fraction (500 = 0.5): warning above a_max·(1+x)
    dyn_a_err: float = 1.0  # P-AXIS-00442 as a fraction (1000 = 1.0): error above a_max·(1+x)
    # block transitions (path/limits.py, `TransitionParams`): P-AXIS-00013 and P-AXIS-00154 as
    # fractions (0.1 %: 1000 = 1.0; a_trans_weight 0 = the cycle time / ramp time factor),
    # P-AXIS-00339/00340 in m/s³ (0 = not set: the axis jerk)
    a_trans_weight: float = 0.0
    r_trans_weight: float = 1.0
    j_trans_c0: float = 0.0
    j_trans_c1: float = 0.0


@dataclass(frozen=True, slots=True)
class NcFile:
    """A global subroutine file as the caller resolved it (reading files is IO, outside the
    core): `name` as written after `L` in the program, `path` for messages, `text` or, when
    it could not be found or read, `error` (reported where the program calls it)."""

    name: str
    path: str
    text: str | None = None
    error: str | None = None


@dataclass(frozen=True, slots=True)
class NcSources:
    """The program's display name and the global subroutine files it (transitively) calls,
    read before decoding. Empty for a program without `L` calls."""

    program: str = ""
    files: tuple[NcFile, ...] = ()

    def find(self, name: str) -> NcFile | None:
        for f in self.files:
            if f.name == name:
                return f
        return None


@dataclass(frozen=True, slots=True)
class ChannelParams:
    """One CNC channel as configured by the start-up, channel and axis lists."""

    channel_id: int
    axes: tuple[AxisParams, ...]  # channel order, gruppe[0].achse[j]
    lift_axis: str
    lift_method: LiftMethod
    cycle_time: float  # s, GEO cycle
    lift_min_dist: float = 0.0  # P-CHAN-00244, m; 0 = off
    slope: SlopeType = SlopeType.STEP  # P-CHAN-00071 default profile
    look_ahead_blocks: int = 120  # from P-STUP-00070 / P-CHAN-00650 (+00653)
    max_radius_diff: float = 5e-6  # P-CHAN-00171 max_radius_diff_circle, m
    m_synch: tuple[tuple[int, MSync], ...] = ()
    path_prep_flags: frozenset[str] = field(default_factory=frozenset)
    ipo_flags: frozenset[str] = field(default_factory=frozenset)
    # NC dialect support (issue 19); all optional, the defaults decode plain DIN programs
    tool_radii: tuple[tuple[int, float], ...] = ()  # D number -> tool radius, m (G41/G42)
    # zero-offset groups 0..6 (G53 data block, G54..G59) -> offset per channel axis, m
    zero_offsets: tuple[tuple[int, tuple[float, ...]], ...] = ()
    zero_offset_default: int = 0  # P-ZERO-00002 default_index: group active at program start
    g53_offsets: bool = False  # P-ZERO-00001 g53_verfuegbar: G53 applies group 0 values
    nc_sources: NcSources = field(default_factory=NcSources)
    max_executed_blocks: int = 2_000_000  # expansion bound (subroutines, repetitions)
    # block transitions: P-CHAN-00009 corr_v_trans_jerk (slow down for the jerk at tangential
    # transitions; default off) and P-CHAN-00117 mode_trans_jerk (0, 1: weights; 2: jerks)
    corr_v_trans_jerk: bool = False
    mode_trans_jerk: int = 0

    def axis(self, name: str) -> AxisParams:
        for ax in self.axes:
            if ax.name == name:
                return ax
        raise KeyError(name)

    @property
    def axis_names(self) -> tuple[str, ...]:
        return tuple(ax.name for ax in self.axes)

    @property
    def lift_axis_index(self) -> int:
        return self.axis_names.index(self.lift_axis)

    def m_sync_of(self, number: int) -> MSync | None:
        """The configured synchronisation of M<number>, None if not configured (NOT_VALID)."""
        for num, kind in self.m_synch:
            if num == number:
                return kind
        return None
