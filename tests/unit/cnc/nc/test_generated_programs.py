"""NC programs generated, not hand-picked: CAM-like valid programs (G00-G03 with I/J or R, F,
M, S, N, comments, blank lines, P parameters, lift ranges back to back, dwells, #FLUSH), the
same programs in other spellings, and mutations of them. What a user relies on: a valid
program decodes without errors and to the same blocks however it is spaced, cased or
commented; a broken line is reported with an id at its own line; the decoder never raises.

Bounded and deterministic (derandomised, no example database): a few seconds in CI."""

from __future__ import annotations

import math
from dataclasses import dataclass

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from liftd.cnc.nc import DecoderContext, DecodeResult, ErrorId, Severity, decode
from tests.support.channel import make_channel

CTX = DecoderContext.from_channel(make_channel())
FAST = settings(
    max_examples=100,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow],
)


def dec(text: str) -> DecodeResult:
    return decode(text, CTX)


def errors(r: DecodeResult) -> list[tuple[int, int]]:
    return [(e.id, e.line) for e in r.errors if e.severity is Severity.ERROR]


def blocks(r: DecodeResult) -> list[tuple[object, ...]]:
    """What a block does, without where it is written (its line)."""
    return [
        (
            b.n,
            b.motion,
            b.dwell,
            b.m_functions,
            b.flush,
            b.slope,
            b.lift_start._replace(line=0) if b.lift_start else None,
            b.lift_end._replace(start_line=0) if b.lift_end else None,
            b.program_end,
        )
        for b in r.blocks
    ]


# -- a generated program: one block per entry, each a list of words -------------------------
@dataclass(frozen=True)
class Program:
    blocks: tuple[tuple[str, ...], ...]  # words of each NC block (the % line not included)

    def text(self, style: Style) -> str:
        out = ["%job"]
        for k, words in enumerate(self.blocks):
            out.extend(style.before(k))
            out.append(style.line(k, words))
        return "\n".join(out) + style.end


@dataclass(frozen=True)
class Style:
    """How a program is written: separators, case, `=`, comments and blank lines."""

    sep: str = " "
    lower: bool = False
    equals: bool = False
    comment_after: str = ""  # appended to each block: " (c)", " ; c", "(a(b)c)"
    blank_every: int = 0  # an empty or comment-only line before every n-th block
    filler: str = ""
    end: str = "\n"

    def before(self, k: int) -> list[str]:
        return [self.filler] if self.blank_every and k % self.blank_every == 0 else []

    def line(self, k: int, words: tuple[str, ...]) -> str:
        shown = []
        for word in words:
            w = word[0] + "=" + word[1:] if self.equals and word[0] in "XYFIJR" else word
            shown.append(w.lower() if self.lower and "[" not in w else w)
        return self.sep.join(shown) + self.comment_after


def num(lo: float, hi: float) -> st.SearchStrategy[float]:
    return st.integers(round(lo * 1000), round(hi * 1000)).map(lambda v: v / 1000)


def fmt(v: float) -> str:
    return f"{v:.3f}".rstrip("0").rstrip(".") or "0"


