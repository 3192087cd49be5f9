"""Decoded NC blocks and NC errors: what the decoder hands to path preparation.

Positions are absolute, in m, one value per channel axis in channel order; feeds in m/s.
The per-block records are NamedTuples: immutable and cheap to build (decoding 100 000 blocks
must stay under 2 s on a 2-vCPU VM, where a frozen dataclass __init__ alone costs ~2 µs).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import NamedTuple

from liftd.cnc.params import SlopeType


class ErrorId(enum.IntEnum):
    """NC error ids: ISG ids where the vendor documents one, liftd's own (99xxxx) otherwise."""

    # ISG ids (vendor text §2.1.1, §2.3; docs/reference/isg-cnc.md §4.8; TF5200 diagnosis pages)
    LIFT_ALREADY_ACTIVE = 21558  # LIFT already active, LIFT_END expected
    LIFT_NOT_ACTIVE = 21559  # LIFT already deactivated, LIFT_START expected
    LIFT_SECOND_START = 120604  # second lift start while a lift is active
    LIFT_AXIS_MISMATCH = 120605  # LIFT_START and LIFT_END for different axes
    LIFT_ROTATION_IN_RANGE = 120606  # #ROTATION / #TRAFO ON|OFF inside the lift range
    LIFT_HSC_SLOPE = 120711  # HSC slope (type 3) with Advanced Lifting
    FEED_ZERO = 20008  # motion block with feed 0 / no F programmed
    DOUBLE_F = 20175  # more than one F word in a block
    FULL_CIRCLE_RADIUS = 20034  # full circle programmed with R
    DWELL_VALUE_AND_AXIS = 20013  # G04 with a direct value and an axis
    DWELL_WITH_AXES = 20685  # warning: other axes programmed in the G04 block
    RADIUS_DIFFERENCE = 21758  # radius difference start/end exceeds P-CHAN-00171
    # circles (tf5200_diagnosis/253243787 "Circle centre point and radius are not permitted at
    # the same time"; 250663051 "Corrected centre point out of data format")
    CENTRE_AND_RADIUS = 21024  # I/J and R in one circle block
    CENTRE_OUT_OF_RANGE = 20054  # the circle's centre beyond the position data format
    # Software-limit messages of path preparation (the ids MCV_SuppressSoftLimSw lists,
    # https://infosys.beckhoff.com/content/1033/tccncmcplatform_fb/15306250379.html;
    # which of the two is positive/negative is our assumption).
    SW_LIMIT_POS = 50041
    SW_LIMIT_NEG = 50042
    # subroutines (TF5200 diagnosis pages tf5200_diagnosis/255123851, 251402891, 251420299)
    WORDS_AFTER_CALL = 21542  # further NC words after an L / LL call in its block
    CALL_DEPTH = 20360  # subroutine stack overflow (nesting too deep, endless recursion)
    TOO_MANY_LOCAL_SUBS = 20365  # more %L definitions than P-STUP-00053 allows (50)
    # expressions (tf5200_diagnosis/251507339, 253008779, 251524747, 251494283)
    DIVISION_BY_ZERO = 20396
    UNKNOWN_PARAMETER = 20925  # P parameter read before it was written
    PARAMETER_INDEX = 20400  # P parameter number 0, negative or too large
    BRACKET_AFTER_FUNCTION = 20387  # SIN45 instead of SIN[45]
    # tool radius compensation (tf5200_diagnosis/261625739, 261660555, 261725835; tccncdiagnosis
    # ID-range 90000-90249)
    TRC_SELECT_ARC = 90008  # TRC selected with a circular block (approach must be linear)
    TRC_NON_RELEVANT_BLOCKS = 90011  # too many blocks without plane motion while TRC is active
    TRC_RADIUS_TOO_LARGE = 90017  # tool radius >= radius of an (inner) arc of the contour
    TRC_RADIUS_CHANGE_ARC = 90047  # tool radius changed right before a circular block
    # words and G groups twice in a block, program structure, M functions (issue 15 item 7:
    # the ids a PLC checks; tf5200_diagnosis/251085195, 250789259, 250815371, 250832779,
    # 250871947, 251054731, 254175115, 250945931)
    AXIS_TWICE = 20203  # an axis programmed twice in one block ("Double-programmed axis")
    MOTION_G_TWICE = 20108  # two of G00/G01/G02/G03 in one block ("block mode")
    TRC_G_TWICE = 20114  # two of G40/G41/G42 in one block
    UNIT_G_TWICE = 20118  # G70 and G71 in one block
    CENTRE_G_TWICE = 20127  # G161 and G162 in one block
    PERCENT_IN_MAIN = 20193  # a % line inside the main program part (%L after it, 2nd main)
    PERCENT_IN_SUBROUTINE = 21313  # the same inside a global subroutine file
    M_NUMBER_TOO_LARGE = 20160  # M above the numbers P-CHAN-00041 can define (>= 1000)
    N_TWICE = 20105  # two block numbers N in one block (tf5200_diagnosis/250776203)
    # liftd's own ids
    SYNTAX = 990001  # unknown character or word
    NUMBER = 990002  # missing or malformed number
    COMMENT_OPEN = 990003  # #COMMENT BEGIN without #COMMENT END
    UNSUPPORTED = 990004  # valid ISG, not emulated by liftd
    LIFT_AXIS_PROGRAMMED = 990005  # lift axis programmed inside a lift range
    LIFT_DOWN_PATH_BASED = 990006  # DOWN with path-based Lifting (vendor §2.2)
    LIFT_NO_METHOD = 990007  # lift command but no lift method enabled in the lists
    LIFT_POS_LIMIT_MISSING = 990008  # POS_LIMIT is mandatory
    LIFT_SYNTAX = 990009  # malformed lift command
    ZERO_LENGTH = 990010  # warning: motion block without motion
    HELIX = 990011  # circle with motion outside the plane
    ARC_GEOMETRY = 990012  # circle cannot be constructed
    WORD_TWICE = 990013  # I, J, K, R or D programmed twice in one block
    M_NOT_CONFIGURED = 990014  # M function without m_synch entry
    # 990015 retired: DOWN with POS_LIMIT above start and target is special case 1 (issue 15)
    DWELL_MISSING = 990016  # G04 without a time
    # 990017 retired: any axis of the channel may lift (issue 18); others are UNKNOWN_AXIS
    UNKNOWN_AXIS = 990018  # address letter that is not an axis of the channel
    LIFT_STEP_SLOPE = 990019  # warning: STEP slope with path-based Lifting (Z overload)
    SUBROUTINE_NOT_FOUND = 990020  # LL name: no %L name in the file
    FILE_NOT_FOUND = 990021  # L file: not found in the search path or not readable
    SUBROUTINE_END_OUTSIDE = 990022  # M17 / M29 outside a subroutine
    PROGRAM_END_IN_SUBROUTINE = 990023  # warning: M02 / M30 in a subroutine ends the program
    PROGRAM_STRUCTURE = 990024  # NC words before the program's % line, no main program ...
    EXPANSION_LIMIT = 990025  # more executed blocks than liftd prepares (max_executed_blocks)
    NOT_EMULATED = 990026  # warning: accepted, runs approximated (e.g. unsmoothed)
    SMOOTHING_IN_LIFT_RANGE = 990027  # smoothing selected inside a lift range (vendor §2.4)
    TRC_NO_RADIUS = 990028  # warning: G41/G42 without a configured radius, programmed contour
    TRC_LIFT_AXIS = 990029  # the lift axis takes part in TRC during a lift range (vendor §2.4)
    ARITH_OVERFLOW = 990030  # expression result not finite
    ARITH_DOMAIN = 990031  # function argument outside its domain (SQRT[-1], LN[0])
    TRC_CONTOUR_VIOLATION = 990032  # the compensated path runs against the contour
    TRC_DESELECT_ARC = 990033  # TRC deselected with a circular block (retract must be linear)
    SEQUENCE_NOT_FOUND = 990034  # L SEQUENCE: block number not found
    DUPLICATE_SUBROUTINE = 990035  # %L name defined twice in a file
    LIFT_LIMIT_CLAMPED = 990036  # warning: POS_LIMIT beyond the software limit, held there
    LIFT_LATE = 990037  # the path passed LIFT_END with the lift axis not at POS (never expected)
    # #TRANSVELMIN ON [v] with a negative or non-numeric v: the programming manual documents
    # the command but no error id for it (tf5200_programming_manual/207486091.html)
    TRANSVELMIN_VALUE = 990038


