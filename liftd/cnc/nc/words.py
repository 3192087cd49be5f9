"""The words of one NC block, collected before the decoder interprets them: a fast path for
the plain address words CAM post-processors emit, and the full path over the lexer's tokens
(expressions evaluated against the P parameters, assignments executed left to right).
Knows the address letters, not their meaning.

A word that cannot be used becomes a fault of the block and is skipped; the other words are
still collected, so the block's modal state (F, G90/G91, the plane ...) is not lost with it
(issue 19: no cascades)."""

from __future__ import annotations

import re

from liftd.cnc.nc.blocks import ErrorId, NcFault
from liftd.cnc.nc.expr import Expr, ExprError, Params, check_index, compile_text
from liftd.cnc.nc.lexer import Token, TokenKind
from liftd.cnc.nc.lift_words import LiftSyntaxError, LiftWords, is_lift_command, parse_lift_words

_PARAMETER = re.compile(r"[Pp][\d\[]")  # a lift command with parameter values
TECHNOLOGY_LETTERS = frozenset("STH")  # laser power, tool number, H function: ignored
VALUE_LETTERS = "FIJKRD"  # feed, circle centre / radius, tool radius selection (D)
NUMBER_CHARS = frozenset("0123456789.+-eE")


class Words:
    """The words of one block, collected before they are interpreted. Read-only once built
    (a subroutine line's Words are reused for every call)."""

    __slots__ = (
        "bare",
        "call",
        "command",
        "fast_g",
        "faults",
        "gcodes",
        "lift",
        "m",
        "n",
        "refused_start",
        "simple",
        "values",
    )

    def __init__(self) -> None:
        self.n: int | None = None
        self.gcodes: list[tuple[int, int]] = []
        self.values: dict[str, tuple[float, int]] = {}  # letter -> (value, column)
        self.m: list[tuple[int, int]] = []
        self.lift: tuple[str, LiftWords, int] | None = None
        # the axis of a LIFT_START whose words could not be read (its fault is in `faults`):
        # the decoder counts its range as started, for its LIFT_END
        self.refused_start: str | None = None
        self.bare: list[tuple[float, int]] = []
        self.command: Token | None = None
        self.call: Token | None = None  # LL / L / L SEQUENCE, always the block's last word
        self.faults: list[NcFault] = []
        # axis words (and N) only: the decoder's fast path (same meaning, fewer checks)
        self.simple = False
        # G00..G03 once with axis words, F, I, J, R (and N) only: that G's number, else -1
        # (the decoder's second fast path)
        self.fast_g = -1


