"""The ISG dialect CAM systems write (issue 19): subroutines, P parameters and expressions,
zero offsets, G70/G71, tool radius compensation, smoothing commands, and no error cascades.
Every expected value is worked out by hand from the program."""

# `# fmt: skip` where it stays: ruff's one-item-per-line layout of those statements would
# take this file past the house's ~450 lines a file (the others were removed, issue 40)
from __future__ import annotations

import dataclasses
import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from liftd.cnc.nc import DecoderContext, DecodeResult, ErrorId, MotionKind, Severity, decode
from liftd.cnc.nc.decoder import iter_decode
from liftd.cnc.nc.expr import ExprError, compile_text
from liftd.cnc.nc.lexer import LexError, tokenize
from liftd.cnc.nc.words import VALUE_LETTERS, Template, collect, collect_plain, template
from liftd.cnc.params import ChannelParams, LiftMethod, NcFile, NcSources
from tests.support.channel import make_channel

MM = 1e-3


def channel(**kw: object) -> ChannelParams:
    method = kw.pop("method", LiftMethod.ADVANCED)
    ch = make_channel(method=method)  # type: ignore[arg-type]
    return dataclasses.replace(ch, **kw)  # type: ignore[arg-type]


def dec(text: str, files: dict[str, str | None] | None = None, **kw: object) -> DecodeResult:
    sources = NcSources(
        "main.nc",
        tuple(
            NcFile(name, f"/subs/{name}", body, None if body is not None else "not found")
            for name, body in (files or {}).items()
        ),
    )
    ch = channel(nc_sources=sources, **kw)
    return decode(text, DecoderContext.from_channel(ch))


def errors(r: DecodeResult) -> list[tuple[int, int]]:
    return [(e.id, e.line) for e in r.errors if e.severity is Severity.ERROR]


def ok(text: str, files: dict[str, str | None] | None = None, **kw: object) -> DecodeResult:
    r = dec(text, files, **kw)
    assert errors(r) == [], r.errors
    return r


def ends(r: DecodeResult) -> list[tuple[float, ...]]:
    """End points of the motions in mm, rounded to 0.1 µm."""
    return [tuple(round(v / MM, 4) for v in b.motion.end) for b in r.blocks if b.motion]


# -- subroutines --------------------------------------------------------------------------------
LOCAL = """%L hole
N1 G01 X[P1] Y[P2] F3000
N2 G91 X5 Y0
N3 G90
N4 M17
%L slot
N5 G01 X[P1+10] Y[P2]
%main
N10 P1=10 P2=20
N11 LL hole
N12 P1=P1+30
N13 LL hole
N14 LL slot
N15 M30
"""


def test_local_subroutines_run_where_called_and_return() -> None:
    r = ok(LOCAL)
    assert ends(r) == [(10, 20, 0), (15, 20, 0), (40, 20, 0), (45, 20, 0), (50, 20, 0)]
    # blocks carry the line in the file (the subroutine's lines, then the main program's)
    assert [b.line for b in r.blocks] == [2, 3, 2, 3, 7, 14]
    assert r.blocks[-1].program_end
    assert r.executed_lines == 4 * 2 + 1 + 6  # hole body twice, slot once, main 6 lines


def test_global_subroutine_file_with_its_own_local_subroutine() -> None:
    files = {
        "part.nc": "%L edge\nG01 X[P1+20] F6000\nM29\n%part\nG01 X[P1] Y[P2] F6000\nLL edge\n"
        "G01 Y[P2+10]\nM17\n"
    }
    r = ok("P1=100 P2=50\nL part.nc\nP1=200\nL part.nc\nM30\n", files)
    assert ends(r) == [(100, 50, 0), (120, 50, 0), (120, 60, 0), (200, 50, 0), (220, 50, 0),
                       (220, 60, 0)]  # fmt: skip
    assert {b.file for b in r.blocks if b.motion} == {"/subs/part.nc"}
    assert r.blocks[-1].file == ""  # M30 in the program itself


def test_a_byte_order_mark_before_a_program_or_subroutine_file_is_not_a_word() -> None:
    r = ok("\ufeffG01 X10 Y0 F6000\nL part.nc\nM30\n", {"part.nc": "\ufeff%part\nX20\nM17\n"})
    assert ends(r) == [(10, 0, 0), (20, 0, 0)]


def test_l_sequence_repeats_a_block_range() -> None:
    r = ok("G01 X0 F1000\nN10 G91 X1\nN20 Y1\nN30 G90\nL SEQUENCE [N10 N20 REPEAT=3]\nM30\n")
    # N10..N20 once in the program, then three more runs (G91 stays modal from N10)
    assert ends(r)[-1] == (4, 4, 0)
    assert len(ends(r)) == 2 + 6  # (G01 X0 does not move)