class Severity(enum.Enum):
    ERROR = "error"
    WARNING = "warning"


class NcFault(Exception):
    """Raised inside the decoder for one block; becomes an NcError with the line."""

    def __init__(self, error_id: ErrorId, column: int, message: str) -> None:
        super().__init__(message)
        self.error_id = error_id
        self.column = column
        self.message = message


@dataclass(frozen=True, slots=True)
class CallSite:
    """Where a subroutine was called: file, line, and the call as written."""

    file: str
    line: int
    call: str  # "LL part_hole", "L hole.nc", "L SEQUENCE [N10 N20]"

    def __str__(self) -> str:
        return f"{self.file}:{self.line} {self.call}"


def chain_text(chain: tuple[CallSite, ...]) -> str:
    """`a.nc:3 LL x > b.nc:7 L y`, repeated calls folded: `b.nc:4 LL again (×20)`."""
    parts: list[str] = []
    last = ""
    count = 0
    for site in chain:
        text = str(site)
        if text == last:
            count += 1
            continue
        if last:
            parts.append(last if count == 1 else f"{last} (×{count})")
        last, count = text, 1
    parts.append(last if count == 1 else f"{last} (×{count})")
    return " > ".join(parts)


@dataclass(frozen=True, slots=True)
class NcError:
    id: int
    line: int  # 1-based source line (in `file`)
    column: int  # 1-based column of the offending word
    message: str  # inside a subroutine it ends with the call chain
    severity: Severity = Severity.ERROR
    file: str = ""  # the program or subroutine file the line is in ("" = the program)
    chain: tuple[CallSite, ...] = ()  # outermost call first; () in the main program

    def __str__(self) -> str:
        return f"{self.line}:{self.column}: {self.severity.value} {self.id}: {self.message}"

    def located(self, program: str) -> str:
        """`file:line:col: severity id: message`, the file defaulting to `program`."""
        return f"{self.file or program}:{self}"


