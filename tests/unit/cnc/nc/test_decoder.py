"""NC decoder: every syntax form, every error id, stop-at-first-error semantics."""

from __future__ import annotations

import dataclasses
import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from liftd.cnc.nc import (
    DecoderContext,
    DecodeResult,
    ErrorId,
    FlushKind,
    LiftEndCause,
    MotionKind,
    Severity,
    decode,
)
from liftd.cnc.params import LiftMethod, SlopeType
from tests.support.channel import make_channel
from tests.support.paths import REPO

MM = 1e-3


def dec(text: str, method: LiftMethod = LiftMethod.ADVANCED, **kw: object) -> DecodeResult:
    ch = make_channel(method=method, **kw)  # type: ignore[arg-type]
    return decode(text, DecoderContext.from_channel(ch))


def ids(result: DecodeResult) -> list[tuple[int, int]]:
    return [(e.id, e.line) for e in result.errors if e.severity is Severity.ERROR]


def ok(text: str, **kw: object) -> DecodeResult:
    r = dec(text, **kw)  # type: ignore[arg-type]
    assert ids(r) == [], r.errors
    return r


# -- basic DIN syntax -------------------------------------------------------------------------
def test_comments_n_numbers_and_modal_words() -> None:
    r = ok(
        "%prog\n"
        "N10 G90 G17 G94 (block (nested) comment) ; rest of line\n"
        "#COMMENT BEGIN\nX999 this is not decoded\n#COMMENT END\n"
        "N20 G01 X10 Y5 F6000 ( unterminated comment runs to the end\n"
        "N30 Y15\n"
        "N40 G91 X1 Y-1\n"
        "N50 G90 G00 X0Y0   ; words need no blanks\n"
    )
    motions = [b.motion for b in r.blocks]
    assert [m.kind if m else None for m in motions] == [MotionKind.LINEAR] * 3 + [MotionKind.RAPID]
    assert motions[0] is not None and motions[0].end == pytest.approx((10 * MM, 5 * MM, 0.0))
    assert motions[0].feed == pytest.approx(0.1)  # 6000 mm/min
    assert motions[1] is not None and motions[1].start == motions[0].end
    assert motions[2] is not None and motions[2].end == pytest.approx((11 * MM, 14 * MM, 0.0))
    assert motions[3] is not None and math.isinf(motions[3].feed)
    assert [b.n for b in r.blocks] == [20, 30, 40, 50]
    assert [b.line for b in r.blocks] == [6, 7, 8, 9]


def test_lower_case_and_equals_sign() -> None:
    r = ok("g01 x=10 f=600\n")
    assert r.blocks[0].motion is not None
    assert r.blocks[0].motion.end[0] == pytest.approx(10 * MM)


def test_arcs_by_centre_radius_and_full_circle() -> None:
    r = ok(
        "G01 X110 Y100 F600\n"
        "G03 X100 Y110 I-10 J0\n"  # quarter CCW around (100, 100)
        "G02 X90 Y100 R10\n"  # R > 0: short arc
        "G02 X110 Y100 R-10\n"  # R < 0 (180° here either way)
        "G03 I-10\n"  # full circle, no end point
        "G161 G02 X100 Y110 I100 J100\n"  # absolute centre
    )
    arcs = [b.motion for b in r.blocks[1:]]
    assert all(a is not None for a in arcs)
    a0, a1, _a2, a3, a4 = arcs  # type: ignore[misc]
    assert a0.center == pytest.approx((0.1, 0.1)) and a0.sweep == pytest.approx(math.pi / 2)
    assert a1.sweep == pytest.approx(-math.pi / 2)
    assert a3.sweep == pytest.approx(2 * math.pi) and a3.end == a3.start
    assert a4.kind is MotionKind.ARC_CW and a4.center == pytest.approx((0.1, 0.1))
    assert a4.sweep == pytest.approx(-3 * math.pi / 2)


def test_radius_sign_selects_the_long_arc() -> None:
    r = ok("G01 X100 Y100 F600\nG03 X110 Y110 R10\nG01 X100 Y100\nG03 X110 Y110 R-10\n")
    short, long_ = r.blocks[1].motion, r.blocks[3].motion
    assert short is not None and long_ is not None
    assert short.sweep == pytest.approx(math.pi / 2)
    assert long_.sweep == pytest.approx(3 * math.pi / 2)