@st.composite
def programs(draw: st.DrawFn) -> Program:
    """A CAM-like job on the test channel (X 0..3000, Y 0..1500, Z -5..150 mm): rapid to a
    pierce point, cut lines and arcs (I/J or R, computed to end on the circle), laser M4/M5,
    lifts over the travels (some back to back, some single-block), dwells and flushes."""
    x, y = draw(num(10, 100)), draw(num(40, 100))  # arcs stay above Y 0
    out: list[tuple[str, ...]] = [("G90", "G17", "G94"), ("G00", f"X{fmt(x)}", f"Y{fmt(y)}", "Z1")]
    n = 10
    for _ in range(draw(st.integers(1, 5))):
        n += 10
        out.append((f"N{n}", "M4", f"S{draw(st.integers(100, 4000))}"))
        for _ in range(draw(st.integers(1, 4))):
            kind = draw(st.sampled_from(["line", "ij", "r", "dwell", "param"]))
            f = f"F{draw(st.integers(600, 12000))}"
            if kind == "line":
                x, y = x + draw(num(0, 30)), y + draw(num(0, 30))
                out.append(("G01", f"X{fmt(x)}", f"Y{fmt(y)}", f))
            elif kind == "ij":  # a half circle around a centre i to the right
                i = draw(num(1, 20))
                g = draw(st.sampled_from(["G02", "G03"]))
                out.append((g, f"X{fmt(x + 2 * i)}", f"Y{fmt(y)}", f"I{fmt(i)}", "J0", f))
                x += 2 * i
            elif kind == "r":
                dx = draw(num(1, 20))
                # rounded up to the 3 decimals written: R1.137 for a chord of 2.275 is too short
                r = math.ceil((dx / 2 + draw(num(0, 10))) * 1000) / 1000
                sign = draw(st.sampled_from(["", "-"]))
                out.append(("G02", f"X{fmt(x + dx)}", f"Y{fmt(y)}", f"R{sign}{fmt(r)}", f))
                x += dx
            elif kind == "dwell":  # G04 <s>, G04 X<s> or G04 P<n> (TF5200 dwell time)
                t = fmt(draw(num(0.01, 0.5)))
                form = draw(st.sampled_from(["direct", "axis", "param"]))
                if form == "param":
                    out.append((f"P2={t}",))
                out.append(("G04", {"direct": t, "axis": f"X{t}", "param": "P2"}[form]))
            else:
                out.append(("P1=" + fmt(draw(num(1, 9))),))
                out.append(("G01", "X[P1+" + fmt(x) + "]", f))
                out.append(("G01", f"X{fmt(x)}"))
        out.append(("M5",))
        lift = draw(st.sampled_from(["range", "single", "back_to_back", "flush", "none"]))
        limit = f"POS_LIMIT={draw(st.integers(20, 100))}"
        x, y = x + draw(num(5, 50)), y + draw(num(5, 50))
        if lift == "single":
            out.append(("G00", f"X{fmt(x)}", f"Y{fmt(y)}", f"Z[LIFT POS=1 {limit}]"))
            continue
        if lift == "none":
            out.append(("G00", f"X{fmt(x)}", f"Y{fmt(y)}"))
            continue
        out.append(("Z[LIFT_START POS=1 " + limit + "]",))
        out.append(("G00", f"X{fmt(x)}"))
        if lift == "flush":
            out.append(("#FLUSH WAIT",))
        if lift == "back_to_back":
            out.append(("G00", f"Y{fmt(y)}", "Z[LIFT_END]"))
            out.append(("Z[LIFT_START POS=1 " + limit + "]",))
            x += 5
            out.append(("G00", f"X{fmt(x)}"))
        out.append(("G00", f"Y{fmt(y)}", "Z[LIFT_END]"))
    out.append(("M30",))
    return Program(tuple(out))


STYLES = st.builds(
    Style,
    sep=st.sampled_from([" ", "  ", "\t", " \t "]),
    lower=st.booleans(),
    equals=st.booleans(),
    comment_after=st.sampled_from(["", " (c)", " ; c", "(a (nested) b)", " ( open to the end"]),
    blank_every=st.integers(0, 3),
    filler=st.sampled_from(["", "   ", "(comment line)", "; comment line", "\t"]),
    end=st.sampled_from(["\n", "", "\r\n"]),
)


def crlf(text: str) -> str:
    return text.replace("\n", "\r\n")


@FAST
@given(programs(), STYLES)
def test_a_generated_valid_program_decodes_the_same_however_it_is_written(
    prog: Program, style: Style
) -> None:
    plain = dec(prog.text(Style()))
    assert errors(plain) == [], (prog.text(Style()), plain.errors)
    text = prog.text(style)
    other = dec(text)
    assert errors(other) == [], (text, other.errors)
    assert blocks(other) == blocks(plain), text
    assert blocks(dec(crlf(text))) == blocks(plain)
    # the block's line is where it is written, whatever lies before it
    lines = text.split("\n")
    for b in other.blocks:
        if b.n is not None:
            assert f"N{b.n}" in lines[b.line - 1].upper(), (text, b)