class MotionKind(enum.Enum):
    RAPID = "G00"
    LINEAR = "G01"
    ARC_CW = "G02"
    ARC_CCW = "G03"


class Motion(NamedTuple):
    kind: MotionKind
    start: tuple[float, ...]  # m, every channel axis
    end: tuple[float, ...]
    feed: float  # m/s programmed (F); inf for G00 (axis limits only)
    center: tuple[float, float] | None = None  # arcs: centre in the G17 plane (axes 0, 1), m
    sweep: float = 0.0  # arcs: signed angle, rad (CCW positive); ±2π for a full circle


class FlushKind(enum.Enum):
    FLUSH = "#FLUSH"
    WAIT = "#FLUSH WAIT"
    CONTINUE = "#FLUSH CONTINUE"


class LiftEndCause(enum.Enum):
    PROGRAMMED = "LIFT_END"
    SINGLE_BLOCK = "LIFT"
    PROGRAM_END = "program end"  # implicit LIFT_END at the end (vendor §2.4)


class LiftStart(NamedTuple):
    """Start of a lift range; takes effect at the beginning of its block's motion."""

    axis: str
    z_start: float  # programmed lift-axis position at the start, m
    target: float  # POS, absolute, m (default: the current command position)
    pos_limit: float  # POS_LIMIT, absolute, m
    down: bool
    line: int  # line of the programmed LIFT_START / LIFT
    single_block: bool = False
    # POS_LIMIT as programmed when it lies beyond the software limit and `pos_limit` is the
    # limit instead (issue 15 item 3); None when programmed within the limits
    limit_programmed: float | None = None


class LiftEnd(NamedTuple):
    """End of a lift range; takes effect at the end of its block's motion."""

    axis: str
    cause: LiftEndCause
    start_line: int


class Block(NamedTuple):
    line: int  # 1-based source line (of `file` when the block comes from a subroutine)
    n: int | None = None
    motion: Motion | None = None
    dwell: float | None = None  # s (G04, #TIME)
    m_functions: tuple[int, ...] = ()
    flush: FlushKind | None = None
    slope: SlopeType | None = None
    lift_start: LiftStart | None = None
    lift_end: LiftEnd | None = None
    program_end: bool = False  # M02 / M30
    file: str = ""  # "" = the main program; else the subroutine file the line is in
    trans_vel_min: float | None = None  # #TRANSVELMIN: m/s from here on (0: OFF, or ON alone)


@dataclass(frozen=True, slots=True)
class DecodeResult:
    """Blocks decoded before the first error (the vendor's "last correctly decoded point"),
    plus every error and warning found in the whole text."""

    blocks: tuple[Block, ...]
    errors: tuple[NcError, ...]
    open_lift: LiftStart | None  # a lift range still open where execution stops
    # what the program uses that liftd accepts but runs approximated, with how many blocks:
    # ("#HSC ON", 3), ("G41/G42 without a tool radius", 1) ...
    not_emulated: tuple[tuple[str, int], ...] = ()
    executed_lines: int = 0  # NC lines executed, subroutine bodies counted per call

    @property
    def first_error(self) -> NcError | None:
        return next((e for e in self.errors if e.severity is Severity.ERROR), None)
