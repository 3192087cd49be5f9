"""NC decoder: text → typed blocks with absolute machine positions (m), lift ranges and ISG
error ids.

The program runs as the CNC's decoder runs it: the main program part of the file, local
subroutines (``LL name``) and global subroutine files (``L file.nc``, read by the caller into
`DecoderContext.sources`), ``L SEQUENCE [..]`` repetitions, P parameters and expressions, zero
offsets (G54..G59, G53, G92), inch/metric (G70/G71) and tool radius compensation (G41/G42/G40).
The expansion is streamed: a stack of frames over the files' lines, never an expanded text, so
the decoder's own memory is bounded by the program text; `iter_decode` yields the blocks one by
one, `decode` collects them.

Execution stops at the first error ("the path motion is always executed up to the last
correctly decoded point", vendor text §2.1.3 case 2), but decoding goes on so that `liftd check`
can report every problem of a program; after the first error a subroutine body is run once
only (its errors are reported once, not per call).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from typing import TypeVar

from liftd.cnc import units
from liftd.cnc.nc import lift_rules
from liftd.cnc.nc.arcs import build_arc
from liftd.cnc.nc.blocks import (
    Block,
    CallSite,
    DecodeResult,
    ErrorId,
    FlushKind,
    LiftEnd,
    LiftEndCause,
    LiftStart,
    Motion,
    MotionKind,
    NcError,
    NcFault,
    Severity,
)
from liftd.cnc.nc.commands import CommandKind, CommandResult, parse_command
from liftd.cnc.nc.context import DecoderContext
from liftd.cnc.nc.expr import Params
from liftd.cnc.nc.lexer import LexError, Token, tokenize
from liftd.cnc.nc.lift_words import LiftKeyword, LiftWords
from liftd.cnc.nc.sources import Section, Source, parse_source
from liftd.cnc.nc.trc import Trc, TrcFault
from liftd.cnc.nc.words import Template, Words, collect_plain, template
from liftd.cnc.params import LiftMethod, SlopeType
from liftd.cnc.path.geometry import ArcSeg

# M functions the ISG kernel handles internally when m_synch does not configure them
# (P-CHAN-00041 default NO_SYNCH for M0/1/2/17/29/30/3/4/19, isg-cnc.md §3.3); any other
# unconfigured M function is an error.
INTERNAL_M = frozenset({0, 1, 2, 3, 4, 17, 19, 29, 30})
MOTION_G = {0: MotionKind.RAPID, 1: MotionKind.LINEAR, 2: MotionKind.ARC_CW, 3: MotionKind.ARC_CCW}
INF = float("inf")
# G groups a block holds one of, with the ISG id for a second one (TF5200 diagnosis: 20108
# .../tf5200_diagnosis/250789259.html, 20114 …/250815371, 20118 …/250832779, 20127 …/250871947)
G_GROUPS = {
    **dict.fromkeys((0, 1, 2, 3), ErrorId.MOTION_G_TWICE),
    **dict.fromkeys((40, 41, 42), ErrorId.TRC_G_TWICE),
    **dict.fromkeys((70, 71), ErrorId.UNIT_G_TWICE),
    **dict.fromkeys((161, 162), ErrorId.CENTRE_G_TWICE),
}
MODE_G = frozenset({17, 94, 163})  # XY plane, F in mm/min, radius programming
ZERO_OFFSET_G = {53: 0, 54: 1, 55: 2, 56: 3, 57: 4, 58: 5, 59: 6}
# Smoothing the decoder accepts and runs unsmoothed: G code -> (kind, selects (True) or
# deselects (False)). G61/G261/G260 polynomial contouring, G151/G150 spline (FCT_SPLINE /
# FCT_POLY of P-STUP-00060, vendor §4.2.1; programming manual 206307595).
SMOOTHING_G = {
    61: ("G61 (polynomial contouring)", True),
    261: ("G261 (polynomial contouring)", True),
    260: ("G261 (polynomial contouring)", False),
    151: ("G151 (spline)", True),
    150: ("G151 (spline)", False),
}
SMOOTHING_CMD = {
    "#HSC": "#HSC ON (HSC smoothing)",
    "#SPLINE": "#SPLINE ON",
    "#CONTOUR MODE": "G261 (polynomial contouring)",
}
NO_RADIUS = "G41/G42 without a tool radius (programmed contour)"
LINE_CACHE = 4096  # distinct lines prepared once and reused by their text (bounded memory)
_T = TypeVar("_T")


class _Frame:
    """One level of the call stack: a section of a file being run."""

    __slots__ = ("cached", "comment", "end", "pos", "reps", "site", "source", "start", "tag")

    def __init__(
        self,
        source: Source,
        start: int,
        end: int,
        site: CallSite | None,
        reps: int = 0,
        tag: str = "",
    ) -> None:
        self.source = source
        self.tag = tag  # Block.file of its lines: "" in the program's own file
        self.start = start
        self.end = end
        self.pos = start
        self.site = site
        self.reps = reps  # further runs of the section after this one (L SEQUENCE REPEAT)
        self.cached = site is not None  # subroutine lines run again: keep their words
        self.comment: int | None = None  # line of an open #COMMENT BEGIN


def decode(text: str, ctx: DecoderContext) -> DecodeResult:
    """Decode a whole program. Never raises for any text: problems come back as NcErrors."""
    dec = _Decoder(ctx)
    blocks = tuple(dec.run(text))
    return dec.result(blocks)


def iter_decode(text: str, ctx: DecoderContext) -> tuple[Iterator[Block], _Decoder]:
    """The blocks as a stream, and the decoder whose `result(())` holds the errors once the
    stream is exhausted (memory bounded by the program text, not by its expansion)."""
    dec = _Decoder(ctx)
    return dec.run(text), dec


class _Decoder:
    def __init__(self, ctx: DecoderContext) -> None:
        self.ctx = ctx
        self.pos = tuple(ctx.start_position)
        self.z = ctx.axis_names.index(ctx.lift_axis)
        self.axes = frozenset(ctx.axis_names)
        self.axis_index = {name: k for k, name in enumerate(ctx.axis_names)}
        self.lift_axis = ctx.lift_axis
        self.limits = tuple((lo - 1e-12, hi + 1e-12) for lo, hi in ctx.sw_limits)
        self.motion = MotionKind.LINEAR
        self.incremental = False
        self.center_absolute = False  # G161 absolute, G162 (default) relative centre
        self.feed: float | None = None  # m/s
        self.radius: float | None = None  # m, modal R
        self.unit = units.M_PER_MM  # G71 (initial); G70: inch
        self.slope = ctx.slope
        self.params: Params = {}
        self.zero_group = ctx.zero_offset_default
        self.g92 = tuple(0.0 for _ in ctx.axis_names)
        self.offset = self._offsets()
        self.trc = Trc()
        self.tool_configured = False  # the active D has a radius in the tool table
        self.open_lift: LiftStart | None = None
        self.out: list[Block] = []
        self.errors: list[NcError] = []
        self.seen: set[tuple[str, int, int, int]] = set()
        self.stopped = False  # an error was found: no further blocks are executed
        self.open_at_error: LiftStart | None = None  # lift range open at the first error
        self.ended = False  # M02/M30 seen
        self.stack: list[_Frame] = []
        self.files: dict[str, Source] = {}
        self.line_cache: dict[str, Words | Template] = {}  # prepared lines by their text
        self.missing: set[str] = set()
        self.visited_after_stop: set[tuple[str, int]] = set()
        self.not_emulated: dict[str, int] = {}
        self.executed = 0
        self.line = 0  # the line being decoded, for messages
        self.last_line = 0
        self.last_file = ""
        self.return_after = False  # M17/M29 in this block
        self.tag = ""  # Block.file of the line being decoded

    # -- program flow --------------------------------------------------------------------------
    def run(self, text: str) -> Iterator[Block]:
        main = parse_source(self.ctx.sources.program, text)
        self._source_problems(main)
        if main.main is None:
            self._error(
                ErrorId.PROGRAM_STRUCTURE, 1, "no main program part (a % line after the local "
                "subroutines)", line=1,
            )  # fmt: skip
        else:
            self.stack.append(_Frame(main, main.main.start, main.main.end, None))
        limit = self.ctx.max_executed_blocks
        out = self.out
        while self.stack and not self.ended:
            frame = self.stack[-1]
            if frame.pos >= frame.end:
                self._leave(frame)
                continue
            idx = frame.pos
            frame.pos = idx + 1
            self.executed += 1
            if self.executed > limit:
                self.stack.clear()
                message = (
                    f"the program runs more than {limit} blocks (subroutine calls and "
                    "repetitions included); liftd prepares whole programs up to "
                    "[nc] max_executed_blocks"
                )
                self._error(ErrorId.EXPANSION_LIMIT, 1, message, line=idx + 1,
                            file=frame.source.name)  # fmt: skip
                break
            self._run_line(frame, idx)
            if out:
                yield from out
                out.clear()
        if not self.stopped:
            for b in self.trc.flush():
                self._output(b, checked=False)
        if self.open_lift is not None and not self.stopped and not self.ended:
            end = self._close_lift(LiftEndCause.PROGRAM_END)
            self._emit(Block(self.last_line, lift_end=end, file=self.last_file))
        yield from out
        out.clear()

    def result(self, blocks: tuple[Block, ...]) -> DecodeResult:
        return DecodeResult(
            blocks,
            tuple(self.errors),
            self.open_at_error,
            tuple(self.not_emulated.items()),
            self.executed,
        )

    def _run_line(self, frame: _Frame, idx: int) -> None:
        line = frame.source.lines[idx]
        lineno = idx + 1
        self.line = lineno
        head = line.lstrip()
        if head.startswith("#"):
            upper = " ".join(head.upper().split())
            if frame.comment is not None:
                if upper.startswith("#COMMENT END"):
                    frame.comment = None
                return
            if upper.startswith("#COMMENT BEGIN"):
                frame.comment = lineno
                return
        if frame.comment is not None or not head:
            return
        self.last_line = lineno
        self.last_file = self.tag = frame.tag
        try:
            self._line(frame, idx, line)
        except NcFault as err:
            self._report(err)
        if self.return_after:
            self.return_after = False
            if self.stack and self.stack[-1] is frame:
                self._return(frame)

    def _report(self, err: NcFault) -> None:
        if isinstance(err, _AlreadyReported):
            return
        if isinstance(err, TrcFault):
            b = err.block
            self._error(err.error_id, err.column, err.message, line=b.line,
                        file=b.file or self.ctx.sources.program)  # fmt: skip
            return
        self._error(err.error_id, err.column, err.message)

    def _leave(self, frame: _Frame) -> None:
        """The end of a section: M17 was left out (allowed), or the file ends."""
        if frame.comment is not None:
            line = frame.comment
            frame.comment = None
            self._error(ErrorId.COMMENT_OPEN, 1, "#COMMENT BEGIN without #COMMENT END",
                        line=line, file=frame.source.name)  # fmt: skip
        self._return(frame)

    def _return(self, frame: _Frame) -> None:
        if frame.reps > 0:
            frame.reps -= 1
            frame.pos = frame.start
            return
        self.stack.pop()

    def _file(self, frame: _Frame | None = None) -> str:
        f = frame or (self.stack[-1] if self.stack else None)
        return f.source.name if f is not None else self.ctx.sources.program

    def _chain(self) -> tuple[CallSite, ...]:
        return tuple(f.site for f in self.stack if f.site is not None)

    # -- errors and output -----------------------------------------------------------------------
    def _error(
        self,
        eid: ErrorId | int,
        column: int,
        message: str,
        *,
        line: int | None = None,
        file: str | None = None,
        severity: Severity = Severity.ERROR,
    ) -> None:
        lineno = self.line if line is None else line
        where = self._file() if file is None else file
        chain = self._chain()
        key = (where, lineno, column, int(eid))
        if severity is Severity.ERROR and not self.stopped:
            self.open_at_error = self.open_lift
            for b in self.trc.flush():  # the held block was decoded correctly: it runs
                self._output(b, checked=False)
            self.stopped = True
        if key in self.seen:
            return
        self.seen.add(key)
        if chain:
            message += f" (call chain: {_chain_text(chain)})"
        main = self.ctx.sources.program
        file_tag = "" if where == main else where
        self.errors.append(NcError(int(eid), lineno, column, message, severity, file_tag, chain))

    def _warn(self, eid: ErrorId, column: int, message: str) -> None:
        self._error(eid, column, message, severity=Severity.WARNING)

    def _count(
        self, kind: str, column: int, message: str, eid: ErrorId = ErrorId.NOT_EMULATED
    ) -> None:
        """Something accepted but run approximated: one warning per kind, counted per block."""
        if kind not in self.not_emulated:
            self.not_emulated[kind] = 0
            self._warn(eid, column, message)
        self.not_emulated[kind] += 1

    def _emit(self, block: Block) -> None:
        if self.stopped:
            return
        if self.trc.engaged:
            for b in self.trc.process(block):
                self._output(b, checked=True)
            return
        if block.motion is not None:
            self.out.append(block)
            return
        self._output(block, checked=False)

    def _output(self, block: Block, checked: bool) -> None:
        motion = block.motion
        if motion is not None:
            if checked:  # the compensated path
                try:
                    self._check_limits(motion, 1)
                except NcFault as err:
                    self._error(err.error_id, err.column, err.message, line=block.line,
                                file=block.file or self.ctx.sources.program)  # fmt: skip
                    return
            self.out.append(block)
            return
        if (
            block.motion is None
            and block.dwell is None
            and not block.m_functions
            and block.flush is None
            and block.slope is None
            and block.lift_start is None
            and block.lift_end is None
            and not block.program_end
        ):
            return
        self.out.append(block)

    def _close_lift(self, cause: LiftEndCause) -> LiftEnd:
        assert self.open_lift is not None
        start = self.open_lift
        pos = list(self.pos)
        pos[self.axis_index[start.axis]] = start.target
        self.pos = tuple(pos)
        self.open_lift = None
        return LiftEnd(start.axis, cause, start.line)

    def _offsets(self) -> tuple[float, ...]:
        """The zero offset in effect per axis: the selected group (G53 only with
        P-ZERO-00001) plus the G92 reference point offset."""
        group = self.zero_group
        values = self.ctx.zero_offsets.get(group) if group or self.ctx.g53_offsets else None
        if values is None:
            return self.g92
        return tuple(a + b for a, b in zip(values, self.g92, strict=True))

    # -- one line ----------------------------------------------------------------------------
    def _words(self, frame: _Frame, idx: int, line: str) -> Words:
        cache = frame.source.cache if frame.cached else None
        if cache is not None:
            hit = cache.get(idx)
            if hit is not None:
                if isinstance(hit, Words):
                    return hit
                assert isinstance(hit, Template)
                return hit.words(self.axes, self.params)
        if "[" not in line and "#" not in line and "(" not in line and ";" not in line:
            plain = collect_plain(line, self.axes)
            if plain is not None:
                if cache is not None:
                    cache[idx] = plain
                return plain
        prepared = self.line_cache.get(line)
        if prepared is None:
            errors: list[LexError] = []
            tokens = tokenize(line, errors)
            prepared = template(tokens, self.axes, [_lex_fault(e) for e in errors])
            if len(self.line_cache) < LINE_CACHE:  # recurring lines: lift commands, calls
                self.line_cache[line] = prepared
        if cache is not None:
            cache[idx] = prepared
        if isinstance(prepared, Words):
            return prepared
        return prepared.words(self.axes, self.params)

    def _line(self, frame: _Frame, idx: int, line: str) -> None:
        w = self._words(frame, idx, line)
        lineno = idx + 1
        if w.simple:  # the common block: axis words only (the fast path, same semantics)
            motion = self._motion(lineno, w)
            if motion is not None and not self.stopped:
                simple = Block(lineno, w.n, motion, None, (), None, None, None, None, False,
                               self.tag)  # fmt: skip
                if self.trc.engaged:
                    self._emit(simple)
                else:
                    self.out.append(simple)
            return
        g = w.fast_g
        if g >= 0:  # G00..G03 with axis words, F, I, J, R: as _block would, fewer checks
            values = w.values
            feed = values.get("F")
            if feed is None or feed[0] > 0.0:
                self.motion = MOTION_G[g]
                if feed is not None:
                    self.feed = feed[0] * self.unit / 60.0
                radius = values.get("R")
                if radius is not None:
                    self.radius = radius[0] * self.unit
                motion = self._motion(lineno, w)
                if not self.stopped:
                    self._emit(Block(lineno, w.n, motion, None, (), None, None, None, None,
                                     False, self.tag))  # fmt: skip
                return
        if w.command is not None and not w.faults:
            self._command(lineno, w.n, parse_command(w.command))
            return
        fault = w.faults[0] if w.faults else None
        block: Block | None = None
        try:
            block = self._block(lineno, w)
        except NcFault as err:
            if fault is None:
                fault = err
        if fault is not None:
            self._report(fault)
            if w.call is not None:  # the call is checked even in a rejected block
                _attempt([], self._call, frame, w.call, lineno)
            return
        if block is not None:
            self._emit(block)
        if w.call is not None:
            self._call(frame, w.call, lineno)

    def _block(self, lineno: int, w: Words) -> Block | None:
        """Interpret one block's words: every part that can be applied is applied (modal G
        functions, F, R, D, the motion, the lift command), so that a rejected word does not
        take the block's modal state with it; the first problem is raised at the end."""
        values = w.values
        faults: list[NcFault] = []
        dwell = g92 = False
        if w.gcodes:
            dwell, g92 = self._gcodes(w, faults)
        feed_word = values.get("F")
        if feed_word is not None:
            if feed_word[0] <= 0.0:
                faults.append(NcFault(ErrorId.FEED_ZERO, feed_word[1], "feed rate F must be > 0"))
            else:
                self.feed = feed_word[0] * self.unit / 60.0  # mm/min (G71) or inch/min (G70)
        if "R" in values:
            self.radius = values["R"][0] * self.unit
        if "D" in values:
            _attempt(faults, self._tool, values["D"])
        if "K" in values:
            faults.append(
                NcFault(
                    ErrorId.UNSUPPORTED,
                    values["K"][1],
                    "K (G18/G19 circles) is not emulated; liftd circles are in the G17 plane",
                )
            )
        block: Block | None = None
        if g92:
            self._g92(w)
        elif dwell:
            seconds = _attempt(faults, self._dwell, lineno, w)
            if seconds is not None:
                block = Block(lineno, w.n, dwell=seconds, file=self._file_tag())
        else:
            block = self._motion_block(lineno, w, faults)
        if faults:
            raise faults[0]
        return block

    def _motion_block(self, lineno: int, w: Words, faults: list[NcFault]) -> Block:
        m = _attempt(faults, self._m_functions, w) if w.m else None
        m_funcs, program_end = m if m is not None else ((), False)
        lift = w.lift[1] if w.lift is not None else None
        start: LiftStart | None = None
        if lift is not None and lift.keyword in (LiftKeyword.START, LiftKeyword.SINGLE):
            assert w.lift is not None
            start = _attempt(faults, self._lift_start, lineno, w.lift[0], lift, w.lift[2])
        motion: Motion | None = None
        try:
            motion = self._motion(lineno, w)
        except NcFault as fault:
            faults.append(fault)
        end: LiftEnd | None = None
        if lift is not None and lift.keyword is LiftKeyword.SINGLE:
            if self.open_lift is not None:
                end = self._close_lift(LiftEndCause.SINGLE_BLOCK)
        elif lift is not None and lift.keyword is LiftKeyword.END:
            assert w.lift is not None
            end = _attempt(faults, self._lift_end, w.lift[0], w.lift[2])
        if program_end and self.open_lift is not None and end is None:
            end = self._close_lift(LiftEndCause.PROGRAM_END)  # vendor §2.4
        self.ended = program_end
        return Block(
            lineno,
            w.n,
            motion=motion,
            m_functions=m_funcs,
            lift_start=start,
            lift_end=end,
            program_end=program_end,
            file=self.tag,
        )

    def _file_tag(self) -> str:
        return self.tag

    def _gcodes(self, w: Words, faults: list[NcFault]) -> tuple[bool, bool]:
        dwell = g92 = False
        groups: set[ErrorId] = set()
        side: int | None = None
        for code, col in w.gcodes:
            twice = G_GROUPS.get(code)
            if twice is not None:
                if twice in groups:
                    message = f"G{code:02d}: a second G function of its group in one block"
                    faults.append(NcFault(twice, col, message + " (the first one counts)"))
                    continue
                groups.add(twice)
            if code in MOTION_G:
                self.motion = MOTION_G[code]
            elif code == 4:
                dwell = True
            elif code in (90, 91):
                self.incremental = code == 91
            elif code in (161, 162):
                self.center_absolute = code == 161
            elif code in (70, 71):
                # G70 inch / G71 metric (TF5200 G-code list, isg-cnc.md §5 [S98])
                self.unit = units.program_length_factor(code == 70)
            elif code in ZERO_OFFSET_G:
                self.zero_group = ZERO_OFFSET_G[code]
                self.offset = self._offsets()
            elif code == 92:
                g92 = True
            elif code in (40, 41, 42):
                side = {40: 0, 41: 1, 42: -1}[code]
            elif code in (138, 139):
                self.trc.direct = code == 138
            elif code in SMOOTHING_G:
                kind, selects = SMOOTHING_G[code]
                fault = self._smoothing(kind, selects, col)
                if fault is not None:
                    faults.append(fault)
            elif code not in MODE_G:
                faults.append(
                    NcFault(ErrorId.UNSUPPORTED, col, f"G{code:02d} is not emulated by liftd")
                )
        if side is not None:
            fault = self._select_trc(side, w.gcodes[0][1])
            if fault is not None:
                faults.append(fault)
        return dwell, g92

    def _smoothing(self, kind: str, selects: bool, column: int) -> NcFault | None:
        """Smoothing is accepted and runs unsmoothed (one warning per kind). Inside a lift
        range no smoothing may be selected (vendor §2.4: "additional contour smoothing of the
        lift axis (contouring, G61/G261, G151, #SPLINE ON, #HSC ON) is not possible in the
        lifting range"); with path-based Lifting not deselected either (§2.2.1: "between
        LIFT_START and LIFT_END smoothing can not be selected or deselected")."""
        rng = self.open_lift
        if rng is not None and (selects or self.ctx.lift_method is LiftMethod.LIFTING):
            what = "selected" if selects else "deselected"
            return NcFault(
                ErrorId.SMOOTHING_IN_LIFT_RANGE,
                column,
                f"{kind.split(' (', 1)[0]}: smoothing {what} inside the lift range started in "
                f"line {rng.line} (vendor §2.4)",
            )
        if selects:
            self._count(kind, column, f"{kind}: smoothing is not emulated by liftd; the path "
                        "runs unsmoothed (exact contour, corners as programmed)")  # fmt: skip
        return None

    def _tool(self, word: tuple[float, int]) -> None:
        """D selects the tool radius for TRC (tool data wz[i].radius, P-TOOL-00004)."""
        number, col = word
        if number != int(number) or number < 0:
            raise NcFault(ErrorId.NUMBER, col, "D needs a tool number >= 0")
        radius = self.ctx.tool_radii.get(int(number))
        self.tool_configured = radius is not None or number == 0
        self.trc.set_radius(radius or 0.0)

    def _select_trc(self, side: int, column: int) -> NcFault | None:
        if side != 0 and not self.tool_configured and self.trc.side == 0:
            self._count(NO_RADIUS, column, "G41/G42: no tool radius configured for the selected "
                        "D (liftd.toml [nc.tools] or the ISG tool list): the programmed "
                        "contour runs uncompensated", ErrorId.TRC_NO_RADIUS)  # fmt: skip
        if (
            side != 0
            and self.open_lift is not None
            and self.axis_index.get(self.open_lift.axis, self.z) in (0, 1)
        ):
            return NcFault(
                ErrorId.TRC_LIFT_AXIS,
                column,
                f"tool radius compensation in the plane of the lift axis {self.open_lift.axis} "
                f"inside the lift range started in line {self.open_lift.line} (vendor §2.4)",
            )
        self.trc.set_side(side)
        return None

    def _g92(self, w: Words) -> None:
        """G92 reference point offset in the programmed axes: absolute under G90, added under
        G91; takes effect with the next absolute coordinate of the axis (programming manual
        https://infosys.beckhoff.com/content/1033/tf5200_programming_manual/206145291.html)."""
        g92 = list(self.g92)
        for k, name in enumerate(self.ctx.axis_names):
            word = w.values.get(name)
            if word is not None:
                value = word[0] * self.unit
                g92[k] = g92[k] + value if self.incremental else value
        self.g92 = tuple(g92)
        self.offset = self._offsets()

    def _dwell(self, lineno: int, w: Words) -> float:
        """G04 X<s> (first main axis), G04 <s>, lenient G04 F<s> (isg-cnc.md §4.9)."""
        first_axis = self.ctx.axis_names[0]
        direct = w.bare[0] if w.bare else None
        by_axis = w.values.get(first_axis) or w.values.get("F")
        if direct is not None and by_axis is not None:
            raise NcFault(
                ErrorId.DWELL_VALUE_AND_AXIS, by_axis[1], "G04 with both a direct time and an axis"
            )
        chosen = direct or by_axis
        if chosen is None or chosen[0] < 0.0:
            raise NcFault(ErrorId.DWELL_MISSING, 1, "G04 needs a time in seconds")
        for letter, (_, col) in w.values.items():
            if letter not in (first_axis, "F"):
                self._warn(ErrorId.DWELL_WITH_AXES, col, f"{letter} in a G04 block is ignored")
        return chosen[0]

    def _m_functions(self, w: Words) -> tuple[tuple[int, ...], bool]:
        numbers = []
        end = False
        for number, col in w.m:
            if number in (17, 29):
                if len(self.stack) <= 1:
                    raise NcFault(
                        ErrorId.SUBROUTINE_END_OUTSIDE,
                        col,
                        f"M{number} ends a subroutine, but the main program is running",
                    )
                self.return_after = True
                continue
            if number >= 1000:  # beyond m_synch[0..999]: taken as internal, unknown
                raise NcFault(
                    ErrorId.M_NUMBER_TOO_LARGE,
                    col,
                    f"M{number}: unknown internal M function (M functions are 0..999, "
                    "P-CHAN-00041)",
                )
            if number not in INTERNAL_M and number not in self.ctx.configured_m:
                raise NcFault(
                    ErrorId.M_NOT_CONFIGURED,
                    col,
                    f"M{number} has no synchronisation "
                    "configured (m_synch[...] in the channel list, P-CHAN-00041)",
                )
            if number in (2, 30):
                end = True
                if len(self.stack) > 1:
                    # the manual: a program abort with M02/M30 in a subroutine gives a warning
                    self._warn(ErrorId.PROGRAM_END_IN_SUBROUTINE, col,
                               f"M{number:02d} in a subroutine ends the whole program")  # fmt: skip
            numbers.append(number)
        return tuple(numbers), end

    def _motion(self, lineno: int, w: Words) -> Motion | None:
        values = w.values
        start = self.pos
        end = list(start)
        column = 0  # column of the first axis word, for messages
        unit = self.unit
        offset = self.offset
        incremental = self.incremental
        axis_index = self.axis_index
        limits = self.limits
        beyond = -1  # an axis beyond its software limit (reported after the other checks)
        for letter, (word, col) in values.items():
            k = axis_index.get(letter)
            if k is not None:
                value = word * unit
                v = end[k] = start[k] + value if incremental else value + offset[k]
                lo, hi = limits[k]
                if not lo <= v <= hi:
                    beyond = k
                if not column or col < column:
                    column = col
        kind = self.motion
        is_arc = kind is MotionKind.ARC_CW or kind is MotionKind.ARC_CCW
        if not column:
            if not (is_arc and ("I" in values or "J" in values)):
                return None
            column = min(col for _, col in values.values())
        lift_word = values.get(self.open_lift.axis) if self.open_lift is not None else None
        if lift_word is not None:
            assert self.open_lift is not None
            raise NcFault(
                ErrorId.LIFT_AXIS_PROGRAMMED,
                lift_word[1],
                f"the lift axis {self.open_lift.axis} must not be programmed inside a lift range",
            )
        feed = INF
        if kind is not MotionKind.RAPID:
            if self.feed is None:
                raise NcFault(
                    ErrorId.FEED_ZERO,
                    column,
                    "no feed rate: program F before the first G01/G02/G03",
                )
            feed = self.feed
        end_t = tuple(end)
        if is_arc:
            i = values.get("I")
            j = values.get("J")
            ij = (i[0] * unit if i else None, j[0] * unit if j else None)
            if self.center_absolute:  # G161: the centre is a position, offsets apply
                ij = (
                    None if ij[0] is None else ij[0] + offset[0],
                    None if ij[1] is None else ij[1] + offset[1],
                )
            self.pos = end_t  # the position advances even if the circle is refused
            center, sweep = build_arc(
                start,
                end_t,
                kind is MotionKind.ARC_CCW,
                ij,
                self.center_absolute,
                self.radius,
                self.ctx.max_radius_diff,
                column,
            )
            motion = Motion(kind, start, end_t, feed, center, sweep)
        elif start == end_t:
            self._warn(ErrorId.ZERO_LENGTH, column, "motion block without motion, skipped")
            return None
        else:
            motion = Motion(kind, start, end_t, feed)
        self.pos = end_t
        if not self.trc.engaged:  # under TRC the compensated path is checked (_output)
            if beyond >= 0:
                self.ctx.check_position(beyond, end_t[beyond], column)
            if is_arc:
                self._check_limits(motion, column)
        return motion

    def _check_limits(self, motion: Motion, column: int) -> None:
        # the start was checked as the previous end
        limits = self.ctx.sw_limits
        for k, (value, (neg, pos)) in enumerate(zip(motion.end, limits, strict=True)):
            if not neg - 1e-12 <= value <= pos + 1e-12:
                self.ctx.check_position(k, value, column)
        center = motion.center
        if center is not None:
            r = math.hypot(motion.start[0] - center[0], motion.start[1] - center[1])
            (n0, p0), (n1, p1) = limits[0], limits[1]
            if (
                n0 <= center[0] - r
                and center[0] + r <= p0
                and n1 <= center[1] - r
                and (center[1] + r <= p1)
            ):
                return  # the whole circle is inside: no need for the arc's extent
            arc = ArcSeg.make(motion.start, motion.end, center, motion.sweep)
            for k, (lo, hi) in enumerate(arc.axis_extent()):
                self.ctx.check_position(k, lo, column)
                self.ctx.check_position(k, hi, column)

    # -- lift commands -------------------------------------------------------------------------
    def _lift_start(self, lineno: int, axis: str, words: LiftWords, column: int) -> LiftStart:
        warnings: list[NcError] = []
        zi = self.axis_index.get(axis, self.z)  # any axis of the channel may lift (issue 18)
        self.open_lift = lift_rules.open_range(
            self.ctx, words, axis=axis, z0=self.pos[zi], slope=self.slope,
            open_lift=self.open_lift, lineno=lineno, column=column, warnings=warnings,
            unit=self.unit, offset=self.offset[zi],
        )  # fmt: skip
        for warning in warnings:
            self._warn(ErrorId(warning.id), warning.column, warning.message)
        if self.trc.side != 0 and zi in (0, 1):
            raise NcFault(
                ErrorId.TRC_LIFT_AXIS,
                column,
                f"the lift axis {axis} lies in the plane of the active tool radius "
                "compensation (vendor §2.4: it must not take part in TRC)",
            )
        return self.open_lift

    def _lift_end(self, axis: str, column: int) -> LiftEnd:
        lift_rules.check_end(self.ctx, axis, self.open_lift, column)
        return self._close_lift(LiftEndCause.PROGRAMMED)

    # -- subroutines ---------------------------------------------------------------------------
    def _call(self, frame: _Frame, tok: Token, lineno: int) -> None:
        kind, name, col = tok.letter, tok.text, tok.column
        written = (
            f"{'LL ' if kind == 'LL' else 'L '}{name}"
            if kind != "SEQ"
            else (f"L SEQUENCE [{name}]")
        )
        if len(self.stack) > self.ctx.max_call_depth:
            # https://infosys.beckhoff.com/content/1033/tf5200_diagnosis/251402891.html
            raise NcFault(
                ErrorId.CALL_DEPTH,
                col,
                f"{written}: subroutines nested deeper than {self.ctx.max_call_depth} levels "
                "(endless recursion?)",
            )
        reps = 0
        if kind == "LL":
            source = frame.source
            section: Section | None = source.locals.get(name.upper())
            if section is None:
                raise NcFault(
                    ErrorId.SUBROUTINE_NOT_FOUND,
                    col,
                    f"LL {name}: no local subroutine %L {name} in this file",
                )
            start, end = section.start, section.end
        else:
            target = name
            if kind == "SEQ":
                target, first, last, reps = self._sequence_args(name, col)
            source = frame.source if kind == "SEQ" and not target else self._global(target, col)
            if kind == "SEQ":
                # without NAME the sequence runs in the current program part, else in the
                # named file's main program part
                own = (frame.start, frame.end) if not target else None
                start, end = self._sequence_range(source, first, last, col, own)
            else:
                if source.main is None:
                    raise NcFault(
                        ErrorId.PROGRAM_STRUCTURE,
                        col,
                        f"L {name}: the file has no main program part to run",
                    )
                start, end = source.main.start, source.main.end
        if self.stopped:  # checking only: each body once
            key = (source.name, start)
            if key in self.visited_after_stop:
                return
            self.visited_after_stop.add(key)
            reps = 0
        site = CallSite(self._file(frame) or "(program)", lineno, written)
        tag = "" if source.name == self.ctx.sources.program else source.name
        self.stack.append(_Frame(source, start, end, site, reps, tag))

    def _global(self, name: str, col: int) -> Source:
        cached = self.files.get(name)
        if cached is not None:
            return cached
        if name in self.missing:  # one root cause, one error
            raise _AlreadyReported
        nc_file = self.ctx.sources.find(name)
        if nc_file is None or nc_file.text is None:
            self.missing.add(name)
            reason = nc_file.error if nc_file is not None and nc_file.error else "not found"
            self._error(ErrorId.FILE_NOT_FOUND, col, f"L {name}: global subroutine {reason}")
            raise _AlreadyReported
        source = parse_source(nc_file.path, nc_file.text, called=True)
        self.files[name] = source
        self._source_problems(source)
        return source

    def _source_problems(self, source: Source) -> None:
        for p in source.problems:
            self._error(p.error_id, 1, p.message, line=p.line, file=source.name)

    def _sequence_args(self, content: str, col: int) -> tuple[str, int, int, int]:
        """L SEQUENCE [ [NAME=<file>] N.. [N..] [REPEAT=..] ] (programming manual
        https://infosys.beckhoff.com/content/1033/tf5200_programming_manual/206866443.html);
        REPEAT is read as the number of runs. String labels and ENDTAG are not emulated."""
        name = ""
        numbers: list[int] = []
        repeat = 1
        for item in content.replace(",", " ").split():
            upper = item.upper()
            if upper.startswith("NAME="):
                name = item[5:].strip("\"'")
            elif upper.startswith("REPEAT="):
                try:
                    repeat = int(float(upper[7:]))
                except ValueError:
                    raise NcFault(ErrorId.NUMBER, col, "REPEAT= needs a number") from None
                if repeat < 1:
                    raise NcFault(ErrorId.NUMBER, col, "REPEAT= must be at least 1")
            elif upper.startswith("N") and upper[1:].isdigit():
                numbers.append(int(upper[1:]))
            else:
                raise NcFault(
                    ErrorId.UNSUPPORTED, col, f"L SEQUENCE: {item} is not emulated by liftd"
                )
        if not 1 <= len(numbers) <= 2:
            raise NcFault(ErrorId.SYNTAX, col, "L SEQUENCE needs one or two block numbers N..")
        return name, numbers[0], numbers[-1], repeat - 1

    def _sequence_range(
        self, source: Source, first: int, last: int, col: int, within: tuple[int, int] | None
    ) -> tuple[int, int]:
        if within is None:
            main = source.main
            within = (main.start, main.end) if main is not None else (0, len(source.lines))
        lo, hi = within
        start = source.block_number_line(first, lo, hi)
        if start is None:
            raise NcFault(ErrorId.SEQUENCE_NOT_FOUND, col, f"L SEQUENCE: no block N{first}")
        stop = source.block_number_line(last, start, hi)
        if stop is None:
            raise NcFault(
                ErrorId.SEQUENCE_NOT_FOUND, col, f"L SEQUENCE: no block N{last} after N{first}"
            )
        return start, stop + 1

    # -- # commands ----------------------------------------------------------------------------
    def _command(self, lineno: int, n: int | None, cmd: CommandResult) -> None:
        tag = self._file_tag()
        if cmd.kind is CommandKind.FLUSH:
            assert cmd.flush is not None
            if (
                self.open_lift is not None
                and cmd.flush is not FlushKind.CONTINUE
                and self.ctx.lift_method is not LiftMethod.LIFTING
            ):
                # #FLUSH / #FLUSH WAIT inside a range: implicit LIFT_END + LIFT_START (§2.4),
                # POS reached in the flush block. Path-based Lifting keeps one range and cuts
                # its plan at the flush instead, where Z is at POS_LIMIT (vendor §2.2.3 case 2,
                # lift/path_based.py).
                interrupted = self.open_lift
                end = self._close_lift(LiftEndCause.FLUSH)
                self._emit(Block(lineno, n, flush=cmd.flush, lift_end=end, file=tag))
                restart = interrupted._replace(
                    z_start=interrupted.target, single_block=False, implicit=True
                )
                self.open_lift = restart
                self._emit(Block(lineno, n, lift_start=restart, file=tag))
                return
            self._emit(Block(lineno, n, flush=cmd.flush, file=tag))
        elif cmd.kind in (CommandKind.SLOPE, CommandKind.SLOPE_DEFAULT):
            slope = cmd.slope if cmd.slope is not None else self.ctx.slope
            if (
                slope is SlopeType.HSC
                and self.open_lift is not None
                and self.ctx.lift_method is LiftMethod.ADVANCED
            ):
                raise NcFault(
                    ErrorId.LIFT_HSC_SLOPE,
                    cmd.column,
                    "HSC slope (type 3) is not supported with Advanced Lifting",
                )
            self.slope = slope
            self._emit(Block(lineno, n, slope=slope, file=tag))
        elif cmd.kind is CommandKind.TIME:
            self._emit(Block(lineno, n, dwell=cmd.seconds, file=tag))
        elif cmd.kind is CommandKind.SMOOTHING:
            if cmd.on is not None:
                fault = self._smoothing(SMOOTHING_CMD[cmd.smoothing], cmd.on, cmd.column)
                if fault is not None:
                    raise fault
        elif cmd.kind is CommandKind.TRANSFORM and self.open_lift is not None:
            raise NcFault(
                ErrorId.LIFT_ROTATION_IN_RANGE,
                cmd.column,
                f"{cmd.text.split()[0]} inside the lift range (started in line "
                f"{self.open_lift.line})",
            )
        else:
            raise NcFault(
                ErrorId.UNSUPPORTED,
                cmd.column,
                f"{cmd.text.split()[0]}: coordinate transformations are not emulated",
            )