def test_subroutine_without_m17_ends_at_the_next_percent_line() -> None:
    r = ok("%L a\nG01 X1 F100\n%L b\nG01 X2\n%main\nLL a\nLL b\nM30\n")
    assert ends(r) == [(1, 0, 0), (2, 0, 0)]


def test_errors_in_a_subroutine_name_file_line_and_call_chain() -> None:
    files = {"inner.nc": "G01 X5 F100\nQ7\nM17\n", "outer.nc": "G01 X1 F100\nL inner.nc\nM17\n"}
    r = dec("N1 G00 X2\nL outer.nc\nM30\n", files)
    (err,) = [e for e in r.errors if e.severity is Severity.ERROR]
    assert (err.id, err.file, err.line, err.column) == (
        ErrorId.UNKNOWN_AXIS,
        "/subs/inner.nc",
        2,
        1,
    )
    assert [(s.file, s.line, s.call) for s in err.chain] == [
        ("main.nc", 2, "L outer.nc"),
        ("/subs/outer.nc", 2, "L inner.nc"),
    ]
    assert "call chain: main.nc:2 L outer.nc > /subs/outer.nc:2 L inner.nc" in err.message
    assert err.located("main.nc").startswith("/subs/inner.nc:2:1: error 990018:")
    # execution stops at the last correctly decoded block
    assert ends(r) == [(2, 0, 0), (1, 0, 0), (5, 0, 0)]


def test_recursion_stops_at_the_nesting_depth_with_20360() -> None:
    r = dec("L self.nc\nM30\n", {"self.nc": "G91 G01 X1 F100\nL self.nc\nM17\n"})
    assert errors(r) == [(ErrorId.CALL_DEPTH, 2)]
    (err,) = [e for e in r.errors if e.severity is Severity.ERROR]
    assert len(err.chain) == 20  # 20 levels below the main program; the 21st call refused
    assert r.executed_lines < 100


def test_a_subroutine_called_many_times_with_an_error_reports_it_once() -> None:
    text = "%L bad\nG01 X1 Q2 F100\nM17\n%main\n" + "LL bad\n" * 500 + "M30\n"
    r = dec(text)
    assert errors(r) == [(ErrorId.UNKNOWN_AXIS, 2)]
    assert r.executed_lines < 520  # after the error each body is checked once


def test_missing_file_is_one_error_at_its_first_call() -> None:
    r = dec("L gone.nc\nG01 X1 F100\nL gone.nc\nM30\n", {"gone.nc": None})
    assert errors(r) == [(ErrorId.FILE_NOT_FOUND, 1)]
    assert "not found" in r.errors[0].message


def test_percent_line_inside_a_global_subroutine_is_21313() -> None:
    # the file's first words start an unnamed program part; its %L line is then inside it
    r = dec("L part.nc\nM30\n", {"part.nc": "G01 X1 F100\n%L late\nM17\n"})
    assert errors(r) == [(ErrorId.PERCENT_IN_SUBROUTINE, 2)]
    assert r.errors[0].file == "/subs/part.nc"


def test_expansion_is_bounded_and_streamed() -> None:
    sub = "%L s\nG91 G01 X0.001 F1000\nG90\nM17\n%m\n"
    text = sub + "L SEQUENCE [N1 N2 REPEAT=1000000]\nN1 LL s\nN2 M00\nM30\n"
    r = dec(text, max_executed_blocks=5000)
    assert errors(r) == [(ErrorId.EXPANSION_LIMIT, 2)] or errors(r)[0][0] == ErrorId.EXPANSION_LIMIT
    assert r.executed_lines == 5001
    stream, decoder = iter_decode("N1 G01 X1 F100\nN2 X2\nM30\n", DecoderContext.from_channel(
        channel()))  # fmt: skip
    first = next(stream)
    assert first.motion is not None and decoder.executed == 1  # one line decoded so far