class Template:
    """A subroutine line prepared once: the words that never change (G, M, N, numbers,
    the call) collected, the expression words kept for evaluation per call."""

    __slots__ = ("base", "compiled", "dynamic", "fast_g", "ordered", "simple")

    def __init__(
        self, base: Words, dynamic: list[Token], axes: frozenset[str], ordered: bool = False
    ) -> None:
        self.base = base
        self.dynamic = dynamic
        self.ordered = ordered  # a call or command in the line: collect all tokens in order
        letters = [t.letter for t in dynamic]
        # X[expr] Y[expr] F[expr] ... each a new value of an axis or a value letter: evaluated
        # in a tight loop (the general loop below gives the same words, with more checks)
        self.compiled: tuple[tuple[str, Expr, int], ...] | None = None
        if (
            not ordered
            and all(t.kind is TokenKind.BRACKET and t.expr is not None for t in dynamic)
            and len(set(letters)) == len(letters)
            and all(
                (letter in axes or letter in VALUE_LETTERS) and letter not in base.values
                for letter in letters
            )
            and (base.lift is None or base.lift[0] not in letters)
        ):
            self.compiled = tuple((t.letter, t.expr, t.column) for t in dynamic if t.expr)
        self.simple = (
            self.compiled is not None
            and _is_simple(base)
            and all(letter in axes for letter in letters)
        )
        self.fast_g = (
            _fast_g(base)
            if self.compiled is not None and all(letter not in SLOW_LETTERS for letter in letters)
            else -1
        )

    def words(self, axes: frozenset[str], params: Params) -> Words:
        if self.ordered:
            w = collect(self.dynamic, axes, params)
            w.faults[:0] = self.base.faults
            return w
        base = self.base
        compiled = self.compiled
        values = dict(base.values)
        if compiled is not None:
            try:
                for name, compiled_expr, column in compiled:
                    values[name] = (compiled_expr.value(params), column)
            except ExprError:  # the general loop below reports it at its word
                values = dict(base.values)
            else:
                return self._words(values, self.simple, self.fast_g)
        w = self._words(values, False, -1)
        for tok in self.dynamic:
            expr = tok.expr
            letter = tok.letter
            if (
                tok.kind is TokenKind.BRACKET
                and expr is not None
                and letter in axes
                and letter not in values
            ):
                try:
                    values[letter] = (expr.value(params), tok.column)
                except ExprError as exc:
                    w.faults.append(NcFault(ErrorId(exc.error_id), tok.column, exc.message))
                continue
            try:
                _collect_one(tok, w, axes, params, self.dynamic)
            except NcFault as fault:
                w.faults.append(fault)
            except ExprError as exc:
                w.faults.append(NcFault(ErrorId(exc.error_id), tok.column, exc.message))
        return w

    def _words(self, values: dict[str, tuple[float, int]], simple: bool, fast_g: int) -> Words:
        base = self.base
        w = Words.__new__(Words)  # every slot set here: no __init__ defaults to overwrite
        w.n = base.n
        w.gcodes = base.gcodes
        w.m = base.m
        w.lift = base.lift
        w.refused_start = base.refused_start
        w.bare = list(base.bare) if base.bare else []
        w.command = base.command
        w.call = base.call
        w.values = values
        w.faults = list(base.faults) if base.faults else []
        w.simple = simple
        w.fast_g = fast_g
        return w


def _is_simple(w: Words) -> bool:
    return (
        not w.gcodes
        and not w.m
        and not w.faults
        and not w.bare
        and w.lift is None
        and w.call is None
        and w.command is None
        and all(letter not in w.values for letter in VALUE_LETTERS)
    )


SLOW_LETTERS = ("K", "D")  # values the decoder's fast paths do not handle


def _fast_g(w: Words) -> int:
    if (
        len(w.gcodes) != 1
        or w.m
        or w.faults
        or w.bare
        or w.lift is not None
        or w.call is not None
        or w.command is not None
        or any(letter in w.values for letter in SLOW_LETTERS)
    ):
        return -1
    g = w.gcodes[0][0]
    return g if g <= 3 else -1


def template(
    tokens: list[Token], axes: frozenset[str], faults: list[NcFault] | None = None
) -> Template | Words:
    """Split a line's tokens for reuse; plain lines come back as their Words. `faults`: the
    lexer's, placed first (they come first in the line's reading)."""
    dynamic = [
        t
        for t in tokens
        if t.kind in (TokenKind.EXPR, TokenKind.ASSIGN)
        or (
            t.kind is TokenKind.BRACKET
            and (t.expr is not None or _PARAMETER.search(t.text) is not None)
        )
    ]
    static = [t for t in tokens if t not in dynamic]
    base = collect(static, axes, {})
    if faults:
        base.faults[:0] = faults
    if not dynamic:
        base.simple = _is_simple(base)
        base.fast_g = _fast_g(base)
        return base
    letters = [t.letter for t in tokens if t.letter and t.kind is not TokenKind.ASSIGN]
    if base.call is not None or base.command is not None or len(set(letters)) < len(letters):
        # order matters (21542; a word twice: the first one counts): all tokens per run
        holder = Words()
        holder.faults = list(faults or [])
        return Template(holder, tokens, axes, ordered=True)
    return Template(base, dynamic, axes)


def _value(tok: Token, params: Params) -> float:
    expr = tok.expr
    if expr is None:
        return float(tok.text)
    return expr.value(params)


