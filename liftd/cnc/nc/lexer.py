"""Split one NC line into words (DIN 66025 subset of the ISG dialect, docs/reference/isg-cnc.md §5).

Comments: ``( ... )`` may nest, ``(`` without ``)`` runs to the end of the line, ``;`` runs to
the end of the line (TF5200 programming manual, comments). A ``#`` command takes the rest of
the line and excludes other words except N. Words need no separating blanks.

Beyond plain address words: subroutine calls ``LL name`` / ``L file.nc`` / ``L SEQUENCE [..]``
(a blank after ``LL``/``L`` is mandatory, TF5200 programming manual 206828043 / 206834699),
P parameter assignments ``P1 = <expr>``, and address values that are expressions:
``X[P1*2]``, ``XP1``, ``X=P1*SIN[30]`` (expr.py).

With an `errors` list the lexer records a malformed word and goes on with the next one, so
that one bad word does not take the rest of its block with it (F, G90/G91 ... stay modal).
"""

from __future__ import annotations

import enum
import math
import re
from typing import NamedTuple

from liftd.cnc.nc.expr import Expr, ExprError, compile_text, parse


class TokenKind(enum.Enum):
    WORD = "word"  # address letter + number: G01, X-10.5, R=50
    BRACKET = "bracket"  # address letter + [ ... ]: Z[LIFT_START ...] or X[P1*2]
    COMMAND = "command"  # # command: #FLUSH WAIT, #SLOPE[TYPE=TRAPEZ]
    NUMBER = "number"  # a bare number (G04 2.5)
    EXPR = "expr"  # address letter + unbracketed expression: XP1*2 (letter set), or a bare
    #                value (letter "", e.g. G04 P1 or G04 [P1*2])
    ASSIGN = "assign"  # P<n> = <expr>
    CALL = "call"  # LL name, L name, L SEQUENCE [...]


class Token(NamedTuple):
    kind: TokenKind
    letter: str  # upper-case address letter ("" for COMMAND / NUMBER / bare EXPR)
    text: str  # number text, bracket content, command text, call name
    column: int  # 1-based
    expr: Expr | None = None  # EXPR value; ASSIGN right-hand side
    param: Expr | None = None  # ASSIGN: the parameter number (P[<expr>] = ...)


class LexError(Exception):
    def __init__(self, column: int, message: str, error_id: int | None = None) -> None:
        super().__init__(message)
        self.column = column
        self.message = message
        self.error_id = error_id  # None: the decoder picks syntax or number


NUMBER_RE = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?")
SEPARATORS = " \t\r\x00,\x03"
NUMBER = 990002  # ErrorId.NUMBER: missing or malformed number
UNSUPPORTED = 990004
SUBROUTINE_CALL_NAME = re.compile(r"[^\s;(\[]+")
_KEYWORD = re.compile(r"[A-Za-z_]{2,}(?![A-Za-z_0-9\[])")


def strip_comments(line: str) -> str:
    """Remove ( ) and ; comments, keeping column positions (comment text becomes blanks)."""
    if "(" not in line and ";" not in line:
        return line
    out: list[str] = []
    depth = 0
    for ch in line:
        if depth == 0 and ch == ";":
            break
        if ch == "(":
            depth += 1
            out.append(" ")
        elif ch == ")" and depth > 0:
            depth -= 1
            out.append(" ")
        else:
            out.append(" " if depth > 0 else ch)
    return "".join(out)


FAST_WORD = re.compile(
    r"[ \t]*([A-Za-z])[ \t]*=?[ \t]*([+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)(?![A-Za-z])"
)


def is_finite_number(number: str) -> bool:
    """False for a number text beyond the float range (F1e999, 400 digits): it would be an
    infinite value. Short texts without an exponent are finite without converting them."""
    if len(number) < 300 and "e" not in number and "E" not in number:
        return True
    return math.isfinite(float(number))


def _check_number(text: str, m: re.Match[str], col: int) -> str:
    """The number matched by m, or LexError 990002 when it is malformed: running on into a
    second decimal point (X1..2, X1.2.3: a CAM post-processor's typo must not be read as
    X1.) or beyond the float range (F1e999)."""
    number = m.group(0)
    end = m.end()
    if end < len(text) and text[end] == ".":
        bad = re.match(r"[0-9.eE+-]*", text[m.start() :])
        written = bad.group(0) if bad else number
        raise LexError(col, f"malformed number {written!r}", NUMBER)
    if not is_finite_number(number):
        shown = number if len(number) <= 20 else number[:20] + "…"
        raise LexError(col, f"number {shown} is out of range (not a finite value)", NUMBER)
    return number