# -- mutations: one line broken, the error at that line -----------------------------------------
BREAKS = [
    # (what replaces the block, id): each one is an error wherever it is written
    (lambda ws: (*ws, "5"), ErrorId.SYNTAX),  # a lost address letter: G01 X10 5 (see below)
    (lambda ws: (*ws, "Q1"), ErrorId.UNKNOWN_AXIS),
    (lambda ws: (*ws, "X1..2"), ErrorId.NUMBER),
    (lambda ws: (*ws, "F1e999"), ErrorId.NUMBER),
    (lambda ws: (*ws, "N1", "N2"), ErrorId.N_TWICE),
    (lambda ws: ("G01", "X10", "Y10", "X11", "F600"), ErrorId.AXIS_TWICE),
    (lambda ws: ("G02", "X10", "Y10", "I5", "R5", "F600"), ErrorId.CENTRE_AND_RADIUS),
    (lambda ws: ("G02", "X10", "Y10", "R1e300", "F600"), ErrorId.CENTRE_OUT_OF_RANGE),
    (lambda ws: ("G02", "X10", "Y10", "I-1e300", "F600"), ErrorId.CENTRE_OUT_OF_RANGE),
    (lambda ws: (*ws, "\x0c"), ErrorId.SYNTAX),  # a form feed is no NC separator
    (lambda ws: (*ws, "\xa0", "X1"), ErrorId.SYNTAX),  # nor a no-break space
    (lambda ws: (*ws, "M1234"), ErrorId.M_NUMBER_TOO_LARGE),
    (lambda ws: ("Z[LIFT_END]",), None),  # 21559 here, or at the range's own end later
]


@FAST
@given(programs(), STYLES, st.data())
def test_a_broken_line_is_reported_at_that_line(
    prog: Program, style: Style, data: st.DataObject
) -> None:
    # a word block: a #-directive with a word appended is another error (990001; the vendor
    # documents 20450 for it, not emulated)
    words = [j for j in range(1, len(prog.blocks) - 1) if not prog.blocks[j][0].startswith("#")]
    k = data.draw(st.sampled_from(words), label="block")
    change, eid = data.draw(st.sampled_from(BREAKS), label="break")
    broken = Program((*prog.blocks[:k], change(prog.blocks[k]), *prog.blocks[k + 1 :]))
    text = broken.text(style)
    r = dec(text)
    # the broken block's line: where a marker written in its place is
    marker = Program(tuple(("MARK",) if j == k else b for j, b in enumerate(broken.blocks)))
    line = marker.text(style).split("\n").index(style.line(k, ("MARK",))) + 1
    first = r.first_error
    if broken.blocks[k][-1] == "5" and "G04" in broken.blocks[k] and "X" in "".join(prog.blocks[k]):
        eid = ErrorId.DWELL_VALUE_AND_AXIS  # G04 X0.2 5: a time given twice, 20013
    if eid is None:  # a range closed early: the range's own LIFT_END is 21559, later
        assert first is None or first.line >= line, (text, r.errors)
        return
    assert first is not None, text
    assert (first.id, first.line) == (eid, line), (text, r.errors)
    assert all(b.line < line for b in r.blocks), text  # execution stops before it


# -- any text: never an exception, errors inside the text, finite positions ----------------------
GARBAGE = st.sampled_from(
    [
        "\x00",
        "\x03",
        "\x0b",
        "\x0c",
        "\x1c",
        "\x85",
        "\u2028",
        "\ufeff",
        "é",
        "\\",
        "'",
        '"',
        "nan",
        "NaN",
        "inf",
        "-inf",
        "1e999",
        "1e-999",
        "1e308",
        "-1e308",
        "(",
        ")",
        "[",
        "]",
        "=",
        ";",
        "%",
        "$",
        "#",
        ",",
        "..",
        "--",
        "\r",
        "\n",
        "R1e300",
        "I1e300",
        "R-1e200",
        "X1e300",
        "F1e-300",
    ]
)