def test_dwell_forms_m_functions_flush_slope_and_end() -> None:
    r = ok(
        "G04 X1.5\nG04 2\nG04 F0.5\n#TIME 0.25\nM04\nM05 M08\n"
        "#FLUSH\n#FLUSH WAIT\n#FLUSH CONTINUE\n#SLOPE [TYPE=SIN2]\n#SLOPE[TYPE=STEP NO_OPT=1]\n"
        "#SLOPE DEFAULT\nM30\nX10 ( after the end: not decoded )\n"
    )
    b = r.blocks
    assert [x.dwell for x in b[:4]] == [1.5, 2.0, 0.5, 0.25]
    assert b[4].m_functions == (4,) and b[5].m_functions == (5, 8)
    assert [x.flush for x in b[6:9]] == [FlushKind.FLUSH, FlushKind.WAIT, FlushKind.CONTINUE]
    assert [x.slope for x in b[9:12]] == [SlopeType.SIN2, SlopeType.STEP, SlopeType.TRAPEZ]
    assert b[12].program_end and len(b) == 13


def test_a_dwell_block_keeps_its_m_functions_lift_command_and_program_end() -> None:
    # they were dropped unchecked: `G04 X1 M30` ran on past the end, M1234 was no error
    r = ok(
        "G01 X1 F600\nZ[LIFT_START POS=1 POS_LIMIT=20]\nG01 X10\nG04 X0.5 M05 Z[LIFT_END]\n"
        "G04 1 M30\nX20\n"
    )
    b = r.blocks
    assert (b[3].dwell, b[3].m_functions, b[3].motion) == (0.5, (5,), None)
    assert b[3].lift_end is not None and b[1].lift_start is not None
    assert b[4].dwell == 1.0 and b[4].program_end and len(b) == 5
    assert ids(dec("G04 0.01 M1234\n")) == [(ErrorId.M_NUMBER_TOO_LARGE, 1)]
    assert ids(dec("G04 X2 M77\n")) == [(ErrorId.M_NOT_CONFIGURED, 1)]


def test_g04_f_is_a_time_not_a_feed_rate() -> None:
    # the lenient G04 F<s> set the modal feed to 0.1 mm/min as well: the next G01 crawled
    b = ok("G01 X1 F6000\nG04 F0.1\nG01 X20\n").blocks
    assert b[1].dwell == 0.1
    assert b[2].motion is not None and b[2].motion.feed == pytest.approx(0.1)  # 6000 mm/min


# -- lift syntax --------------------------------------------------------------------------------
def test_cross_block_lift_with_defaults() -> None:
    r = ok("G01 X10 Z2 F600\nZ[LIFT_START POS_LIMIT=30]\nX20\nX30 Y5\nZ[LIFT_END]\nX40\n")
    start = r.blocks[1].lift_start
    assert start is not None and not start.single_block
    assert (start.z_start, start.target, start.pos_limit, start.down) == pytest.approx(
        (2 * MM, 2 * MM, 30 * MM, False)
    )  # POS defaults to the current command position
    end = r.blocks[4].lift_end
    assert end is not None and end.cause is LiftEndCause.PROGRAMMED and end.start_line == 2
    # the lift axis does not move in the path blocks inside the range
    assert all(
        b.motion is not None and b.motion.start[2] == b.motion.end[2] == 2 * MM
        for b in r.blocks[2:4]
    )


def test_lift_words_with_motion_in_the_same_block() -> None:
    r = ok(
        "G01 X10 F600\nG01 X20 Y5 Z[LIFT_START POS=12 POS_LIMIT=100]\nG01 X30 Z[LIFT_END]\nX40\n"
    )
    b1, b2, b3 = r.blocks[1:]
    assert b1.motion is not None and b1.lift_start is not None
    assert b2.motion is not None and b2.lift_end is not None
    assert b3.motion is not None and b3.motion.start[2] == pytest.approx(12 * MM)


