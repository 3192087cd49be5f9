"""The lift syntax inside ``<axis>[ ... ]`` (vendor text §3):

    <axis>[LIFT_START [DOWN] [G90|G91] [POS=..] POS_LIMIT=..]
    <axis>[LIFT_END]
    <axis>[LIFT [DOWN] [G90|G91] [POS=..] POS_LIMIT=..]

The first keyword identifies the command and must come first; the parameters are non-modal
and may follow in any order.
"""

from __future__ import annotations

import enum
import re
from collections.abc import Callable
from dataclasses import dataclass

from liftd.cnc.nc.lexer import NUMBER_RE, is_finite_number


class LiftKeyword(enum.Enum):
    START = "LIFT_START"
    END = "LIFT_END"
    SINGLE = "LIFT"


KEYWORDS = {k.value: k for k in LiftKeyword}


@dataclass(frozen=True, slots=True)
class LiftWords:
    keyword: LiftKeyword
    down: bool = False
    incremental: bool = False  # G91: POS and POS_LIMIT relative to the start position
    pos_mm: float | None = None
    pos_limit_mm: float | None = None


class LiftSyntaxError(Exception):
    pass


_ITEM = re.compile(r"\s*([A-Za-z_][A-Za-z_0-9]*)\s*(=\s*(\[|[^\s,\[]+))?")
Evaluate = Callable[[str], float]  # an expression value (POS=[P1+2], POS_LIMIT=P3)


def is_lift_command(content: str) -> bool:
    first = content.split(None, 1)[0].upper() if content.strip() else ""
    return first in KEYWORDS


def _balanced(text: str, start: int) -> int:
    """Position after the `]` closing the `[` at start."""
    depth = 0
    for k in range(start, len(text)):
        if text[k] == "[":
            depth += 1
        elif text[k] == "]":
            depth -= 1
            if depth == 0:
                return k + 1
    raise LiftSyntaxError("'[' in the lift command is not closed")


def parse_lift_words(content: str, evaluate: Evaluate | None = None) -> LiftWords:
    """Parse the bracket content of a lift command; raises LiftSyntaxError. Values that are
    not plain numbers go to `evaluate` (P parameters, expressions); without it they are
    syntax errors."""
    items: list[tuple[str, str | None]] = []
    pos = 0
    text = content.strip()
    while pos < len(text):
        m = _ITEM.match(text, pos)
        if m is None or m.end() == pos:
            raise LiftSyntaxError(f"cannot read {text[pos:]!r}")
        value = m.group(3)
        pos = m.end()
        if value == "[":
            end = _balanced(text, m.start(3))
            value = text[m.start(3) : end]
            pos = end
        items.append((m.group(1).upper(), value))
        while pos < len(text) and text[pos] in " \t,":
            pos += 1
    if not items:
        raise LiftSyntaxError("empty lift command")
    head, head_value = items[0]
    keyword = KEYWORDS.get(head)
    if keyword is None:
        raise LiftSyntaxError(f"{head} is not a lift keyword")
    if head_value is not None:
        raise LiftSyntaxError(f"{head} takes no value")
    if keyword is LiftKeyword.END:
        if len(items) > 1:
            raise LiftSyntaxError("LIFT_END takes no parameters")
        return LiftWords(keyword)
    seen: set[str] = set()
    down = incremental = False
    pos_mm: float | None = None
    limit_mm: float | None = None
    for name, value in items[1:]:
        group = "G9x" if name in ("G90", "G91") else name
        if group in seen:
            raise LiftSyntaxError(f"{name} programmed twice")
        seen.add(group)
        if name in KEYWORDS:
            raise LiftSyntaxError(f"{name} must be the first keyword")
        if name in ("DOWN", "G90", "G91"):
            if value is not None:
                raise LiftSyntaxError(f"{name} takes no value")
            down = down or name == "DOWN"
            incremental = name == "G91" or incremental
            continue
        if name in ("POS", "POS_LIMIT"):
            if value is None:
                raise LiftSyntaxError(f"{name}= needs a number")
            if NUMBER_RE.fullmatch(value) is not None and is_finite_number(value):
                number = float(value)
            elif evaluate is not None:
                number = evaluate(value)
            else:
                raise LiftSyntaxError(f"{name}= needs a finite number")
            if name == "POS":
                pos_mm = number
            else:
                limit_mm = number
            continue
        raise LiftSyntaxError(f"unknown lift parameter {name}")
    return LiftWords(keyword, down, incremental, pos_mm, limit_mm)