SUB_ERRORS = [
    ("LL nowhere\n", ErrorId.SUBROUTINE_NOT_FOUND, 1),
    ("%L a\nM17\n%m\nG01 X1 F100 LL a X2\n", ErrorId.WORDS_AFTER_CALL, 4),
    ("%L a\nM17\n%main\nLL a G01 X1\n", ErrorId.WORDS_AFTER_CALL, 4),
    ("L SEQUENCE [N7]\n", ErrorId.SEQUENCE_NOT_FOUND, 1),
    ("G01 X1 F100\n%L a\nM17\n%main\nM30\n", ErrorId.PERCENT_IN_MAIN, 2),
    ("%main\nM30\n%L late\nM17\n", ErrorId.PERCENT_IN_MAIN, 3),
    ("%one\nM30\n%two\nM30\n", ErrorId.PERCENT_IN_MAIN, 3),
    ("%L a\nM17\n%L a\nM17\n%main\nM30\n", ErrorId.DUPLICATE_SUBROUTINE, 3),
    ("%L a\nM17\n", ErrorId.PROGRAM_STRUCTURE, 1),
    ("".join(f"%L s{i}\nM17\n" for i in range(51)) + "%m\nM30\n", ErrorId.TOO_MANY_LOCAL_SUBS, 101),
    ("M29\n", ErrorId.SUBROUTINE_END_OUTSIDE, 1),
]


@pytest.mark.parametrize(("text", "eid", "line"), SUB_ERRORS, ids=lambda v: str(v)[:20])
def test_subroutine_errors(text: str, eid: ErrorId, line: int) -> None:
    r = dec(text)
    assert errors(r)[0] == (eid, line), r.errors


def test_m30_in_a_subroutine_ends_the_program_with_a_warning() -> None:
    r = dec("%L a\nG01 X1 F100\nM30\n%m\nLL a\nG01 X9\n")
    assert errors(r) == []
    assert [(e.id, e.severity) for e in r.errors] == [
        (ErrorId.PROGRAM_END_IN_SUBROUTINE, Severity.WARNING)
    ]
    assert ends(r) == [(1, 0, 0)] and r.blocks[-1].program_end


# -- parameters and expressions ---------------------------------------------------------------
def test_parameters_expressions_and_functions() -> None:
    r = ok(
        "P1 = 20 P2=P1*2+5\n"
        "G01 X[P1*2+5] Y=P2 F[P1*300]\n"
        "XP1*SIN[30] Y[SQRT[16]+ABS[-2]**2]\n"
        "X[ATAN2[1, 1]] Y[INT[7.9] + FRACT[2.25] + ROUND[2.5] + 7 MOD 4]\n"
        "X[P[1]] Y[MIN[P1, 3] + MAX[1, 2] + EXP[0] + LN[1] + LOG[100] + DEXP[1]]\n"
        "X[COS[60]*P1] Y[SQR[3] - TAN[45] + ASIN[1] - ACOS[0] + ATAN[0] + PI - PI]\n"
    )
    assert ends(r) == [
        (45, 45, 0),
        (10, 8, 0),  # 20 * sin 30° = 10; 4 + 2² = 8
        (45, 13.25, 0),  # atan2 in degrees; 7 + 0.25 + 3 + 3 (halves away from zero)
        (20, 18, 0),  # 3 + 2 + 1 + 0 + 2 + 10
        (10, 8, 0),  # cos 60° * 20; 9 - 1 + 90 - 90
    ]
    assert r.blocks[0].motion is not None and r.blocks[0].motion.feed == pytest.approx(0.1)


def test_subroutine_words_from_expressions_set_feed_radius_and_centre() -> None:
    # prepared subroutine lines take F, R, I, J from expressions as well as axes
    r = ok(
        "%L s\nG01\nX[P1] F[P2]\nG02 X[P1+2*P3] Y0 I[P3] J0\nG03 X[P1] R[P3]\nM17\n%main\n"
        "G01 X1 Y0 F100\nP1=5 P2=6000 P3=5\nLL s\nP1=7 P2=1200 P3=6\nLL s\nM30\n"
    )
    feeds = [round(b.motion.feed * 60 / MM) for b in r.blocks if b.motion]
    assert feeds == [100, 6000, 6000, 6000, 1200, 1200, 1200]
    centres = [b.motion.center for b in r.blocks if b.motion and b.motion.center]
    assert [tuple(round(v / MM, 4) for v in c) for c in centres] == [
        (10, 0),
        (10, 0),
        (13, 0),
        (13, 0),
    ]


def test_cos_90_is_exactly_zero_so_dividing_by_it_is_20396() -> None:
    # the vendor's own example of ID 20396 divides by COS[90]
    r = dec("P2=10/COS[90]\n")
    assert errors(r) == [(ErrorId.DIVISION_BY_ZERO, 1)]