class _AlreadyReported(NcFault):
    """An error that was reported where it was found (raised to reject its block only)."""

    def __init__(self) -> None:
        super().__init__(ErrorId.FILE_NOT_FOUND, 1, "")


def _chain_text(chain: tuple[CallSite, ...]) -> str:
    """`a.nc:3 LL x > b.nc:7 L y`, repeated calls folded: `b.nc:4 LL again (×20)`."""
    parts: list[str] = []
    last = ""
    count = 0
    for site in chain:
        text = str(site)
        if text == last:
            count += 1
            continue
        if last:
            parts.append(last if count == 1 else f"{last} (×{count})")
        last, count = text, 1
    parts.append(last if count == 1 else f"{last} (×{count})")
    return " > ".join(parts)


def _attempt(faults: list[NcFault], fn: Callable[..., _T], *args: object) -> _T | None:
    """Run one part of a block; its NcFault is kept for the end of the block."""
    try:
        return fn(*args)
    except _AlreadyReported:
        faults.append(_AlreadyReported())
    except NcFault as fault:
        faults.append(fault)
    return None


def _lex_fault(err: LexError) -> NcFault:
    if err.error_id is not None:
        return NcFault(ErrorId(err.error_id), err.column, err.message)
    eid = ErrorId.NUMBER if "number" in err.message else ErrorId.SYNTAX
    return NcFault(eid, err.column, err.message)