def test_single_block_lift_forms() -> None:
    r = ok(
        "G01 X10 Z40 F600\nX20 Z[LIFT POS=30 POS_LIMIT=300]\nZ[LIFT DOWN POS=25 POS_LIMIT=-2]\n",
        z_limits=(-0.005, 0.5),
    )
    b1, b2 = r.blocks[1:]
    assert b1.lift_start is not None and b1.lift_start.single_block and b1.motion is not None
    assert b1.lift_end is not None and b1.lift_end.cause is LiftEndCause.SINGLE_BLOCK
    assert b2.motion is None and b2.lift_start is not None and b2.lift_start.down
    assert b2.lift_start.z_start == pytest.approx(30 * MM)


def test_g91_pos_and_pos_limit_are_relative_and_non_modal() -> None:
    r = ok(
        "G01 Z10 F600\nZ[LIFT_START G91 POS=-5 POS_LIMIT=20]\nX5\nZ[LIFT_END]\n"
        "Z[LIFT_START POS=3 POS_LIMIT=20]\nX6\nZ[LIFT_END]\n"
    )
    s1 = r.blocks[1].lift_start
    s2 = r.blocks[4].lift_start
    assert s1 is not None and s2 is not None
    assert (s1.target, s1.pos_limit) == pytest.approx((5 * MM, 30 * MM))
    assert (s2.z_start, s2.target, s2.pos_limit) == pytest.approx((5 * MM, 3 * MM, 20 * MM))


def test_parameters_in_any_order_and_blank_before_bracket() -> None:
    r = ok("Z [LIFT_START POS_LIMIT=-4 DOWN G90 POS=-1]\nX1 F100\nZ[LIFT_END]\n")
    s = r.blocks[0].lift_start
    assert s is not None and s.down and s.target == pytest.approx(-MM)


@pytest.mark.parametrize("method", [LiftMethod.ADVANCED, LiftMethod.LIFTING])
def test_flush_in_range_is_a_flush_inside_one_range(method: LiftMethod) -> None:
    """Issue 37 item 2: no implicit LIFT_END + LIFT_START for either method; each lift
    method acts at the flush as its own passage says (vendor §2.1.3 case 3, §2.2.3 case 2)."""
    r = ok("Z[LIFT_START POS=1 POS_LIMIT=40]\nG01 X10 F600\n#FLUSH WAIT\nX20\nZ[LIFT_END]\n",
           method=method)  # fmt: skip
    flush = r.blocks[2]
    assert flush.flush is FlushKind.WAIT and flush.lift_end is None and flush.lift_start is None
    assert [b.lift_start is not None for b in r.blocks].count(True) == 1
    assert [b.lift_end is not None for b in r.blocks].count(True) == 1


def test_flush_continue_does_not_interrupt_the_lift() -> None:
    r = ok("Z[LIFT_START POS_LIMIT=40]\nG01 X10 F600\n#FLUSH CONTINUE\nX20\nZ[LIFT_END]\n")
    assert sum(b.lift_end is not None for b in r.blocks) == 1


def test_program_end_without_lift_end_is_an_implicit_lift_end() -> None:
    r = ok("Z[LIFT_START POS_LIMIT=40]\nG01 X10 F600\nM30\n")
    end = r.blocks[-1]
    assert end.program_end and end.lift_end is not None
    assert end.lift_end.cause is LiftEndCause.PROGRAM_END
    r = ok("Z[LIFT_START POS_LIMIT=40]\nG01 X10 F600\n")  # end of text without M30
    assert r.blocks[-1].lift_end is not None and r.open_lift is None


def test_error_in_range_keeps_blocks_before_it_and_reports_open_lift() -> None:
    r = dec("Z[LIFT_START POS_LIMIT=30]\nG01 X10 F600\nX20\nQ5 syntax error\nX50\nZ[LIFT_END]\n")
    assert ids(r) == [(ErrorId.SYNTAX, 4)]
    assert [b.line for b in r.blocks] == [1, 2, 3]
    assert r.open_lift is not None and r.open_lift.pos_limit == pytest.approx(30 * MM)
    assert r.first_error is not None and r.first_error.line == 4


