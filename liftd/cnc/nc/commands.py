"""`#` commands of the ISG dialect that liftd understands (docs/reference/isg-cnc.md §4.9, §5).

#FLUSH, #FLUSH WAIT, #FLUSH CONTINUE; #SLOPE [TYPE=STEP|TRAPEZ|SIN2|HSC [NO_OPT=0|1]] and
#SLOPE DEFAULT; #TIME <s>; #TRANSVELMIN ON [<v>] / ON / OFF, the minimum velocity at contour
kinks in mm/min (inch/min under G70), modal until the program's end
(https://infosys.beckhoff.com/content/1033/tf5200_programming_manual/207486091.html).
#ROTATION, #TRAFO and #CS are recognised so that the lift-specific errors can be given; liftd
does not emulate coordinate transformations.

Smoothing commands are accepted (the path runs unsmoothed, the decoder warns once per kind):
#HSC ON [..] / #HSC OFF / #HSC [..] (HSC mode, TF5200 HSC pack), #SPLINE ON / OFF,
#CONTOUR MODE [..] (parameters only) / #CONTOUR MODE ON [..] (= G261) / OFF (= G260),
https://infosys.beckhoff.com/content/1033/tf5250_hsc_pack/475156491.html
"""

from __future__ import annotations

import enum
import math
import re
from dataclasses import dataclass

from liftd.cnc.nc.blocks import ErrorId, FlushKind, NcFault
from liftd.cnc.nc.lexer import NUMBER_RE, Token
from liftd.cnc.params import SlopeType


class CommandKind(enum.Enum):
    FLUSH = "flush"
    SLOPE = "slope"
    SLOPE_DEFAULT = "slope default"
    TIME = "time"
    TRANSFORM = "transform"  # #ROTATION / #TRAFO: forbidden inside a lift range (120606)
    CS = "cs"
    SMOOTHING = "smoothing"  # #HSC, #SPLINE, #CONTOUR MODE
    TRANSVELMIN = "transvelmin"


@dataclass(frozen=True, slots=True)
class CommandResult:
    kind: CommandKind
    column: int
    flush: FlushKind | None = None
    slope: SlopeType | None = None
    seconds: float | None = None
    text: str = ""
    smoothing: str = ""  # "#HSC", "#SPLINE", "#CONTOUR MODE"
    on: bool | None = None  # selected / deselected / only parameterised
    value: float = 0.0  # #TRANSVELMIN ON [v]: v in program units per minute


_TRANSVELMIN = re.compile(r"#TRANSVELMIN\s+(ON|OFF)\s*(?:\[(.*)\])?\s*\Z")
_SLOPE = re.compile(r"#SLOPE\s*\[\s*TYPE\s*=\s*([A-Z0-9]+)\s*(NO_OPT\s*=\s*[01]\s*)?\]\Z")


def parse_command(token: Token) -> CommandResult:
    """Parse one # command token; raises NcFault."""
    text = " ".join(token.text.upper().split())
    col = token.column
    if text in ("#FLUSH", "#FLUSH WAIT", "#FLUSH CONTINUE"):
        return CommandResult(CommandKind.FLUSH, col, flush=FlushKind(text))
    if text.startswith("#SLOPE"):
        if text == "#SLOPE DEFAULT":
            return CommandResult(CommandKind.SLOPE_DEFAULT, col)
        m = _SLOPE.match(text)
        if m is None:
            raise NcFault(ErrorId.SYNTAX, col, "#SLOPE needs [TYPE=STEP|TRAPEZ|SIN2|HSC]")
        try:
            slope = SlopeType[m.group(1)]
        except KeyError:
            raise NcFault(
                ErrorId.SYNTAX, col, f"unknown slope type {m.group(1)} (STEP|TRAPEZ|SIN2|HSC)"
            ) from None
        return CommandResult(CommandKind.SLOPE, col, slope=slope)
    if text == "#TRANSVELMIN" or text.startswith(("#TRANSVELMIN ", "#TRANSVELMIN[")):
        return _transvelmin(text, col)
    if text.startswith("#TIME"):
        value = text[len("#TIME") :].strip()
        if NUMBER_RE.fullmatch(value) is None or not 0.0 <= float(value) < math.inf:
            raise NcFault(ErrorId.DWELL_MISSING, col, "#TIME needs a finite time in seconds >= 0")
        return CommandResult(CommandKind.TIME, col, seconds=float(value))
    for name in ("#HSC", "#SPLINE", "#CONTOUR MODE"):
        if text == name or text.startswith((name + " ", name + "[")):
            rest = text[len(name) :].strip()
            on = True if rest.startswith("ON") else False if rest.startswith("OFF") else None
            if on is None and rest and not rest.startswith("["):
                raise NcFault(ErrorId.SYNTAX, col, f"{name} ON [..] | OFF | [..] expected")
            return CommandResult(CommandKind.SMOOTHING, col, text=text, smoothing=name, on=on)
    if text.startswith(("#ROTATION", "#TRAFO")):
        return CommandResult(CommandKind.TRANSFORM, col, text=text)
    if text.startswith("#CS"):
        return CommandResult(CommandKind.CS, col, text=text)
    name = text.split("[", 1)[0].split(" ", 1)[0]
    if name == "#FLUSH":  # emulated: the argument is wrong, not the command
        raise NcFault(
            ErrorId.SYNTAX,
            col,
            f"{text}: #FLUSH takes WAIT, CONTINUE or nothing, not {text[len(name) :].strip()}",
        )
    raise NcFault(ErrorId.UNSUPPORTED, col, f"{name} is not emulated by liftd")


def _transvelmin(text: str, col: int) -> CommandResult:
    m = _TRANSVELMIN.match(text)
    if m is None:
        raise NcFault(ErrorId.SYNTAX, col, "#TRANSVELMIN ON [<velocity>] | ON | OFF expected")
    if m.group(1) == "OFF":
        if m.group(2) is not None:
            raise NcFault(ErrorId.SYNTAX, col, "#TRANSVELMIN OFF takes no velocity")
        return CommandResult(CommandKind.TRANSVELMIN, col, on=False)
    raw = (m.group(2) or "").strip()
    if m.group(2) is None:
        return CommandResult(CommandKind.TRANSVELMIN, col, on=True)  # ON alone: 0
    if NUMBER_RE.fullmatch(raw) is None or not 0.0 <= float(raw) < math.inf:
        raise NcFault(
            ErrorId.TRANSVELMIN_VALUE,
            col,
            f"#TRANSVELMIN ON [{raw}]: the minimum transition velocity must be a number >= 0 "
            "(mm/min)",
        )
    return CommandResult(CommandKind.TRANSVELMIN, col, on=True, value=float(raw))