@FAST
@given(programs(), st.lists(st.tuples(st.integers(0, 10_000), GARBAGE), min_size=1, max_size=4))
def test_garbage_in_a_valid_program_never_raises(
    prog: Program, cuts: list[tuple[int, str]]
) -> None:
    text = prog.text(Style())
    for pos, junk in cuts:
        at = pos % (len(text) + 1)
        text = text[:at] + junk + text[at:]
    r = dec(text)
    n_lines = len(text.replace("\r\n", "\n").replace("\r", "\n").split("\n"))
    for e in r.errors:
        assert 1 <= e.line <= n_lines and e.column >= 1, (text, e)
    for b in r.blocks:
        if b.motion is not None:
            values = (*b.motion.start, *b.motion.end, b.motion.sweep, *(b.motion.center or ()))
            assert all(math.isfinite(v) for v in values), (text, b)


# -- the bugs these generators found, as the smallest programs --------------------------------
HEAD = "G01 X10 Y10 F600\n"


def test_a_value_without_an_address_letter_is_an_error_outside_g04() -> None:
    """`G01 X10 5` (a lost axis letter) ran as G01 X10: the 5 was dropped silently."""
    assert errors(dec(HEAD + "G01 X20 5\n")) == [(ErrorId.SYNTAX, 2)]
    assert errors(dec(HEAD + "M5 5\n")) == [(ErrorId.SYNTAX, 2)]
    assert errors(dec(HEAD + "G04 2 3\n")) == [(ErrorId.SYNTAX, 2)]
    assert dec(HEAD + "G04 2\n").blocks[-1].dwell == 2.0  # G04's own time stays
    assert dec(HEAD + "P1=2\nG04 P1\n").blocks[-1].dwell == 2.0  # also from a parameter


def test_a_circle_with_centre_and_radius_is_21024() -> None:
    """The vendor's example of ID 21024; before, I/J won and R was ignored."""
    r = dec(HEAD + "G02 X20 Y10 I5 J0 R5\n")
    assert errors(r) == [(ErrorId.CENTRE_AND_RADIUS, 2)]
    assert r.errors[0].column == 19  # at the R word
    assert errors(dec(HEAD + "G02 X20 Y10 R5\nG02 X30 Y10 I5\n")) == []  # modal R, then I


def test_a_circle_centre_beyond_the_data_format_is_20054_not_a_crash() -> None:
    """G02 X20 R1e300 raised ValueError out of decode (a NaN centre); G02 X20 I1e300 ran a
    half circle of 5 mm (the radius check's tolerance scaled with the huge radius)."""
    for arc in ("G02 X20 R1e300", "G02 X20 R-1e200", "G02 X20 I1e300", "G02 X20 R1000000"):
        assert errors(dec(HEAD + arc + "\n")) == [(ErrorId.CENTRE_OUT_OF_RANGE, 2)], arc


def test_two_block_numbers_are_20105() -> None:
    assert errors(dec("N20 G01 X10 F600 N30\n")) == [(ErrorId.N_TWICE, 1)]


def test_line_numbers_count_only_line_feeds_and_carriage_returns() -> None:
    """A form feed, NEL or U+2028 in a comment ended the line there (str.splitlines): the
    comment's rest was an error and every later line number was off by one."""
    for odd in ("\x0c", "\x0b", "\x1c", "\x85", "\u2028"):
        r = dec(HEAD + f"(page{odd}break)\nG01 X20\nQ1\n")
        assert errors(r) == [(ErrorId.UNKNOWN_AXIS, 4)], repr(odd)
    assert errors(dec(HEAD + "G01 X20\rQ1\r\nX30\n")) == [(ErrorId.UNKNOWN_AXIS, 3)]


def test_odd_whitespace_is_the_same_error_with_or_without_a_comment() -> None:
    """The plain-word fast path split at FF, NBSP, U+3000 (str.split), the lexer not."""
    for odd in ("\x0c", "\xa0", "\u3000"):
        for tail in ("", " (c)"):
            assert errors(dec(HEAD + f"G01 X20{odd}Y5{tail}\n")) == [(ErrorId.SYNTAX, 2)]


def test_l_number_is_a_call_and_g04_p_a_parameter() -> None:
    """`L4711` (a global subroutine by number) and `G04 P1` were read as address words L and
    P: error 990018 instead of the call and the dwell."""
    assert errors(dec("L4711\n")) == [(ErrorId.FILE_NOT_FOUND, 1)]
    assert errors(dec(HEAD + "G01 X20 L 4711\n")) == [(ErrorId.FILE_NOT_FOUND, 2)]