def test_decoding_continues_after_an_error_to_report_everything() -> None:
    r = dec("G01 X10\nQ1\nZ[LIFT_END]\n")
    assert ids(r) == [
        (ErrorId.FEED_ZERO, 1),
        (ErrorId.UNKNOWN_AXIS, 2),
        (ErrorId.LIFT_NOT_ACTIVE, 3),
    ]
    assert r.blocks == ()


HEADER = "G90 G17 G94\nG00 X20 Y20 Z1\nG01 X100 F6000\n"


@pytest.mark.parametrize(
    ("line", "column"),
    [
        ("G01 X1..2 F6000", 5),  # a CAM post-processor's typo, not X1.0
        ("G01 X1.2.3", 5),  # not X1.2
        ("G01 X=1..2", 5),
        ("G01 X110 Y1.2.3 (comment)", 10),  # the full lexer's path
        ("G01 X110 F1e999", 10),  # an infinite feed
        ("G01 X110 F1e999 (comment)", 10),
        ("G01 X[1..2]", 5),
        ("G01 X[2*1e999]", 5),
        ("P1 = 1e999", 1),
        ("N1e999 G01 X110", 1),  # was an OverflowError out of the decoder
        ("G04 1..2", 5),
        ("Z[LIFT_START POS=1e999 POS_LIMIT=40]", 1),
    ],
)
def test_malformed_or_infinite_number_is_990002_at_its_word(line: str, column: int) -> None:
    r = dec(HEADER + line + "\nG01 X200\nM30\n")
    assert [(e.id, e.line, e.column) for e in r.errors] == [(ErrorId.NUMBER, 4, column)]
    assert [b.line for b in r.blocks] == [2, 3]  # nothing runs from the bad block on


def test_infinite_dwell_and_repeat_count_are_refused_not_run() -> None:
    assert ids(dec("#TIME 1e999\n")) == [(ErrorId.DWELL_MISSING, 1)]
    r = dec("N1 G01 X1 F6\nN2 X2\nL SEQUENCE [N1 N2 REPEAT=1e999]\n")  # was OverflowError
    assert ids(r) == [(ErrorId.NUMBER, 3)]


@pytest.mark.parametrize(
    ("start", "eid", "kw"),
    [
        ("Z[LIFT_START POS=1]", ErrorId.LIFT_POS_LIMIT_MISSING, {}),
        ("Z[LIFT_START POS=-1000 POS_LIMIT=40]", ErrorId.SW_LIMIT_NEG, {}),
        ("Z[LIFT_START POS=1 POS_LIMIT=40]", ErrorId.LIFT_HSC_SLOPE, {"slope": SlopeType.HSC}),
        ("Z[LIFT_START POS_LIMIT=abc]", ErrorId.LIFT_SYNTAX, {}),
        ("Z[LIFT_START POS=1e999 POS_LIMIT=40]", ErrorId.NUMBER, {}),
        ("Z5 Z[LIFT_START POS_LIMIT=40]", ErrorId.AXIS_TWICE, {}),
    ],
)
def test_a_refused_lift_start_is_one_error_not_also_21559_at_its_lift_end(
    start: str, eid: ErrorId, kw: dict[str, object]
) -> None:
    r = dec(HEADER + start + "\nG01 X120\nZ[LIFT_END]\nG01 X130\nM30\n", **kw)  # type: ignore[arg-type]
    assert ids(r) == [(eid, 4)]
    assert r.open_lift is None  # execution stopped before the range: nothing is open


def test_the_range_of_a_refused_lift_start_counts_as_started() -> None:
    bad = HEADER + "Z[LIFT_START POS=1]\nG01 X120\n"  # 990008 in line 4
    r = dec(bad + "Z[LIFT_START POS=1 POS_LIMIT=40]\nZ[LIFT_END]\n")  # no LIFT_END between
    assert ids(r) == [(ErrorId.LIFT_POS_LIMIT_MISSING, 4), (ErrorId.LIFT_ALREADY_ACTIVE, 6)]
    assert "refused LIFT_START in line 4" in r.errors[1].message
    r = dec(bad + "Y[LIFT_END]\n")
    assert ids(r) == [(ErrorId.LIFT_POS_LIMIT_MISSING, 4), (ErrorId.LIFT_AXIS_MISMATCH, 6)]
    r = dec(bad + "Z[LIFT_END]\nZ[LIFT_END]\n")  # the second one closes nothing
    assert ids(r) == [(ErrorId.LIFT_POS_LIMIT_MISSING, 4), (ErrorId.LIFT_NOT_ACTIVE, 7)]


