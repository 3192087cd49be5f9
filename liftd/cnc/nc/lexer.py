"""Split one NC line into words (DIN 66025 subset of the ISG dialect, isg-cnc.md §5).

Comments: ``( ... )`` may nest, ``(`` without ``)`` runs to the end of the line, ``;`` runs to
the end of the line (TF5200 programming manual, comments). A ``#`` command takes the rest of
the line and excludes other words except N. Words need no separating blanks.
"""

from __future__ import annotations

import enum
import re
from typing import NamedTuple


class TokenKind(enum.Enum):
    WORD = "word"  # address letter + number: G01, X-10.5, R=50
    BRACKET = "bracket"  # address letter + [ ... ]: Z[LIFT_START POS=1 POS_LIMIT=40]
    COMMAND = "command"  # # command: #FLUSH WAIT, #SLOPE[TYPE=TRAPEZ]
    NUMBER = "number"  # a bare number (G04 2.5)


class Token(NamedTuple):
    kind: TokenKind
    letter: str  # upper-case address letter ("" for COMMAND / NUMBER)
    text: str  # number text, bracket content or command text
    column: int  # 1-based


class LexError(Exception):
    def __init__(self, column: int, message: str) -> None:
        super().__init__(message)
        self.column = column
        self.message = message


NUMBER_RE = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?")
SEPARATORS = " \t\r\x00,\x03"


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


def _tokenize_plain(text: str) -> list[Token] | None:
    """Fast path for lines of plain address words only; None means "use the full lexer"."""
    tokens = []
    pos = 0
    for m in FAST_WORD.finditer(text):
        if m.start() != pos:
            return None
        tokens.append(Token(TokenKind.WORD, m.group(1).upper(), m.group(2), m.start(1) + 1))
        pos = m.end()
    return tokens if not text[pos:].strip(SEPARATORS) else None


def tokenize(line: str) -> list[Token]:
    """Words of one line; raises LexError(column, message) on malformed text."""
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
        if ch == "#":
            tokens.append(Token(TokenKind.COMMAND, "", text[i:].strip(), i + 1))
            break
        if ch.isalpha():
            letter = ch.upper()
            j = i + 1
            if j < n and text[j].isalpha():
                word = re.match(r"[A-Za-z_]+", text[i:])
                raise LexError(i + 1, f"unknown word {word.group(0) if word else ch!r}")
            while j < n and text[j] in " \t":
                j += 1
            if j < n and text[j] == "[":
                depth = 0
                k = j
                while k < n:
                    if text[k] == "[":
                        depth += 1
                    elif text[k] == "]":
                        depth -= 1
                        if depth == 0:
                            break
                    k += 1
                if k >= n:
                    raise LexError(j + 1, f"'[' after {letter} is not closed")
                tokens.append(Token(TokenKind.BRACKET, letter, text[j + 1 : k].strip(), i + 1))
                i = k + 1
                continue
            if j < n and text[j] == "=":
                j += 1
            while j < n and text[j] in " \t":
                j += 1
            m = NUMBER_RE.match(text, j)
            if m is None:
                raise LexError(i + 1, f"{letter} needs a number")
            tokens.append(Token(TokenKind.WORD, letter, m.group(0), i + 1))
            i = m.end()
            continue
        m = NUMBER_RE.match(text, i)
        if m is not None:
            tokens.append(Token(TokenKind.NUMBER, "", m.group(0), i + 1))
            i = m.end()
            continue
        raise LexError(i + 1, f"unexpected character {ch!r}")
    return tokens
