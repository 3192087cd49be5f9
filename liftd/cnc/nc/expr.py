"""P parameters and arithmetic expressions of the ISG dialect, compiled once per source line
and evaluated per execution (a subroutine body runs many times).

Syntax (TF5200 programming manual):
* arithmetic expressions use square brackets for grouping, point before dash:
  ``P5 = [[SIN[P1*30] + P2] / P5]``
  https://infosys.beckhoff.com/content/1033/tf5200_programming_manual/206014219.html
* P parameters: ``P`` + index > 0, created by the first write (``P10=20.5``), valid in the
  main program and every subroutine it calls (P-CHAN-00067 decides whether they survive the
  program; liftd starts every program with none)
  https://infosys.beckhoff.com/content/1033/tf5200_programming_manual/206872331.html
* an address letter takes a parameter or an expression directly: ``XP1*SIN[P2*30]``, or in
  brackets ``X[P1*2+5]``
  https://infosys.beckhoff.com/content/1031/tf5200_programming_manual/206878987.html
* functions take their argument in square brackets (``SIN[45]``, else ID 20387); angles are in
  degrees: the diagnosis example of ID 20396 divides by ``COS[90]``, so COS[90] is exactly 0
  https://infosys.beckhoff.com/content/1033/tf5200_diagnosis/251507339.html

The function table of the manual's overview could not be read in full from our copy; liftd
offers what CAM post-processors emit: + - * / ** MOD, ABS SQR SQRT EXP LN LOG DEXP INT FRACT
ROUND SIN COS TAN ASIN ACOS ATAN ATAN2[y,x] MIN[a,b] MAX[a,b] and the constant PI.

Errors carry ISG ids where the diagnosis pages document one: 20396 division by zero, 20925
unknown parameter (read before any write), 20400 parameter index 0, negative or too large,
20387 function without ``[``. Overflow and arguments outside a function's domain have no
documented id; they get liftd's own.
"""

from __future__ import annotations

import math
import operator
import re
from collections.abc import Callable
from typing import NamedTuple

Params = dict[int, float]
Fn = Callable[[Params], float]

# ISG ids (TF5200 diagnosis pages) and liftd's own for what the kernel does not document
DIVISION_BY_ZERO = (
    20396  # https://infosys.beckhoff.com/content/1033/tf5200_diagnosis/251507339.html
)
UNKNOWN_PARAMETER = (
    20925  # https://infosys.beckhoff.com/content/1033/tf5200_diagnosis/253008779.html
)
PARAMETER_INDEX = 20400  # https://infosys.beckhoff.com/content/1033/tf5200_diagnosis/251524747.html
BRACKET_AFTER_FUNCTION = (
    20387  # https://infosys.beckhoff.com/content/1033/tf5200_diagnosis/251494283.html
)
SYNTAX = 990001
NUMBER = 990002  # malformed number (1..2) or one beyond the float range (1e999)
OVERFLOW = 990030  # result not a finite number
DOMAIN = 990031  # argument outside the function's domain (SQRT[-1], LN[0], ASIN[2])

MAX_PARAMETER = 100_000  # highest P index (the CNC's maximum is configuration-dependent)
MAX_DEPTH = 64  # bracket nesting: bounds recursion on hostile input

_NUMBER = re.compile(r"(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?")
_PLAIN_NUMBER = re.compile(r"[ \t]*((?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)")
_NUMBER_RUN = re.compile(r"[0-9.eE]+")  # a malformed number as written, for its message
_NAME = re.compile(r"[A-Za-z_][A-Za-z_0-9]*")
_INDEX = re.compile(r"\d+")


class ExprError(Exception):
    """An expression that cannot be read or evaluated; `offset` is 0-based in its text."""

    def __init__(self, error_id: int, message: str, offset: int = 0) -> None:
        super().__init__(message)
        self.error_id = error_id
        self.message = message
        self.offset = offset


class Expr(NamedTuple):
    """A compiled expression: a constant, or a function of the P parameters."""

    const: float
    fn: Fn | None = None
    text: str = ""

    def value(self, params: Params) -> float:
        fn = self.fn
        if fn is None:
            return self.const
        try:
            return fn(params)
        except KeyError as exc:  # a parameter read before it was written
            raise ExprError(
                UNKNOWN_PARAMETER, f"P{exc.args[0]} is read before it was written"
            ) from None


def _checked(value: float) -> float:
    if not math.isfinite(value):
        raise ExprError(OVERFLOW, "arithmetic overflow: the result is not a finite number")
    return value