def test_a_refused_single_block_lift_leaves_the_open_range_to_its_lift_end() -> None:
    r = dec(
        HEADER + "Z[LIFT_START POS=1 POS_LIMIT=40]\nX110 Z[LIFT POS=1 POS_LIMIT=40]\n"
        "G01 X120\nZ[LIFT_END]\nM30\n"
    )
    assert ids(r) == [(ErrorId.LIFT_SECOND_START, 5)]  # before: also 21559 in line 7
    assert r.open_lift is not None and r.open_lift.line == 4  # open where execution stops


# -- every error id -------------------------------------------------------------------------------
CASES = [
    ("Z[LIFT_START POS_LIMIT=9]\nZ[LIFT_START POS_LIMIT=9]\n", ErrorId.LIFT_ALREADY_ACTIVE, 2, {}),
    ("Z[LIFT_END]\n", ErrorId.LIFT_NOT_ACTIVE, 1, {}),
    ("Z[LIFT_START POS_LIMIT=9]\nX1 F9 Z[LIFT POS_LIMIT=9]\n", ErrorId.LIFT_SECOND_START, 2, {}),
    ("Z[LIFT_START POS_LIMIT=9]\nY[LIFT_END]\n", ErrorId.LIFT_AXIS_MISMATCH, 2, {}),
    ("Z[LIFT_START POS_LIMIT=9]\n#ROTATION ON\n", ErrorId.LIFT_ROTATION_IN_RANGE, 2, {}),
    ("Z[LIFT_START POS_LIMIT=9]\n#TRAFO OFF\n", ErrorId.LIFT_ROTATION_IN_RANGE, 2, {}),
    ("#SLOPE[TYPE=HSC]\nZ[LIFT_START POS_LIMIT=9]\n", ErrorId.LIFT_HSC_SLOPE, 2, {}),
    ("Z[LIFT_START POS_LIMIT=9]\n#SLOPE[TYPE=HSC]\n", ErrorId.LIFT_HSC_SLOPE, 2, {}),
    ("G01 X10 F100\n#TRANSVELMIN ON [-600]\n", ErrorId.TRANSVELMIN_VALUE, 2, {}),
    ("G01 X10 F100\n#TRANSVELMIN ON [fast]\n", ErrorId.TRANSVELMIN_VALUE, 2, {}),
    ("G01 X10 F100\n#TRANSVELMIN ON 600\n", ErrorId.SYNTAX, 2, {}),
    ("G01 X10\n", ErrorId.FEED_ZERO, 1, {}),
    ("G01 X10 F0\n", ErrorId.FEED_ZERO, 1, {}),
    ("G01 X10 F5 F6\n", ErrorId.DOUBLE_F, 1, {}),
    ("G01 X10 F100\nG02 X10 Y0 R5\n", ErrorId.FULL_CIRCLE_RADIUS, 2, {}),
    ("G04 2 X1\n", ErrorId.DWELL_VALUE_AND_AXIS, 1, {}),
    ("G01 X110 Y100 F100\nG02 X100 Y100 I-4 J0\n", ErrorId.RADIUS_DIFFERENCE, 2, {}),
    ("G01 X3011 F100\n", ErrorId.SW_LIMIT_POS, 1, {}),
    ("G01 X-2 F100\n", ErrorId.SW_LIMIT_NEG, 1, {}),
    ("G01 X1500 Y1509 F100\nG02 I0 J1\n", ErrorId.SW_LIMIT_POS, 2, {}),  # arc bulges out
    ("Z[LIFT_START POS=151 POS_LIMIT=160]\n", ErrorId.SW_LIMIT_POS, 1, {}),
    ("Z[LIFT_START DOWN POS=-6 POS_LIMIT=-2]\n", ErrorId.SW_LIMIT_NEG, 1, {}),
    ("X1 $\n", ErrorId.SYNTAX, 1, {}),
    ("G01 XYZ\n", ErrorId.SYNTAX, 1, {}),
    ("G01 X F100\n", ErrorId.NUMBER, 1, {}),
    ("#COMMENT BEGIN\nX1\n", ErrorId.COMMENT_OPEN, 1, {}),
    ("G18\n", ErrorId.UNSUPPORTED, 1, {}),
    ("G01 X[1+2] F100 Y=V.L.A\n", ErrorId.UNSUPPORTED, 1, {}),
    ("#CS ON[1,2,3,0,0,0]\n", ErrorId.UNSUPPORTED, 1, {}),
    ("#MCS ON\n", ErrorId.UNSUPPORTED, 1, {}),
    ("$IF P1 == 2\n", ErrorId.UNSUPPORTED, 1, {}),
    ("M17\n", ErrorId.SUBROUTINE_END_OUTSIDE, 1, {}),
    ("Z[LIFT_START POS_LIMIT=9]\nG01 X1 Z5 F100\n", ErrorId.LIFT_AXIS_PROGRAMMED, 2, {}),
    (
        "Z[LIFT_START DOWN POS_LIMIT=-1]\n",
        ErrorId.LIFT_DOWN_PATH_BASED,
        1,
        {"method": LiftMethod.LIFTING},
    ),
    ("Z[LIFT_START POS_LIMIT=9]\n", ErrorId.LIFT_NO_METHOD, 1, {"method": LiftMethod.NONE}),
    ("X1 F1\nZ[LIFT_END]\n", ErrorId.LIFT_NO_METHOD, 2, {"method": LiftMethod.NONE}),
    ("Z[LIFT_START POS=5]\n", ErrorId.LIFT_POS_LIMIT_MISSING, 1, {}),
    ("Z[LIFT_START POS=5 POS=6 POS_LIMIT=9]\n", ErrorId.LIFT_SYNTAX, 1, {}),
    ("Z[LIFT_START G90 G91 POS_LIMIT=9]\n", ErrorId.LIFT_SYNTAX, 1, {}),
    ("Z[POS_LIMIT=9 LIFT_START]\n", ErrorId.UNSUPPORTED, 1, {}),
    ("Z[LIFT_START POS_LIMIT=9 HIGH]\n", ErrorId.LIFT_SYNTAX, 1, {}),
    ("Z[LIFT_START POS_LIMIT=abc]\n", ErrorId.LIFT_SYNTAX, 1, {}),
    ("Z[LIFT_END POS=3]\n", ErrorId.LIFT_SYNTAX, 1, {}),
    ("G01 X1 Y2 Y3 F100\n", ErrorId.AXIS_TWICE, 1, {}),
    ("Z5 Z[LIFT_START POS_LIMIT=9]\n", ErrorId.AXIS_TWICE, 1, {}),
    ("G01 G02 X1 F1\n", ErrorId.MOTION_G_TWICE, 1, {}),
    ("G01 G41 X1 G42 F1\n", ErrorId.TRC_G_TWICE, 1, {}),
    ("G70 G71 X1\n", ErrorId.UNIT_G_TWICE, 1, {}),
    ("G161 G02 X1 I1 G162 F1\n", ErrorId.CENTRE_G_TWICE, 1, {}),
    ("G02 X1 Y1 I1 I2 F100\n", ErrorId.WORD_TWICE, 1, {}),
    ("M1001\n", ErrorId.M_NUMBER_TOO_LARGE, 1, {}),
    ("G02 X1 Y1 F100\n", ErrorId.ARC_GEOMETRY, 1, {}),
    ("G02 X10 Y0 R2 F100\n", ErrorId.ARC_GEOMETRY, 1, {}),
    ("G02 X10 Y0 Z5 I5 F100\n", ErrorId.HELIX, 1, {}),
    ("M77\n", ErrorId.M_NOT_CONFIGURED, 1, {}),
    ("G04\n", ErrorId.DWELL_MISSING, 1, {}),
    ("Y[LIFT_START POS_LIMIT=9]\nX5 F100\nZ[LIFT_END]\n", ErrorId.LIFT_AXIS_MISMATCH, 3, {}),
    ("A10\n", ErrorId.UNKNOWN_AXIS, 1, {}),
    ("Q[LIFT_START POS_LIMIT=9]\n", ErrorId.UNKNOWN_AXIS, 1, {}),
]


