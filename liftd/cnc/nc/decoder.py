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

from collections.abc import Iterator
from typing import cast

from liftd.cnc.nc.blocks import (
    Block,
    CallSite,
    DecodeResult,
    ErrorId,
    LiftEndCause,
    LiftStart,
    NcError,
    NcFault,
    Severity,
    chain_text,
)
from liftd.cnc.nc.calls import SubroutineCalls
from liftd.cnc.nc.commands import CommandKind, CommandResult, parse_command
from liftd.cnc.nc.context import DecoderContext
from liftd.cnc.nc.gfunctions import MOTION_G, SMOOTHING_CMD
from liftd.cnc.nc.lexer import LexError, tokenize
from liftd.cnc.nc.modal import AlreadyReported, attempt
from liftd.cnc.nc.sources import Frame, Source, parse_source
from liftd.cnc.nc.trc import TrcFault
from liftd.cnc.nc.words import Template, Words, collect_plain, template
from liftd.cnc.params import LiftMethod, SlopeType
from liftd.cnc.pause import pause, release

LINE_CACHE = 4096  # distinct lines prepared once and reused by their text (bounded memory)


def decode(text: str, ctx: DecoderContext) -> DecodeResult:
    """Decode a whole program. Never raises for any text: problems come back as NcErrors."""
    dec = _Decoder(ctx)
    blocks = tuple(dec.run(text))
    result = dec.result(blocks)
    dec.release()
    return result


def iter_decode(text: str, ctx: DecoderContext) -> tuple[Iterator[Block], _Decoder]:
    """The blocks as a stream, and the decoder whose `result(())` holds the errors once the
    stream is exhausted (memory bounded by the program text, not by its expansion)."""
    dec = _Decoder(ctx)
    return dec.run(text), dec


class _Decoder(SubroutineCalls):
    def __init__(self, ctx: DecoderContext) -> None:
        super().__init__(ctx)
        self.out: list[Block] = []
        self.errors: list[NcError] = []
        self.seen: set[tuple[str, int, int, int]] = set()
        self.stopped = False  # an error was found: no further blocks are executed
        self.open_at_error: LiftStart | None = None  # lift range open at the first error
        self.stack: list[Frame] = []
        self.main_source: Source | None = None
        self.files: dict[str, Source] = {}
        self.line_cache: dict[str, Words | Template] = {}  # prepared lines by their text
        self.missing: set[str] = set()
        self.visited_after_stop: set[tuple[str, int]] = set()
        self.not_emulated: dict[str, int] = {}
        self.executed = 0
        self.line = 0  # the line being decoded, for messages
        self.last_line = 0
        self.last_file = ""

    # -- program flow --------------------------------------------------------------------------
    def run(self, text: str) -> Iterator[Block]:
        main = self.main_source = parse_source(self.ctx.sources.program, text)
        self._source_problems(main)
        if main.main is None:
            self._error(
                ErrorId.PROGRAM_STRUCTURE, 1, "no main program part (a % line after the local "
                "subroutines)", line=1,
            )  # fmt: skip
        else:
            self.stack.append(Frame(main, main.main.start, main.main.end, None))
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
            pause()  # a line's work at most between two pause points
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

    def release(self) -> None:
        """Free the files' lines and prepared lines a piece at a time (pause.py)."""
        for source in [self.main_source, *self.files.values()]:
            if source is not None:
                cached = list(source.cache.values())
                source.cache.clear()
                release(cached)
                release(cast(list[object], source.lines))
        cached = list(self.line_cache.values())
        self.line_cache.clear()
        release(cached)

    def result(self, blocks: tuple[Block, ...]) -> DecodeResult:
        return DecodeResult(
            blocks,
            tuple(self.errors),
            self.open_at_error,
            tuple(self.not_emulated.items()),
            self.executed,
        )

    def _run_line(self, frame: Frame, idx: int) -> None:
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
        if isinstance(err, AlreadyReported):
            return
        if isinstance(err, TrcFault):
            b = err.block
            self._error(err.error_id, err.column, err.message, line=b.line,
                        file=b.file or self.ctx.sources.program)  # fmt: skip
            return
        self._error(err.error_id, err.column, err.message)

    def _leave(self, frame: Frame) -> None:
        """The end of a section: M17 was left out (allowed), or the file ends."""
        if frame.comment is not None:
            line = frame.comment
            frame.comment = None
            self._error(ErrorId.COMMENT_OPEN, 1, "#COMMENT BEGIN without #COMMENT END",
                        line=line, file=frame.source.name)  # fmt: skip
        self._return(frame)

    def _return(self, frame: Frame) -> None:
        if frame.reps > 0:
            frame.reps -= 1
            frame.pos = frame.start
            return
        self.stack.pop()

    def _chain(self) -> tuple[CallSite, ...]:
        return tuple(f.site for f in self.stack if f.site is not None)

    def _depth(self) -> int:
        return len(self.stack)

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
            message += f" (call chain: {chain_text(chain)})"
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
                    self.ctx.check_motion(motion, 1)
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

    # -- one line ----------------------------------------------------------------------------
    def _words(self, frame: Frame, idx: int, line: str) -> Words:
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

    def _line(self, frame: Frame, idx: int, line: str) -> None:
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
                attempt([], self._call, frame, w.call, lineno)
            return
        if block is not None:
            self._emit(block)
        if w.call is not None:
            self._call(frame, w.call, lineno)

    # -- # commands ----------------------------------------------------------------------------
    def _command(self, lineno: int, n: int | None, cmd: CommandResult) -> None:
        tag = self._file_tag()
        if cmd.kind is CommandKind.FLUSH:
            # inside a lift range too: a flush, not an implicit LIFT_END + LIFT_START (§2.4).
            # The lift follows its method's own passage (issue 37 item 2): Advanced Lifting
            # plans on across it and the path may have to wait there for Z (§2.1.3 case 3,
            # lift_ahead.py); path-based Lifting cuts its plan there at POS_LIMIT (§2.2.3
            # case 2, lift/path_based.py)
            assert cmd.flush is not None
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
        elif cmd.kind is CommandKind.TRANSVELMIN:
            v_min = cmd.value * self.unit / 60.0 if cmd.on else 0.0
            self._emit(Block(lineno, n, trans_vel_min=v_min, file=tag))
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


def _lex_fault(err: LexError) -> NcFault:
    if err.error_id is not None:
        return NcFault(ErrorId(err.error_id), err.column, err.message)
    eid = ErrorId.NUMBER if "number" in err.message else ErrorId.SYNTAX
    return NcFault(eid, err.column, err.message)