EXPR_ERRORS = [
    ("G01 X[P7] F100\n", ErrorId.UNKNOWN_PARAMETER),
    ("P0=1\n", ErrorId.PARAMETER_INDEX),
    ("G01 X[1/0] F100\n", ErrorId.DIVISION_BY_ZERO),
    ("P1=SIN45]\n", ErrorId.BRACKET_AFTER_FUNCTION),
    ("P1=EXP[800]\n", ErrorId.ARITH_OVERFLOW),
    ("P1=10**400\n", ErrorId.ARITH_OVERFLOW),
    ("P1=SQRT[-1]\n", ErrorId.ARITH_DOMAIN),
    ("P1=LN[0]\n", ErrorId.ARITH_DOMAIN),
    ("P1=[1+\n", ErrorId.SYNTAX),
    ("P1=FOO[2]\n", ErrorId.SYNTAX),
    ("Z[LIFT_START POS=[1/0] POS_LIMIT=9]\n", ErrorId.DIVISION_BY_ZERO),
]


@pytest.mark.parametrize(("text", "eid"), EXPR_ERRORS, ids=lambda v: str(v)[:16])
def test_expression_errors(text: str, eid: ErrorId) -> None:
    assert errors(dec(text)) == [(eid, 1)]


def test_deeply_nested_brackets_are_refused_not_a_crash() -> None:
    with pytest.raises(ExprError):
        compile_text("[" * 5000 + "1" + "]" * 5000)
    assert errors(dec("P1=" + "[" * 5000 + "1" + "]" * 5000 + "\n"))[0][0] == ErrorId.SYNTAX


def test_lift_values_take_parameters() -> None:
    r = ok("P5=2 P6=40\nZ[LIFT_START POS=[P5*2] POS_LIMIT=P6]\nG01 X10 F100\nZ[LIFT_END]\n")
    start = r.blocks[0].lift_start
    assert start is not None
    assert (start.target, start.pos_limit) == pytest.approx((4 * MM, 40 * MM))


# -- zero offsets and units ---------------------------------------------------------------------
OFFSETS = ((1, (100 * MM, 50 * MM, 0.0)), (2, (400 * MM, 0.0, 2 * MM)))


def test_zero_offsets_shift_absolute_coordinates_to_machine_coordinates() -> None:
    r = ok(
        "G01 X10 Y10 F1000\n"  # G53 initial: no offset
        "G54 X10 Y10\n"  # applies in its own block
        "G91 X1\n"  # relative: no new offset
        "G90 G55\n"  # selected; takes effect with the next absolute coordinate
        "Y10\n"  # only Y moves: X keeps its machine position
        "X0 Z1\n"
        "G53 X0\n",
        zero_offsets=OFFSETS,
    )
    assert ends(r) == [(10, 10, 0), (110, 60, 0), (111, 60, 0), (111, 10, 0), (400, 10, 3),
                       (0, 10, 3)]  # fmt: skip


def test_g92_sets_or_adds_a_reference_point_offset() -> None:
    r = ok("G92 X10 Z30\nG01 X0 Z0 F100\nG91 G92 X5\nG90 X0\nG92 X0 Z0\nX0\n")
    assert ends(r) == [(10, 0, 30), (15, 0, 30), (0, 0, 30)]


def test_zero_offset_applies_to_lift_pos_and_absolute_centres() -> None:
    r = ok(
        "G55 G01 X10 Y10 Z1 F1000\nZ[LIFT_START POS=1 POS_LIMIT=20]\nG161 G02 X0 Y10 I5 J10\n"
        "Z[LIFT_END]\n",
        zero_offsets=OFFSETS,
    )
    start = r.blocks[1].lift_start
    assert start is not None and (start.target, start.pos_limit) == pytest.approx((3 * MM, 22 * MM))
    arc = r.blocks[2].motion
    assert arc is not None and arc.center == pytest.approx((405 * MM, 10 * MM))


def test_g70_programs_in_inch() -> None:
    r = ok("G70 G01 X1 Y2 F60\nG71 X10\n")
    assert ends(r) == [(25.4, 50.8, 0), (10, 50.8, 0)]
    m = r.blocks[0].motion
    assert m is not None and m.feed == pytest.approx(25.4 * MM)  # 60 inch/min = 1 inch/s


# -- tool radius compensation -------------------------------------------------------------------
TOOLS = ((1, 1 * MM), (2, 2 * MM))
# the contours below are programmed around X0 Y0; G54 (active from the start) puts them at
# X50 Y50 on the machine, inside its software limits; `rel` takes the 50 off again
SHIFT = {"tool_radii": TOOLS, "zero_offsets": ((1, (50 * MM, 50 * MM, 0.0)),),
         "zero_offset_default": 1}  # fmt: skip