@pytest.mark.parametrize(
    ("text", "eid", "line", "kw"),
    CASES,
    ids=[str(c[1].name) + f"-{i}" for i, c in enumerate(CASES)],
)
def test_error_ids(text: str, eid: ErrorId, line: int, kw: dict[str, object]) -> None:
    r = dec(text, **kw)  # type: ignore[arg-type]
    assert ids(r)[0] == (eid, line), r.errors
    assert r.errors[0].column >= 1


def test_every_error_id_is_tested() -> None:
    # the warnings are tested below and in tests/unit/cnc/lift/test_path_based.py; the
    # dialect's ids (subroutines, expressions, TRC, smoothing) in test_dialect.py
    from tests.unit.cnc.nc import test_dialect as d  # noqa: PLC0415

    tested = (
        {c[1] for c in CASES}
        | {c[1] for c in d.SUB_ERRORS}
        | {c[1] for c in d.EXPR_ERRORS}
        | {c[1] for c in d.TRC_ERRORS}
        | {
            ErrorId.ZERO_LENGTH,
            ErrorId.DWELL_WITH_AXES,
            ErrorId.LIFT_STEP_SLOPE,
            # test_dialect: one test each
            ErrorId.CALL_DEPTH,  # test_recursion_stops_at_the_nesting_depth_with_20360
            ErrorId.FILE_NOT_FOUND,  # test_missing_file_is_one_error_at_its_first_call
            ErrorId.EXPANSION_LIMIT,  # test_expansion_is_bounded_and_streamed
            ErrorId.PROGRAM_END_IN_SUBROUTINE,  # test_m30_in_a_subroutine_ends_...
            ErrorId.NOT_EMULATED,  # test_smoothing_runs_unsmoothed_with_one_warning_per_kind
            ErrorId.SMOOTHING_IN_LIFT_RANGE,  # test_no_smoothing_selected_inside_a_lift_range
            ErrorId.TRC_NO_RADIUS,  # test_no_radius_configured_runs_the_programmed_contour
            ErrorId.TRC_LIFT_AXIS,  # test_lift_axis_in_the_compensation_plane_is_an_error
            ErrorId.TRC_RADIUS_TOO_LARGE,  # test_arcs_get_the_offset_radius_and_...
            ErrorId.TRC_RADIUS_CHANGE_ARC,  # test_side_change_and_radius_change
            ErrorId.PERCENT_IN_SUBROUTINE,  # test_percent_line_inside_a_global_subroutine_...
            # tests/fidelity/test_s3_programming.py: the vendor's own POS_LIMIT=300 example
            ErrorId.LIFT_LIMIT_CLAMPED,
            # tests/unit/cnc/test_geo_core.py: a lift made late on purpose is reported
            ErrorId.LIFT_LATE,
            # test_generated_programs: one test each
            ErrorId.CENTRE_AND_RADIUS,  # test_a_circle_with_centre_and_radius_is_21024
            ErrorId.CENTRE_OUT_OF_RANGE,  # test_a_circle_centre_beyond_the_data_format_...
            ErrorId.N_TWICE,  # test_two_block_numbers_are_20105
        }
    )
    assert tested == set(ErrorId)