def collect(tokens: list[Token], axes: frozenset[str], params: Params) -> Words:
    """The words of a block from the full lexer's tokens. Problems become `faults`."""
    w = Words()
    values = w.values
    faults = w.faults
    for tok in tokens:
        letter = tok.letter
        if w.call is not None:
            # ID 21542: "No further NC commands allowed after subroutine or cycle call"
            # https://infosys.beckhoff.com/content/1033/tf5200_diagnosis/255123851.html
            faults.append(
                NcFault(
                    ErrorId.WORDS_AFTER_CALL,
                    tok.column,
                    "no further NC words are allowed after a subroutine call in its block "
                    "(program them before the call)",
                )
            )
            break
        kind = tok.kind
        if letter in axes and letter not in values:  # the common cases first
            if kind is TokenKind.WORD:
                values[letter] = (float(tok.text), tok.column)
                continue
            expr = tok.expr
            if kind is TokenKind.BRACKET and expr is not None:
                try:
                    values[letter] = (expr.value(params), tok.column)
                except ExprError as exc:
                    faults.append(NcFault(ErrorId(exc.error_id), tok.column, exc.message))
                continue
        try:
            _collect_one(tok, w, axes, params, tokens)
        except NcFault as fault:
            faults.append(fault)
        except ExprError as exc:
            faults.append(NcFault(ErrorId(exc.error_id), tok.column, exc.message))
    return w


def _collect_one(
    tok: Token, w: Words, axes: frozenset[str], params: Params, tokens: list[Token]
) -> None:
    kind = tok.kind
    letter = tok.letter
    if kind is TokenKind.COMMAND:
        others = [t for t in tokens if t is not tok and t.letter != "N"]
        if others:
            raise NcFault(
                ErrorId.SYNTAX,
                others[0].column,
                "a # command excludes other words in its block (except N)",
            )
        w.command = tok
    elif kind is TokenKind.CALL:
        w.call = tok
    elif kind is TokenKind.ASSIGN:
        assert tok.expr is not None and tok.param is not None
        index = check_index(tok.param.value(params))
        params[index] = tok.expr.value(params)
    elif kind is TokenKind.NUMBER or (kind is TokenKind.EXPR and not letter):
        w.bare.append((_value(tok, params), tok.column))
    elif kind is TokenKind.BRACKET:
        _bracket(tok, w, axes, params)
    elif letter == "N":
        if kind is not TokenKind.WORD:
            raise NcFault(ErrorId.UNSUPPORTED, tok.column, "N with an expression is not emulated")
        if w.n is not None:
            # ID 20105 "Double-programmed block number N" (its example: N20 X10 N30)
            # https://infosys.beckhoff.com/content/1033/tf5200_diagnosis/250776203.html
            raise NcFault(ErrorId.N_TWICE, tok.column, "a second block number N in one block")
        w.n = int(float(tok.text))
    elif letter in "GM":
        if kind is not TokenKind.WORD:
            raise NcFault(
                ErrorId.UNSUPPORTED, tok.column, f"{letter} with an expression is not emulated"
            )
        code = float(tok.text)
        if code != int(code) or code < 0:
            raise NcFault(
                ErrorId.UNSUPPORTED, tok.column, f"{letter}{tok.text} is not emulated by liftd"
            )
        (w.gcodes if letter == "G" else w.m).append((int(code), tok.column))
    elif letter in TECHNOLOGY_LETTERS:
        if kind is TokenKind.EXPR:
            _value(tok, params)  # evaluated for its errors, the value is not used
    elif letter in axes or letter in VALUE_LETTERS:
        _store(w, letter, _value(tok, params), tok.column)
    else:
        raise NcFault(
            ErrorId.UNKNOWN_AXIS,
            tok.column,
            f"{letter} is not an axis of the channel nor a known address",
        )