def _tokenize_plain(text: str) -> list[Token] | None:
    """Fast path for lines of plain address words only; None means "use the full lexer"."""
    tokens = []
    pos = 0
    for m in FAST_WORD.finditer(text):
        if m.start() != pos or not is_finite_number(m.group(2)):
            return None
        if m.group(1) in "LlPp":  # L4711 is a call, G04 P1 a parameter: not address words
            return None
        tokens.append(Token(TokenKind.WORD, m.group(1).upper(), m.group(2), m.start(1) + 1))
        pos = m.end()
    return tokens if not text[pos:].strip(SEPARATORS) else None


def _closing_bracket(text: str, j: int) -> int:
    """Index of the `]` that closes the `[` at j, or -1."""
    depth = 0
    for k in range(j, len(text)):
        c = text[k]
        if c == "[":
            depth += 1
        elif c == "]":
            depth -= 1
            if depth == 0:
                return k
    return -1


def _starts_expression(text: str, j: int) -> bool:
    """An address value that is an expression, not a plain number: P1, P[..], -P1, SIN[..]."""
    n = len(text)
    if j >= n:
        return False
    c = text[j]
    if c in "+-" and j + 1 < n:
        j += 1
        c = text[j]
    if c == "[":
        return True
    if c in "Pp" and j + 1 < n and (text[j + 1].isdigit() or text[j + 1] == "["):
        return True
    # a function name, or a variable (V.L.x, not emulated: the parser says so)
    return (
        c.isalpha() and j + 1 < n and (text[j + 1].isalpha() or (c in "Vv" and text[j + 1] == "."))
    )


def _skip_word(text: str, i: int) -> int:
    """Position after the malformed word at i (the next separator)."""
    n = len(text)
    while i < n and text[i] not in SEPARATORS:
        i += 1
    return i


def _call(text: str, i: int, col: int) -> tuple[Token, int]:
    """`LL name` / `L name` / `L<digits>` / `L SEQUENCE [..]` at i (the first L)."""
    n = len(text)
    local = i + 1 < n and text[i + 1] in "Ll"
    j = i + (2 if local else 1)
    if j < n and text[j] not in " \t" and not (not local and text[j].isdigit()):
        raise LexError(col, "a blank must separate LL / L from the subroutine name")
    while j < n and text[j] in " \t":
        j += 1
    if not local and text[j : j + 8].upper() == "SEQUENCE":
        k = j + 8
        while k < n and text[k] in " \t":
            k += 1
        if k >= n or text[k] != "[":
            raise LexError(col, "L SEQUENCE needs [ N.. [N..] [REPEAT=..] ]")
        end = _closing_bracket(text, k)
        if end < 0:
            raise LexError(k + 1, "'[' after L SEQUENCE is not closed")
        return Token(TokenKind.CALL, "SEQ", text[k + 1 : end].strip(), col), end + 1
    if j < n and text[j] in "\"'":
        raise LexError(col, "subroutine names in macros are not emulated", UNSUPPORTED)
    m = SUBROUTINE_CALL_NAME.match(text, j)
    if m is None:
        raise LexError(col, f"{'LL' if local else 'L'} needs a subroutine name")
    name = m.group(0)
    upper = name.upper()
    if upper == "CYCLE" or upper.startswith("V."):
        raise LexError(col, f"L {name}: cycles and parametric calls are not emulated", UNSUPPORTED)
    return Token(TokenKind.CALL, "LL" if local else "L", name, col), m.end()


def _expression(text: str, j: int, col: int) -> tuple[Expr, int]:
    try:
        return parse(text, j)
    except ExprError as exc:
        raise LexError(col, exc.message, exc.error_id) from None


def _parameter(text: str, i: int, col: int) -> tuple[Token, int]:
    """`P<n> = <expr>` (assignment) or `P<n>` / `P[..]` as a bare value, at i."""
    n = len(text)
    j = i + 1
    index: Expr | None = None
    number = ""
    if j < n and text[j] == "[":
        end = _closing_bracket(text, j)
        if end < 0:
            raise LexError(j + 1, "'[' after P is not closed")
        try:
            index = compile_text(text[j + 1 : end])
        except ExprError as exc:
            raise LexError(col, exc.message, exc.error_id) from None
        j = end + 1
    else:
        m = re.match(r"\d+", text[j:])
        if m is None:
            raise LexError(col, "P needs a parameter number")
        number = m.group(0)
        j += len(number)
        if j < n and text[j] == "[":
            raise LexError(col, "parameter arrays are not emulated", UNSUPPORTED)
    k = j
    while k < n and text[k] in " \t":
        k += 1
    if k < n and text[k] == "=" and not text.startswith("==", k):
        rhs, end = _expression(text, k + 1, col)
        if index is None:
            index = Expr(float(number))
        return Token(TokenKind.ASSIGN, "P", number, col, rhs, index), end
    value, end = _expression(text, i, col)  # the parameter as a value (G04 P1)
    return Token(TokenKind.EXPR, "", text[i:end], col, value), end


