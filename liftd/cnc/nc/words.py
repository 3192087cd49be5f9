"""The words of one NC block, collected before the decoder interprets them: a fast path for
the plain address words CAM post-processors emit, and the full path over the lexer's tokens.
Knows the address letters, not their meaning."""

from __future__ import annotations

from liftd.cnc.nc.blocks import ErrorId, NcFault
from liftd.cnc.nc.lexer import Token, TokenKind
from liftd.cnc.nc.lift_words import LiftSyntaxError, LiftWords, is_lift_command, parse_lift_words

TECHNOLOGY_LETTERS = frozenset("STDH")  # laser power, tool, ...: accepted and ignored
NUMBER_CHARS = frozenset("0123456789.+-eE")


class Words:
    """The words of one block, collected before they are interpreted."""

    __slots__ = ("bare", "command", "gcodes", "lift", "m", "n", "values")

    def __init__(self) -> None:
        self.n: int | None = None
        self.gcodes: list[tuple[int, int]] = []
        self.values: dict[str, tuple[float, int]] = {}  # letter -> (value, column)
        self.m: list[tuple[int, int]] = []
        self.lift: tuple[str, LiftWords, int] | None = None
        self.bare: list[tuple[float, int]] = []
        self.command: Token | None = None


def collect(tokens: list[Token], axes: frozenset[str]) -> Words:
    """The words of a block from the full lexer's tokens; NcFault for what is not allowed."""
    w = Words()
    values = w.values
    for tok in tokens:
        letter = tok.letter
        if tok.kind is TokenKind.WORD and letter in axes and letter not in values:
            values[letter] = (float(tok.text), tok.column)  # the common case first
            continue
        if tok.kind is TokenKind.COMMAND:
            others = [t for t in tokens if t is not tok and t.letter != "N"]
            if others:
                raise NcFault(
                    ErrorId.SYNTAX,
                    others[0].column,
                    "a # command excludes other words in its block (except N)",
                )
            w.command = tok
        elif tok.kind is TokenKind.NUMBER:
            w.bare.append((float(tok.text), tok.column))
        elif tok.kind is TokenKind.BRACKET:
            _bracket(tok, w, axes)
        elif tok.letter == "N":
            w.n = int(float(tok.text))
        elif tok.letter in "GM":
            code = float(tok.text)
            if code != int(code) or code < 0:
                raise NcFault(
                    ErrorId.UNSUPPORTED,
                    tok.column,
                    f"{tok.letter}{tok.text} is not emulated by liftd",
                )
            (w.gcodes if tok.letter == "G" else w.m).append((int(code), tok.column))
        elif tok.letter in TECHNOLOGY_LETTERS:
            continue
        elif tok.letter in axes or tok.letter in "FIJKR":
            if tok.letter in w.values or (w.lift is not None and w.lift[0] == tok.letter):
                eid = ErrorId.DOUBLE_F if tok.letter == "F" else ErrorId.AXIS_TWICE
                raise NcFault(eid, tok.column, f"{tok.letter} programmed twice in one block")
            w.values[tok.letter] = (float(tok.text), tok.column)
        else:
            raise NcFault(
                ErrorId.UNKNOWN_AXIS,
                tok.column,
                f"{tok.letter} is not an axis of the channel nor a known address",
            )
    return w


def _bracket(tok: Token, w: Words, axes: frozenset[str]) -> None:
    if tok.letter not in axes:
        raise NcFault(ErrorId.UNKNOWN_AXIS, tok.column, f"{tok.letter} is not an axis")
    if not is_lift_command(tok.text):
        raise NcFault(
            ErrorId.UNSUPPORTED,
            tok.column,
            f"{tok.letter}[{tok.text}] is not "
            "emulated by liftd (lift commands and plain numbers are)",
        )
    if w.lift is not None or tok.letter in w.values:
        raise NcFault(ErrorId.AXIS_TWICE, tok.column, f"{tok.letter} programmed twice")
    try:
        w.lift = (tok.letter, parse_lift_words(tok.text), tok.column)
    except LiftSyntaxError as exc:
        raise NcFault(ErrorId.LIFT_SYNTAX, tok.column, str(exc)) from None


def collect_plain(line: str, axes: frozenset[str]) -> Words | None:
    """Fast path for blank-separated plain address words ("G01 X20.5 Y10 F6000"), which
    is what CAM post-processors emit; None means "use the full lexer"."""
    w = Words()
    values = w.values
    col = 0
    for word in line.split():
        col = line.find(word, col) + 1
        letter = word[0]
        number = word[1:]
        if not number or not letter.isalpha() or not NUMBER_CHARS.issuperset(number):
            return None
        try:
            value = float(number)
        except ValueError:
            return None
        if letter.islower():
            letter = letter.upper()
        if letter in axes or letter in "FIJKR":
            if letter in values:
                return None
            values[letter] = (value, col)
        elif letter == "G" or letter == "M":  # noqa: PLR1714
            if value != int(value) or value < 0:
                return None
            (w.gcodes if letter == "G" else w.m).append((int(value), col))
        elif letter == "N":
            w.n = int(value)
        elif letter not in TECHNOLOGY_LETTERS:
            return None
        col += len(word) - 1
    return w