def _store(w: Words, letter: str, value: float, column: int) -> None:
    if letter in w.values or (w.lift is not None and w.lift[0] == letter):
        eid = (
            ErrorId.DOUBLE_F
            if letter == "F"
            else ErrorId.WORD_TWICE
            if letter in VALUE_LETTERS
            else ErrorId.AXIS_TWICE
        )
        raise NcFault(eid, column, f"{letter} programmed twice in one block")
    w.values[letter] = (value, column)


def _bracket(tok: Token, w: Words, axes: frozenset[str], params: Params) -> None:
    if tok.expr is not None:  # X[P1*2+5]
        if tok.letter not in axes and tok.letter not in VALUE_LETTERS:
            raise NcFault(ErrorId.UNKNOWN_AXIS, tok.column, f"{tok.letter} is not an axis")
        _store(w, tok.letter, tok.expr.value(params), tok.column)
        return
    try:
        _lift_command(tok, w, axes, params)
    except NcFault:
        if tok.text.split(None, 1)[0].upper() == "LIFT_START":
            w.refused_start = tok.letter
        raise


def _lift_command(tok: Token, w: Words, axes: frozenset[str], params: Params) -> None:
    if tok.letter not in axes:
        raise NcFault(ErrorId.UNKNOWN_AXIS, tok.column, f"{tok.letter} is not an axis")
    if not is_lift_command(tok.text):
        raise NcFault(
            ErrorId.UNSUPPORTED,
            tok.column,
            f"{tok.letter}[{tok.text}] is not "
            "emulated by liftd (lift commands, numbers and expressions are)",
        )
    if w.lift is not None or tok.letter in w.values:
        raise NcFault(ErrorId.AXIS_TWICE, tok.column, f"{tok.letter} programmed twice")

    def evaluate(text: str) -> float:
        expr: Expr = compile_text(text[1:-1] if text.startswith("[") else text)
        return expr.value(params)

    try:
        w.lift = (tok.letter, parse_lift_words(tok.text, evaluate), tok.column)
    except LiftSyntaxError as exc:
        raise NcFault(ErrorId.LIFT_SYNTAX, tok.column, str(exc)) from None
    except ExprError as exc:  # a malformed value is a malformed lift command
        eid = ErrorId.LIFT_SYNTAX if exc.error_id == ErrorId.SYNTAX else ErrorId(exc.error_id)
        raise NcFault(eid, tok.column, f"lift command: {exc.message}") from None


def collect_plain(line: str, axes: frozenset[str]) -> Words | None:
    """Fast path for blank-separated plain address words ("G01 X20.5 Y10 F6000"), which
    is what CAM post-processors emit; None means "use the full lexer"."""
    w = Words()
    values = w.values
    col = 0
    simple = True
    # blanks and tabs only: str.split() also splits at FF, NBSP, U+3000 ..., which the lexer
    # rejects (no NC separators), so such a line decoded differently with a comment appended
    for word in line.replace("\t", " ").split(" "):
        if not word:
            continue
        col = line.find(word, col) + 1
        letter = word[0]
        number = word[1:]
        if not number or not letter.isalpha() or not NUMBER_CHARS.issuperset(number):
            return None
        try:
            value = float(number)
        except ValueError:  # X1..2, X1.2.3: the full lexer says where
            return None
        if value - value != 0.0:  # inf (F1e999): the full lexer reports it
            return None
        if letter.islower():
            letter = letter.upper()
        if letter in axes:
            if letter in values:
                return None
            values[letter] = (value, col)
        elif letter in VALUE_LETTERS:
            if letter in values:
                return None
            values[letter] = (value, col)
            simple = False
        elif letter == "G" or letter == "M":  # noqa: PLR1714
            if value != int(value) or value < 0:
                return None
            (w.gcodes if letter == "G" else w.m).append((int(value), col))
            simple = False
        elif letter == "N":
            if w.n is not None:  # ID 20105: the full path reports it
                return None
            w.n = int(value)
        elif letter not in TECHNOLOGY_LETTERS:
            return None
        col += len(word) - 1
    w.simple = simple
    if not simple and w.gcodes:
        w.fast_g = _fast_g(w)
    return w