def tokenize(line: str, errors: list[LexError] | None = None) -> list[Token]:
    """Words of one line. Without `errors` a malformed word raises LexError(column, message);
    with it, the error is recorded and lexing goes on after the word."""
    text = strip_comments(line)
    if "[" not in text and "#" not in text:
        fast = _tokenize_plain(text)
        if fast is not None:
            return fast
    tokens: list[Token] = []
    i = 0
    n = len(text)
    while i < n:
        ch = text[i]
        if ch in SEPARATORS:
            i += 1
            continue
        try:
            i = _token(text, i, tokens)
        except LexError as err:
            if errors is None:
                raise
            errors.append(err)
            if ch == "#":
                break
            i = _skip_word(text, i + 1)
    return tokens


def _token(text: str, i: int, tokens: list[Token]) -> int:
    """Append the token at i; returns the position after it."""
    n = len(text)
    ch = text[i]
    col = i + 1
    if ch == "#":
        tokens.append(Token(TokenKind.COMMAND, "", text[i:].strip(), col))
        return n
    if ch == "$" and i + 1 < n and text[i + 1].isalpha():
        word = re.match(r"\$[A-Za-z_]*", text[i:])
        name = word.group(0) if word else "$"
        raise LexError(col, f"control blocks ({name}) are not emulated by liftd", UNSUPPORTED)
    if ch.isalpha():
        letter = ch.upper()
        if letter == "L" and (i + 1 >= n or text[i + 1] in " \tLl" or text[i + 1].isdigit()):
            tok, end = _call(text, i, col)
            tokens.append(tok)
            return end
        if letter == "P" and i + 1 < n and (text[i + 1].isdigit() or text[i + 1] == "["):
            tok, end = _parameter(text, i, col)
            tokens.append(tok)
            return end
        j = i + 1
        if j < n and text[j].isalpha() and not _starts_expression(text, j):
            word = re.match(r"[A-Za-z_.]+", text[i:])
            name = word.group(0) if word else ch
            if name.upper().startswith("V."):
                raise LexError(col, f"variables ({name}) are not emulated by liftd", UNSUPPORTED)
            raise LexError(col, f"unknown word {name!r}")
        while j < n and text[j] in " \t":
            j += 1
        if j < n and text[j] == "[":
            end = _closing_bracket(text, j)
            if end < 0:
                raise LexError(j + 1, f"'[' after {letter} is not closed")
            content = text[j + 1 : end].strip()
            head = _KEYWORD.match(content)
            if (
                head is not None
                and head.group(0).upper() != "PI"
                and not content[head.end() :].lstrip().startswith("[")
            ):
                # a keyword command (LIFT_START ..., OVERRIDE ...), interpreted by the decoder
                tokens.append(Token(TokenKind.BRACKET, letter, content, col))
                return end + 1
            try:
                expr = compile_text(content)
            except ExprError as exc:
                raise LexError(col, exc.message, exc.error_id) from None
            tokens.append(Token(TokenKind.BRACKET, letter, content, col, expr))
            return end + 1
        if j < n and text[j] == "=":
            j += 1
        while j < n and text[j] in " \t":
            j += 1
        m = NUMBER_RE.match(text, j)
        if m is not None and not (m.end() < n and text[m.end()] in "*/+-"):
            tokens.append(Token(TokenKind.WORD, letter, _check_number(text, m, col), col))
            return m.end()
        if m is not None or _starts_expression(text, j):
            expr, end = _expression(text, j, col)
            tokens.append(Token(TokenKind.EXPR, letter, text[j:end], col, expr))
            return end
        raise LexError(col, f"{letter} needs a number")
    if ch == "[":
        end = _closing_bracket(text, i)
        if end < 0:
            raise LexError(col, "'[' is not closed")
        try:
            expr = compile_text(text[i + 1 : end])
        except ExprError as exc:
            raise LexError(col, exc.message, exc.error_id) from None
        tokens.append(Token(TokenKind.EXPR, "", text[i : end + 1], col, expr))
        return end + 1
    m = NUMBER_RE.match(text, i)
    if m is not None:
        tokens.append(Token(TokenKind.NUMBER, "", _check_number(text, m, col), col))
        return m.end()
    raise LexError(col, f"unexpected character {ch!r}")