def trc(text: str, **kw: object) -> DecodeResult:
    return ok(text, **SHIFT, **kw)


def rel(r: DecodeResult) -> list[tuple[float, ...]]:
    return [(round(x - 50, 4), round(y - 50, 4), z) for x, y, z in ends(r)]


def test_g41_rectangle_inner_corners_and_outer_transition_arcs() -> None:
    # a 20 x 10 rectangle, counter-clockwise, tool left = inside: all corners are inner
    # lead-in along the first edge, lead-out down from the last corner
    r = trc("D1 G00 X-5 Y0\nG41 G01 X0 Y0 F1000\nX20\nY10\nX0\nY0\nG40 X0 Y-5\n")
    assert rel(r) == [(-5, 0, 0), (0, 1, 0), (19, 1, 0), (19, 9, 0), (1, 9, 0), (1, 0, 0),
                      (0, -5, 0)]  # fmt: skip
    # the same rectangle with G42 (tool outside): arcs of radius 1 around each corner
    r = trc("D1 G00 X-5 Y0\nG42 G01 X0 Y0 F1000\nX20\nY10\nX0\nY0\nG40 X0 Y-5\n")
    arcs = [b.motion for b in r.blocks if b.motion and b.motion.center is not None]
    centres = [70 * MM, 50 * MM, 70 * MM, 60 * MM, 50 * MM, 60 * MM]
    assert [v for a in arcs for v in a.center] == pytest.approx(centres)
    assert all(a.kind is MotionKind.ARC_CCW and a.sweep == pytest.approx(math.pi / 2) for a in arcs)
    assert rel(r)[2:4] == [(20, -1, 0), (21, 0, 0)]


def test_arcs_get_the_offset_radius_and_a_radius_too_large_is_90017() -> None:
    r = trc("D2 G01 X0 Y0 F1000\nG41 X10\nG03 X20 Y10 I0 J10\nG40 G01 X30\n")
    arc = next(b.motion for b in r.blocks if b.motion and b.motion.center)
    # CCW with the tool left = inside the arc: radius 10 - 2
    assert math.dist(arc.start[:2], arc.center) == pytest.approx(8 * MM)
    r = dec("D2 G01 X0 Y0 F1000\nG41 X10\nG03 X11 Y1 I0 J1\nG40 G01 X30\n", **SHIFT)
    assert errors(r)[0] == (ErrorId.TRC_RADIUS_TOO_LARGE, 3)


def test_direct_selection_g138_goes_straight_to_the_compensated_start() -> None:
    r = trc("D1 G00 X-5 Y-5\nG138 G41 G01 X0 Y0 F1000\nX20\nG40 Y-5\n")
    assert rel(r)[1] == (0, 1, 0)  # approach ends perpendicular to the first element


def test_full_circle_is_compensated_as_one_circle() -> None:
    # tangential lead-in and lead-out: nothing to trim, the circle stays closed
    r = trc("D1 G00 X20 Y-5\nG41 G01 X20 Y0 F1000\nG03 I-10 J0\nG40 G01 X20 Y5\n")
    arc = next(b.motion for b in r.blocks if b.motion and b.motion.center)
    # CCW with the tool left = inside: radius 9
    assert arc.sweep == pytest.approx(2 * math.pi)
    assert math.dist(arc.start[:2], arc.center) == pytest.approx(9 * MM)
    # radial lead-in (a 90° inner corner): the circle starts and ends at the corner points
    r = trc("D1 G00 X10 Y0\nG41 G01 X20 Y0 F1000\nG03 I-10 J0\nG40 G01 X10 Y0\n")
    arc = next(b.motion for b in r.blocks if b.motion and b.motion.center)
    corner = (10 + math.sqrt(80), 1.0)  # y = 1 (offset of the lead-in) on the radius-9 circle
    assert rel(r)[1][:2] == pytest.approx(corner, abs=1e-4)
    assert arc.sweep == pytest.approx(2 * math.pi - 2 * math.asin(1 / 9))


def test_blocks_without_plane_motion_wait_at_the_corner() -> None:
    r = trc("D1 G01 X0 Y0 F1000\nG41 X10\nM05\nG01 Z1\nY10\nG40 X20\n")
    kinds = [(b.line, b.m_functions, rel(DecodeResult((b,), (), None))) for b in r.blocks]
    # after the approach to the corner point (9, 1), M05 and the Z move run there
    assert kinds[1:4] == [(2, (), [(9, 1, 0)]), (3, (5,), []), (4, (), [(9, 1, 1)])]