def _deg_trig(fn: Callable[[float], float], zero_at: float) -> Callable[[float], float]:
    """sin/cos/tan of an angle in degrees, exact at multiples of 90° (COS[90] = 0)."""

    def f(deg: float) -> float:
        if deg == int(deg):
            r = deg % 360.0
            if r % 90.0 == 0.0:
                q = int(r // 90.0)
                if zero_at == 0.0:  # sin
                    return (0.0, 1.0, 0.0, -1.0)[q]
                if zero_at == 90.0:  # cos
                    return (1.0, 0.0, -1.0, 0.0)[q]
                if q % 2 == 0:  # tan of 0° / 180°
                    return 0.0
                raise ExprError(DOMAIN, f"TAN[{deg:g}] is not defined")
        return fn(math.radians(deg))

    return f


def _domain(
    name: str, ok: Callable[[float], bool], fn: Callable[[float], float]
) -> Callable[[float], float]:
    def f(x: float) -> float:
        if not ok(x):
            raise ExprError(DOMAIN, f"{name}[{x:g}]: argument outside the function's domain")
        return fn(x)

    return f


def _round(x: float) -> float:
    # ROUND: to the nearest integer, halves away from zero (not banker's rounding)
    return float(math.floor(abs(x) + 0.5)) * (1.0 if x >= 0.0 else -1.0)


FUNCTIONS1: dict[str, Callable[[float], float]] = {
    "ABS": abs,
    "SQR": lambda x: x * x,
    "SQRT": _domain("SQRT", lambda x: x >= 0.0, math.sqrt),
    "EXP": lambda x: math.exp(x) if x < 709.0 else math.inf,
    "LN": _domain("LN", lambda x: x > 0.0, math.log),
    "LOG": _domain("LOG", lambda x: x > 0.0, math.log10),
    "DEXP": lambda x: 10.0**x if x < 308.0 else math.inf,
    "INT": lambda x: float(math.trunc(x)) if math.isfinite(x) else x,
    "FRACT": lambda x: x - math.trunc(x) if math.isfinite(x) else x,
    "ROUND": _round,
    "SIN": _deg_trig(math.sin, 0.0),
    "COS": _deg_trig(math.cos, 90.0),
    "TAN": _deg_trig(math.tan, 0.0),
    "ASIN": _domain("ASIN", lambda x: -1.0 <= x <= 1.0, lambda x: math.degrees(math.asin(x))),
    "ACOS": _domain("ACOS", lambda x: -1.0 <= x <= 1.0, lambda x: math.degrees(math.acos(x))),
    "ATAN": lambda x: math.degrees(math.atan(x)),
}
FUNCTIONS2: dict[str, Callable[[float, float], float]] = {
    "ATAN2": lambda y, x: math.degrees(math.atan2(y, x)),
    "MIN": min,
    "MAX": max,
}


def _div(a: float, b: float) -> float:
    if b == 0.0:
        raise ExprError(DIVISION_BY_ZERO, "division by 0")
    return _checked(a / b)


def _mod(a: float, b: float) -> float:
    if b == 0.0:
        raise ExprError(DIVISION_BY_ZERO, "division by 0 (MOD)")
    return math.fmod(a, b)


def _pow(a: float, b: float) -> float:
    if a < 0.0 and b != int(b):
        raise ExprError(DOMAIN, f"{a:g} ** {b:g} is not a real number")
    if a == 0.0 and b < 0.0:
        raise ExprError(DIVISION_BY_ZERO, "division by 0 (0 ** negative)")
    try:
        return _checked(a**b)
    except OverflowError:
        raise ExprError(OVERFLOW, "arithmetic overflow in **") from None


BINARY: dict[str, Callable[[float, float], float]] = {
    "+": lambda a, b: _checked(a + b),
    "-": lambda a, b: _checked(a - b),
    "*": lambda a, b: _checked(a * b),
    "/": _div,
    "MOD": _mod,
    "**": _pow,
}


def read_parameter(params: Params, index: int) -> float:
    """P<index>; a missing one raises KeyError, turned into ID 20925 by `Expr.value`."""
    return params[index]


def check_index(value: float) -> int:
    """A P index from a number or an expression value (ID 20400 when out of range)."""
    if value != int(value) or not 1 <= value <= MAX_PARAMETER:
        raise ExprError(
            PARAMETER_INDEX, f"P parameter number {value:g} is 0, negative or above {MAX_PARAMETER}"
        )
    return int(value)


# -- compilation ----------------------------------------------------------------------------------
def _const(value: float) -> Expr:
    return Expr(value)


def _apply1(f: Callable[[float], float], a: Expr) -> Expr:
    afn = a.fn
    if afn is None:
        return Expr(_checked(f(a.const)))
    return Expr(0.0, lambda p: _checked(f(afn(p))))


def _apply2(f: Callable[[float, float], float], a: Expr, b: Expr) -> Expr:
    """Combine two operands; constants are folded, and each closure calls its operands'
    functions directly (no per-call dispatch: subroutine bodies evaluate them per call)."""
    afn, bfn = a.fn, b.fn
    if afn is None and bfn is None:
        return Expr(_checked(f(a.const, b.const)))
    if afn is None:
        ac = a.const
        assert bfn is not None
        return Expr(0.0, lambda p: f(ac, bfn(p)))
    if bfn is None:
        bc = b.const
        return Expr(0.0, lambda p: f(afn(p), bc))
    return Expr(0.0, lambda p: f(afn(p), bfn(p)))


class _Parser:
    """Recursive descent over one expression. `blanks` False: an unbracketed expression
    after a word or `=`; blanks end it unless a binary operator follows them."""

    def __init__(self, text: str, pos: int, bracketed: bool) -> None:
        self.text = text
        self.pos = pos
        self.bracketed = bracketed
        self.depth = 0

    def error(self, message: str, error_id: int = SYNTAX) -> ExprError:
        return ExprError(error_id, message, self.pos)

    def skip(self) -> None:
        text, n = self.text, len(self.text)
        while self.pos < n and text[self.pos] in " \t":
            self.pos += 1

    def peek_operator(self, ops: tuple[str, ...]) -> str | None:
        """The binary operator at the position (after blanks), without consuming it; in an
        unbracketed expression blanks before a non-operator end the expression."""
        start = self.pos
        self.skip()
        text = self.text
        for op in ops:
            if op == "MOD":
                if text[self.pos : self.pos + 3].upper() == "MOD" and not (
                    self.pos + 3 < len(text) and (text[self.pos + 3].isalnum())
                ):
                    return op
            elif text.startswith(op, self.pos) and not (
                op == "*" and text.startswith("**", self.pos)
            ):
                return op
        self.pos = start
        return None

    def expr(self) -> Expr:
        left = self.term()
        while (op := self.peek_operator(("+", "-"))) is not None:
            self.pos += len(op)
            left = _apply2(BINARY[op], left, self.term())
        return left

    def term(self) -> Expr:
        left = self.power()
        while (op := self.peek_operator(("**", "*", "/", "MOD"))) is not None:
            if op == "**":
                break
            self.pos += len(op)
            left = _apply2(BINARY[op], left, self.power())
        return left

    def power(self) -> Expr:
        base = self.unary()
        if self.peek_operator(("**",)) is not None:
            self.pos += 2
            return _apply2(BINARY["**"], base, self.power())  # right-associative
        return base

    def unary(self) -> Expr:
        self.skip()
        text = self.text
        if self.pos < len(text) and text[self.pos] in "+-":
            sign = text[self.pos]
            self.pos += 1
            operand = self.unary()
            return operand if sign == "+" else _apply1(lambda x: -x, operand)
        return self.atom()

    def _open(self) -> bool:
        """Enter `[` at the position; returns the bracketed state to restore."""
        self.depth += 1
        if self.depth > MAX_DEPTH:
            raise self.error(f"brackets nested deeper than {MAX_DEPTH}")
        self.pos += 1
        saved = self.bracketed
        self.bracketed = True
        return saved

    def _close(self, saved: bool, message: str) -> None:
        """Leave at `]` (after blanks), else `message`."""
        self.skip()
        if self.pos >= len(self.text) or self.text[self.pos] != "]":
            raise self.error(message)
        self.pos += 1
        self.bracketed = saved
        self.depth -= 1

    def bracket(self) -> Expr:
        """`[ expr ]` with the position at `[`."""
        saved = self._open()
        inner = self.expr()
        self._close(saved, "']' expected")
        return inner

    def atom(self) -> Expr:
        self.skip()
        text, pos = self.text, self.pos
        if pos >= len(text):
            raise self.error("operand expected at the end of the expression")
        ch = text[pos]
        if ch == "[":
            return self.bracket()
        m = _NUMBER.match(text, pos)
        if m is not None:
            self.pos = m.end()
            return _const(_literal(text, m))
        if ch in "Pp" and pos + 1 < len(text) and (text[pos + 1].isdigit() or text[pos + 1] == "["):
            return self.parameter()
        m = _NAME.match(text, pos)
        if m is None:
            raise self.error(f"unexpected {ch!r} in the expression")
        name = m.group(0).upper()
        self.pos = m.end()
        if name == "PI":
            return _const(math.pi)
        if name in FUNCTIONS1 or name in FUNCTIONS2:
            self.skip()
            if self.pos >= len(text) or text[self.pos] != "[":
                raise self.error(f"{name} needs its argument in [ ]", BRACKET_AFTER_FUNCTION)
            return self.call(name)
        for fn in (*FUNCTIONS1, *FUNCTIONS2):
            if name.startswith(fn) and name[len(fn) :].isdigit():  # SIN45 for SIN[45]
                raise ExprError(BRACKET_AFTER_FUNCTION, f"{fn} needs its argument in [ ]", pos)
        if name.startswith("V") and self.pos < len(text) and text[self.pos] == ".":
            raise ExprError(990004, f"variables ({name}.…) are not emulated by liftd", pos)
        raise ExprError(SYNTAX, f"unknown name {m.group(0)!r} in the expression", pos)

    def call(self, name: str) -> Expr:
        saved = self._open()
        args = [self.expr()]
        self.skip()
        while self.pos < len(self.text) and self.text[self.pos] == ",":
            self.pos += 1
            args.append(self.expr())
            self.skip()
        self._close(saved, "']' expected after the function argument")
        if name in FUNCTIONS1:
            if len(args) != 1:
                raise self.error(f"{name} takes one argument")
            return _apply1(FUNCTIONS1[name], args[0])
        if len(args) != 2:
            raise self.error(f"{name} takes two arguments [a, b]")
        return _apply2(FUNCTIONS2[name], args[0], args[1])

    def parameter(self) -> Expr:
        self.pos += 1  # 'P'
        text = self.text
        if text[self.pos] == "[":
            index_expr = self.bracket()
            ifn = index_expr.value
            return Expr(0.0, lambda p: read_parameter(p, check_index(ifn(p))))
        m = _INDEX.match(text, self.pos)
        assert m is not None
        self.pos = m.end()
        if self.pos < len(text) and text[self.pos] == ".":
            raise self.error("a P parameter index is a whole number")
        try:
            index = check_index(float(m.group(0)))
        except ExprError as exc:
            exc.offset = self.pos
            raise
        return Expr(0.0, operator.itemgetter(index))


def _literal(text: str, m: re.Match[str], group: int = 0) -> float:
    """The value of a number literal; 990002 when it runs on into a second decimal point
    (1..2, 1.2.3) or lies beyond the float range (1e999)."""
    end = m.end()
    if end < len(text) and text[end] == ".":
        written = _NUMBER_RUN.match(text, m.start(group))
        shown = written.group(0) if written else m.group(group)
        raise ExprError(NUMBER, f"malformed number {shown!r}", m.start(group))
    value = float(m.group(group))
    if not math.isfinite(value):
        shown = m.group(group)
        shown = shown if len(shown) <= 20 else shown[:20] + "…"
        raise ExprError(
            NUMBER, f"number {shown} is out of range (not a finite value)", m.start(group)
        )
    return value


def parse(text: str, pos: int = 0, bracketed: bool = False) -> tuple[Expr, int]:
    """Compile the expression at `pos`; returns it and the position after it.

    Unbracketed (after an address letter or `=`) the expression ends at a blank that is not
    followed by a binary operator, so ``P1=P2*3 X[P1]`` and ``P1 = P2 * 3`` both work."""
    m = _PLAIN_NUMBER.match(text, pos)
    if m is not None:  # a plain number (P1=26.000): the parser would read just the same
        end = m.end()
        after = end
        while after < len(text) and text[after] in " \t":
            after += 1
        nxt = text[after : after + 3]
        if not nxt or (nxt[0] not in "+-*/" and nxt.upper() != "MOD"):
            return Expr(_literal(text, m, 1), None, text[pos:end]), end
    p = _Parser(text, pos, bracketed)
    expr = p.expr()
    return expr._replace(text=text[pos : p.pos]), p.pos


def compile_text(text: str) -> Expr:
    """A whole text as one expression (the content of ``X[ ... ]``)."""
    expr, end = parse(text, 0, bracketed=True)
    rest = text[end:].strip()
    if rest:
        raise ExprError(SYNTAX, f"unexpected {rest[:10]!r} after the expression", end)
    return expr