def test_a_wrong_flush_argument_is_a_syntax_error_not_an_unemulated_command() -> None:
    r = dec("#FLUSH FOO\n")
    assert ids(r) == [(ErrorId.SYNTAX, 1)]
    assert r.errors[0].message == "#FLUSH FOO: #FLUSH takes WAIT, CONTINUE or nothing, not FOO"


def test_warnings_do_not_stop_execution() -> None:
    r = dec("G01 X10 F100\nX10\nG04 X1 Y2\nX20\n")
    warn = [(e.id, e.line) for e in r.errors]
    assert warn == [(ErrorId.ZERO_LENGTH, 2), (ErrorId.DWELL_WITH_AXES, 3)]
    assert all(e.severity is Severity.WARNING for e in r.errors)
    assert r.blocks[-1].motion is not None and r.blocks[-1].line == 4


def test_columns_point_at_the_word() -> None:
    r = dec("G01 X10 F100\nG01 X20   Q3\n")
    assert (r.errors[0].line, r.errors[0].column) == (2, 11)


def test_radius_difference_within_p_chan_00171_is_accepted() -> None:
    r = ok("G01 X110 Y100 F100\nG02 X100 Y110.000004 I-10 J0\n")
    m = r.blocks[1].motion
    assert m is not None and m.center is not None
    r0 = math.dist(m.start[:2], m.center)
    r1 = math.dist(m.end[:2], m.center)
    assert abs(r0 - r1) < 1e-12  # centre corrected onto the bisector