def test_side_change_and_radius_change() -> None:
    r = trc("D1 G01 X0 Y0 F1000\nG41 X10\nG42 X20\nG40 X30\n")
    assert rel(r) == [(0, 0, 0), (10, 1, 0), (20, -1, 0), (30, 0, 0)]
    r = dec("D1 G01 X0 Y0 F1000\nG41 X10\nD2 G02 X20 Y0 I5 J0\nG40 X30\n", **SHIFT)
    assert errors(r)[0] == (ErrorId.TRC_RADIUS_CHANGE_ARC, 3)


TRC_ERRORS = [
    ("D1 G01 X0 Y0 F100\nG41 G02 X10 Y0 I5 J0\n", ErrorId.TRC_SELECT_ARC, 2),
    ("D1 G01 X0 Y0 F100\nG41 X10\nG40 G02 X20 Y0 I5 J0\n", ErrorId.TRC_DESELECT_ARC, 3),
    # a notch narrower than the tool: the compensated path would run backwards
    ("D2 G01 X0 Y0 F100\nG41 X10\nY-1\nX11\nY0\nX20\nG40 Y5\n", ErrorId.TRC_CONTOUR_VIOLATION, 3),
    ("D1 G01 X0 Y0 F100\nG41 X10\n" + "M05\n" * 1001, ErrorId.TRC_NON_RELEVANT_BLOCKS, 1003),
]


@pytest.mark.parametrize(("text", "eid", "line"), TRC_ERRORS, ids=lambda v: str(v)[:16])
def test_trc_errors(text: str, eid: ErrorId, line: int) -> None:
    assert errors(dec(text, **SHIFT))[0] == (eid, line)


def test_no_radius_configured_runs_the_programmed_contour_with_one_warning() -> None:
    r = dec("D7 G01 X0 Y0 F100\nG41 X10\nY10\nG40 X0\nG42 X5\nG40 X0\n", **SHIFT)
    assert errors(r) == []
    assert [e.id for e in r.errors] == [ErrorId.TRC_NO_RADIUS]
    assert rel(r) == [(0, 0, 0), (10, 0, 0), (10, 10, 0), (0, 10, 0), (5, 10, 0), (0, 10, 0)]
    assert r.not_emulated == (("G41/G42 without a tool radius (programmed contour)", 2),)


def test_lift_axis_in_the_compensation_plane_is_an_error() -> None:
    ch = make_channel()
    axes = (dataclasses.replace(ch.axes[2], name="Z"), ch.axes[1], dataclasses.replace(
        ch.axes[0], name="X"))  # fmt: skip
    r = dec("D1 G01 Y1 F100\nG41 Y10\nZ[LIFT_START POS_LIMIT=9]\n", tool_radii=TOOLS, axes=axes)
    assert errors(r)[0] == (ErrorId.TRC_LIFT_AXIS, 3)
    r = dec("Z[LIFT_START POS_LIMIT=9]\nD1 G41 G01 Y10 F100\n", tool_radii=TOOLS, axes=axes)
    assert errors(r)[0] == (ErrorId.TRC_LIFT_AXIS, 2)
    # Z outside the G17 plane takes no part: a range inside a compensated contour is fine
    trc("D1 G01 X0 Y0 F100\nG41 X10\nZ[LIFT_START POS=0 POS_LIMIT=9]\nY10\nZ[LIFT_END]\nG40 X0\n")


# -- smoothing ----------------------------------------------------------------------------------
def test_smoothing_runs_unsmoothed_with_one_warning_per_kind() -> None:
    r = ok(
        "#HSC ON [OPMODE 2 PATH_DEV 0.05]\nG01 X1 F100\n#HSC OFF\n#HSC ON\nG261 X2\nG61 X3\n"
        "G260\n#CONTOUR MODE [DEV PATH_DEV=0.1]\n#CONTOUR MODE ON [DEV PATH_DEV=0.1]\n"
        "#CONTOUR MODE OFF\nG151 X4\nG150\n#SPLINE ON\n#SPLINE OFF\n"
    )
    assert ends(r) == [(1, 0, 0), (2, 0, 0), (3, 0, 0), (4, 0, 0)]
    assert [e.id for e in r.errors] == [ErrorId.NOT_EMULATED] * 5
    assert dict(r.not_emulated) == {
        "#HSC ON (HSC smoothing)": 2,
        "G261 (polynomial contouring)": 2,
        "G61 (polynomial contouring)": 1,
        "G151 (spline)": 1,
        "#SPLINE ON": 1,
    }


@pytest.mark.parametrize("method", [LiftMethod.ADVANCED, LiftMethod.LIFTING])
def test_no_smoothing_selected_inside_a_lift_range(method: LiftMethod) -> None:
    # vendor §2.4 (both methods): no additional smoothing of the lift axis in the range
    for select in ("#HSC ON", "G61 X5", "G261", "G151", "#SPLINE ON", "#CONTOUR MODE ON"):
        r = dec(f"G01 X1 F100\nZ[LIFT_START POS_LIMIT=9]\n{select}\nZ[LIFT_END]\n", method=method)
        assert errors(r) == [(ErrorId.SMOOTHING_IN_LIFT_RANGE, 3)], select
    # §2.2.1 (path-based Lifting): not deselected either; Advanced Lifting allows it
    r = dec("#HSC ON\nZ[LIFT_START POS_LIMIT=9]\n#HSC OFF\nZ[LIFT_END]\n", method=method)
    expected = [(ErrorId.SMOOTHING_IN_LIFT_RANGE, 3)] if method is LiftMethod.LIFTING else []
    assert errors(r) == expected
    # active before the range: allowed, suppressed at start and end (here: never smoothed)
    assert errors(dec("#HSC ON\nZ[LIFT_START POS_LIMIT=9]\nX5 F100\nZ[LIFT_END]\n",
                      method=method)) == []  # fmt: skip


# -- no cascades ----------------------------------------------------------------------------------
def test_a_rejected_word_keeps_its_blocks_modal_state() -> None:
    # G18 is rejected, but F, G91 and G01 of its block stay in effect: one error only
    r = dec("G18 G91 G01 X5 F600\nX5\nY5\n")
    assert errors(r) == [(ErrorId.UNSUPPORTED, 1)]
    r = dec("G01 G41 D9 X5 F600 Q1\nX10\nG40 X20\n")
    assert errors(r) == [(ErrorId.UNKNOWN_AXIS, 1)]
    r = dec("G01 X[1/0] F600 G91\nX5\n")  # the feed and G91 survive the bad expression
    assert errors(r) == [(ErrorId.DIVISION_BY_ZERO, 1)]
    r = dec("G01 X$ F600\nX5\n")
    assert errors(r) == [(ErrorId.NUMBER, 1)]


def test_the_issue_program_runs_with_its_documented_warnings_only() -> None:
    text = """%L part_hole
N1 G00 X[P1] Y[P2]
N2 M04
N3 G02 I5 J0 F3000
N4 M05
N5 M17
%nest_0815
N10 G90 G17 G71 G94
N11 #HSC ON [OPMODE 2 PATH_DEV 0.05]
N12 H10 D1
N13 G54
N14 G00 X10 Y10 Z1
N15 M04
N16 G41 G01 X20 Y10 F6000
N17 X60
N18 Y40
N19 X20
N20 Y10
N21 G40 X15 Y5
N22 M05
N23 Z[LIFT_START POS=1 POS_LIMIT=60]
N24 G00 X90 Y20
N25 Z[LIFT_END]
N26 P1=100 P2=20
N27 LL part_hole
N28 M30
"""
    r = dec(text, tool_radii=TOOLS, zero_offsets=OFFSETS)
    assert errors(r) == []
    assert [e.id for e in r.errors] == [ErrorId.NOT_EMULATED]  # #HSC ON, once
    hole = next(b.motion for b in r.blocks if b.motion and abs(b.motion.sweep) > 6)
    assert hole.center == pytest.approx((205 * MM, 70 * MM))  # G54 applies in the subroutine
    assert hole.sweep == pytest.approx(-2 * math.pi)


# -- fuzzing the new syntax -----------------------------------------------------------------------
DIALECT_WORDS = st.sampled_from(
    [
        "G01", "G02", "G03", "G00", "G90", "G91", "G41", "G42", "G40", "G138", "G139",
        "G54", "G55", "G53", "G92", "G70", "G71", "G61", "G261", "G260", "G151",
        "X10", "Y-5.5", "X[P1*2]", "Y[P2/P3]", "XP1", "X=P2*SIN[30]", "F600", "F[P1*100]",
        "I5", "J-5", "R7", "D1", "D2", "D9", "M04", "M05", "M17", "M29", "M30", "N10", "N20",
        "P1=5", "P2=0", "P3=P1-5", "P[P1]=2", "P1=SQRT[P2-1]", "P1=10**400", "P4=ATAN2[1,0]",
        "LL hole", "LL nowhere", "L part.nc", "L self.nc", "L gone.nc",
        "L SEQUENCE [N10 N20 REPEAT=3]", "L SEQUENCE [N99]",
        "Z[LIFT_START POS=[P1] POS_LIMIT=30]", "Z[LIFT_END]", "Z[LIFT POS_LIMIT=P1]",
        "#HSC ON [OPMODE 2]", "#HSC OFF", "#CONTOUR MODE ON", "#FLUSH",
        "%L hole", "%main", "(c)", ";", "[", "]", "=", "2.5", "$IF", "V.G.X",
    ]
)  # fmt: skip
FUZZ_FILES = {
    "part.nc": "%L e\nG91 X1\nG90\nM17\n%part\nG01 X[P1] F100\nLL e\nM17\n",
    "self.nc": "G91 G01 X0.001 F100\nL self.nc\nM17\n",
    "gone.nc": None,
}