def test_exact_arcs_pass_a_zero_radius_tolerance_and_10_nm_off_does_not() -> None:
    ch = dataclasses.replace(make_channel(), max_radius_diff=0.0)  # P-CHAN-00171 = 0
    demo = (REPO / "config" / "programs" / "demo.nc").read_text()
    assert decode(demo, DecoderContext.from_channel(ch)).errors == ()  # rounding is no error
    off = decode(
        "G01 X110 Y100 F100\nG02 X100 Y110.00001 I-10 J0\n", DecoderContext.from_channel(ch)
    )
    assert [(e.id, e.line) for e in off.errors] == [(ErrorId.RADIUS_DIFFERENCE, 2)]
    assert "difference 0.000010 mm > 0.000000 mm" in off.errors[0].message


def test_shipped_demo_program_decodes() -> None:
    r = ok((REPO / "config" / "programs" / "demo.nc").read_text())
    starts = [b.lift_start for b in r.blocks if b.lift_start is not None]
    assert len(starts) == 5 and sum(s.single_block for s in starts) == 1
    assert r.blocks[-1].program_end


WORDS = st.sampled_from(
    [
        "G01",
        "G02",
        "G03",
        "G00",
        "G04",
        "G90",
        "G91",
        "X10",
        "Y-5.5",
        "Z1",
        "F600",
        "I5",
        "J-5",
        "R7",
        "M04",
        "M05",
        "M30",
        "N10",
        "Z[LIFT_START POS=2 POS_LIMIT=30]",
        "Z[LIFT_END]",
        "Z[LIFT POS_LIMIT=20]",
        "#FLUSH",
        "#SLOPE[TYPE=HSC]",
        "(c)",
        ";",
        "[",
        "]",
        "=",
        "2.5",
    ]
)


@settings(max_examples=300, deadline=None)
@given(st.lists(st.lists(WORDS, max_size=6).map(" ".join), max_size=12).map("\n".join))
def test_structured_fuzz_never_raises(text: str) -> None:
    r = dec(text)
    for b in r.blocks:
        if b.motion is not None:
            assert all(math.isfinite(v) for v in b.motion.end)


@settings(max_examples=300, deadline=None)
@given(st.text())
def test_any_text_never_raises(text: str) -> None:
    r = dec(text)
    assert all(e.line >= 1 for e in r.errors if e.severity is Severity.ERROR)


def test_a_refused_feed_is_one_error_not_one_per_following_block() -> None:
    """F0 before any feed: each later G01 reported 'no feed rate' too, and hid a real error
    (a LIFT_END without LIFT_START) behind the cascade. A feed already in effect stays."""
    r = dec("N1 G01 X10 Y10 F0\nN2 G01 X20\nN3 G01 X30 Z[LIFT_END]\nN4 G01 X40\nM30\n")
    assert ids(r) == [(20008, 1), (21559, 3)]
    r = dec("N1 G01 X10 F600\nN2 G01 X20 F0\nN3 G01 X30\nM30\n")
    assert ids(r) == [(20008, 2)]
    assert dec("N1 G01 X10\nN2 G01 X20\nM30\n").errors[0].id == 20008  # none at all: each