@settings(max_examples=300, deadline=None)
@given(st.lists(st.lists(DIALECT_WORDS, max_size=6).map(" ".join), max_size=14).map("\n".join))
def test_dialect_fuzz_never_raises_and_stays_finite(text: str) -> None:
    r = dec(text, FUZZ_FILES, **SHIFT, max_executed_blocks=20_000)
    for b in r.blocks:
        if b.motion is not None:
            assert all(math.isfinite(v) for v in (*b.motion.start, *b.motion.end))
    assert r.executed_lines <= 20_001
    assert all(e.line >= 1 and e.column >= 1 for e in r.errors)


@settings(max_examples=300, deadline=None)
@given(st.text(alphabet="P0123456789.+-*/[], SINCOSQRTABMD=", max_size=40))
def test_expressions_compile_or_say_why(text: str) -> None:
    try:
        expr = compile_text(text)
    except ExprError as exc:
        assert exc.error_id in set(ErrorId)
        return
    try:
        value = expr.value({1: 2.0, 2: 0.0})
    except ExprError as exc:
        assert exc.error_id in set(ErrorId)
        return
    assert math.isfinite(value)


def test_malformed_words_in_prepared_lines_are_reported_every_way() -> None:
    # the same faulty lines in the main program (prepared by their text) and a subroutine
    for text in ("%L s\nM17\n%m\nG01 X1 $ F100\n", "%L s\nG01 X1 $ F100\nM17\n%m\nLL s\n"):
        assert errors(dec(text))[0][0] == ErrorId.SYNTAX, text
    r = dec("%L s\nM17\n%m\nX1 $ LL s\n")  # a call in a line with a lexer error
    assert errors(r)[0] == (ErrorId.SYNTAX, 4)


LINE_WORDS = st.sampled_from(
    [
        "G00", "G01", "G02", "G03", "G90", "G91", "M05", "N7", "X1", "Y-2.5", "Z3", "F100",
        "F0", "R5", "I2", "J-1", "K1", "D1", "X[P1*2]", "Y[P2-1]", "F[P1*10]", "R[P2]",
        "I[P1]", "J[P2/P3]", "D[P1]", "K[P1]", "Q[P1]", "X[P9]", "Z[LIFT_END]", "XP1",
    ]
)  # fmt: skip


@settings(max_examples=400, deadline=None)
@given(st.lists(LINE_WORDS, min_size=1, max_size=6).map(" ".join))
def test_prepared_lines_give_the_words_of_the_general_path(line: str) -> None:
    """The decoder's fast paths (plain words, prepared lines with a tight expression loop)
    must collect what the general path collects; `simple`/`fast_g` only where they hold."""
    axes = frozenset("XYZ")
    params = {1: 2.0, 2: 4.0, 3: 0.0}
    lex_errors: list[LexError] = []
    tokens = tokenize(line, lex_errors)
    general = collect(tokens, axes, dict(params))
    prepared = template(tokens, axes)
    fast = prepared.words(axes, dict(params)) if isinstance(prepared, Template) else prepared
    plain = collect_plain(line, axes)
    for w in (fast, plain):
        if w is None:
            continue
        assert w.values == general.values
        assert (w.gcodes, w.m, w.n) == (general.gcodes, general.m, general.n)
        assert [f.error_id for f in w.faults] == [f.error_id for f in general.faults]
        if w.simple:
            assert not w.gcodes and not w.m and not w.faults and w.lift is None
            assert all(letter in axes for letter in w.values)
        if w.fast_g >= 0:
            assert [g for g, _ in w.gcodes] == [w.fast_g] and w.fast_g <= 3
            assert not w.m and not w.faults and w.lift is None and w.call is None
            assert all(letter in axes or letter in VALUE_LETTERS for letter in w.values)
            assert "K" not in w.values and "D" not in w.values
