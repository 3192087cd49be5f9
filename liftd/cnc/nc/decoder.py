"""NC decoder: text → typed blocks with absolute machine positions (m), lift ranges and ISG
error ids.

The map: `ProgramDecoder` (here) runs the program's lines and holds its parts, each owning its
own state: `report.Report` (where the decoder is: the frame stack and the line; the errors,
warnings and not-emulated counts), `gfunctions.GFunctions` (the G functions' modal state:
motion mode, G90/G91, units, zero offsets, the tool radius compensation's selection),
`modal.ModalDecoder` (the rest of the modal state and one block's interpretation: position, F,
R, P parameters, M functions, the lift ranges), `execution.Execution` (the blocks run, through
tool radius compensation, and the stop at the first error) and `calls.SubroutineCalls` (the
subroutine files and the frames a call pushes). Each part reports through the `Report` it is
given; nothing reaches back into the program decoder.

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

from liftd.cnc.nc.blocks import Block, DecodeResult, ErrorId, LiftEndCause, NcFault
from liftd.cnc.nc.calls import SubroutineCalls
from liftd.cnc.nc.commands import CommandKind, CommandResult, parse_command
from liftd.cnc.nc.context import DecoderContext
from liftd.cnc.nc.execution import Execution
from liftd.cnc.nc.gfunctions import MOTION_G, SMOOTHING_CMD, GFunctions
from liftd.cnc.nc.lexer import LexError, tokenize
from liftd.cnc.nc.modal import ModalDecoder, attempt
from liftd.cnc.nc.report import AlreadyReported, Report
from liftd.cnc.nc.sources import Frame, Source, parse_source
from liftd.cnc.nc.trc import TrcFault
from liftd.cnc.nc.words import Template, Words, collect_plain, template
from liftd.cnc.params import LiftMethod, SlopeType
from liftd.cnc.pause import pause, release

LINE_CACHE = 4096  # distinct lines prepared once and reused by their text (bounded memory)


def decode(text: str, ctx: DecoderContext) -> DecodeResult:
    """Decode a whole program. Never raises for any text: problems come back as NcErrors."""
    dec = ProgramDecoder(ctx)
    blocks = tuple(dec.run(text))
    result = dec.result(blocks)
    dec.release()
    return result


def iter_decode(text: str, ctx: DecoderContext) -> tuple[Iterator[Block], ProgramDecoder]:
    """The blocks as a stream, and the decoder whose `result(())` holds the errors once the
    stream is exhausted (memory bounded by the program text, not by its expansion)."""
    dec = ProgramDecoder(ctx)
    return dec.run(text), dec


class ProgramDecoder:
    """One program's decoder. It holds its parts (the map at the top of this module) and owns
    the program flow: the main source, the lines prepared once, the count of lines run."""

    def __init__(self, ctx: DecoderContext) -> None:
        self.ctx = ctx
        self.report = Report(ctx.sources.program)
        self.stack = self.report.stack  # the frame stack: run here, pushed by `calls`
        self.gfunctions = GFunctions(ctx, self.report)
        self.modal = ModalDecoder(ctx, self.gfunctions, self.report)
        self.execution = Execution(ctx, self.report, self.modal, self.gfunctions.trc)
        self.calls = SubroutineCalls(ctx, self.report, self.execution)
        self.main_source: Source | None = None
        self.line_cache: dict[str, Words | Template] = {}  # prepared lines by their text
        self.executed = 0
        self.last_line = 0
        self.last_file = ""

    # -- program flow --------------------------------------------------------------------------
    def run(self, text: str) -> Iterator[Block]:
        main = self.main_source = parse_source(self.ctx.sources.program, text)
        self.calls.source_problems(main)
        if main.main is None:
            message = "no main program part (a % line after the local subroutines)"
            self.execution.error(ErrorId.PROGRAM_STRUCTURE, 1, message, line=1)
        else:
            self.stack.append(Frame(main, main.main.start, main.main.end, None))
        limit = self.ctx.max_executed_blocks
        modal = self.modal
        execution = self.execution
        out = execution.out
        while self.stack and not modal.ended:
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
                where = frame.source.name
                execution.error(ErrorId.EXPANSION_LIMIT, 1, message, line=idx + 1, file=where)
                break
            self._run_line(frame, idx)
            pause()  # a line's work at most between two pause points
            if out:
                yield from out
                out.clear()
        if not execution.stopped:
            execution.flush()
        if modal.open_lift is not None and not execution.stopped and not modal.ended:
            end = modal.close_lift(LiftEndCause.PROGRAM_END)
            execution.emit(Block(self.last_line, lift_end=end, file=self.last_file))
        yield from out
        out.clear()

    def release(self) -> None:
        """Free the files' lines and prepared lines a piece at a time (pause.py)."""
        for source in [self.main_source, *self.calls.files.values()]:
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
            tuple(self.report.errors),
            self.execution.open_at_error,
            tuple(self.report.not_emulated.items()),
            self.executed,
        )

    def _run_line(self, frame: Frame, idx: int) -> None:
        line = frame.source.lines[idx]
        lineno = idx + 1
        self.report.line = lineno
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
        modal = self.modal
        self.last_file = modal.tag = frame.tag
        try:
            self._line(frame, idx, line)
        except NcFault as err:
            self._report(err)
        if modal.return_after:
            modal.return_after = False
            if self.stack and self.stack[-1] is frame:
                self._return(frame)

    def _report(self, err: NcFault) -> None:
        if isinstance(err, AlreadyReported):
            return
        if isinstance(err, TrcFault):
            b = err.block
            where = b.file or self.ctx.sources.program
            self.execution.error(err.error_id, err.column, err.message, line=b.line, file=where)
            return
        self.execution.error(err.error_id, err.column, err.message)

    def _leave(self, frame: Frame) -> None:
        """The end of a section: M17 was left out (allowed), or the file ends."""
        if frame.comment is not None:
            line = frame.comment
            frame.comment = None
            message = "#COMMENT BEGIN without #COMMENT END"
            where = frame.source.name
            self.execution.error(ErrorId.COMMENT_OPEN, 1, message, line=line, file=where)
        self._return(frame)

    def _return(self, frame: Frame) -> None:
        if frame.reps > 0:
            frame.reps -= 1
            frame.pos = frame.start
            return
        self.stack.pop()

    # -- one line ----------------------------------------------------------------------------
    def _words(self, frame: Frame, idx: int, line: str) -> Words:
        axes = self.modal.axes
        cache = frame.source.cache if frame.cached else None
        if cache is not None:
            hit = cache.get(idx)
            if hit is not None:
                if isinstance(hit, Words):
                    return hit
                assert isinstance(hit, Template)
                return hit.words(axes, self.modal.params)
        if "[" not in line and "#" not in line and "(" not in line and ";" not in line:
            plain = collect_plain(line, axes)
            if plain is not None:
                if cache is not None:
                    cache[idx] = plain
                return plain
        prepared = self.line_cache.get(line)
        if prepared is None:
            errors: list[LexError] = []
            tokens = tokenize(line, errors)
            prepared = template(tokens, axes, [_lex_fault(e) for e in errors])
            if len(self.line_cache) < LINE_CACHE:  # recurring lines: lift commands, calls
                self.line_cache[line] = prepared
        if cache is not None:
            cache[idx] = prepared
        if isinstance(prepared, Words):
            return prepared
        return prepared.words(axes, self.modal.params)

    def _line(self, frame: Frame, idx: int, line: str) -> None:
        w = self._words(frame, idx, line)
        lineno = idx + 1
        modal = self.modal
        execution = self.execution
        if w.simple:  # the common block: axis words only (the fast path, same semantics)
            motion = modal.motion_of(lineno, w)
            if motion is not None and not execution.stopped:
                simple = Block(lineno, w.n, motion, None, (), None, None, None, None, False,
                               modal.tag)  # fmt: skip
                if execution.trc.engaged:
                    execution.emit(simple)
                else:
                    execution.out.append(simple)
            return
        g = w.fast_g
        if g >= 0:  # G00..G03 with axis words, F, I, J, R: as _block would, fewer checks
            values = w.values
            feed = values.get("F")
            if feed is None or feed[0] > 0.0:
                unit = self.gfunctions.unit
                self.gfunctions.motion = MOTION_G[g]
                if feed is not None:
                    modal.feed = feed[0] * unit / 60.0
                radius = values.get("R")
                if radius is not None:
                    modal.radius = radius[0] * unit
                motion = modal.motion_of(lineno, w)
                if not execution.stopped:
                    execution.emit(Block(lineno, w.n, motion, None, (), None, None, None, None,
                                         False, modal.tag))  # fmt: skip
                return
        if w.command is not None and not w.faults:
            self._command(lineno, w.n, parse_command(w.command))
            return
        fault = w.faults[0] if w.faults else None
        block: Block | None = None
        try:
            block = modal.interpret(lineno, w)
        except NcFault as err:
            if fault is None:
                fault = err
        if fault is not None:
            self._report(fault)
            if w.call is not None:  # the call is checked even in a rejected block
                attempt([], self.calls.call, frame, w.call, lineno)
            return
        if block is not None:
            execution.emit(block)
        if w.call is not None:
            self.calls.call(frame, w.call, lineno)

    # -- # commands ----------------------------------------------------------------------------
    def _command(self, lineno: int, n: int | None, cmd: CommandResult) -> None:
        modal = self.modal
        emit = self.execution.emit
        tag = modal.tag
        if cmd.kind is CommandKind.FLUSH:
            # inside a lift range too: a flush, not an implicit LIFT_END + LIFT_START (§2.4).
            # The lift follows its method's own passage (issue 37 item 2): Advanced Lifting
            # plans on across it and the path may have to wait there for Z (§2.1.3 case 3,
            # lift_ahead.py); path-based Lifting cuts its plan there at POS_LIMIT (§2.2.3
            # case 2, lift/path_based.py)
            assert cmd.flush is not None
            emit(Block(lineno, n, flush=cmd.flush, file=tag))
        elif cmd.kind in (CommandKind.SLOPE, CommandKind.SLOPE_DEFAULT):
            slope = cmd.slope if cmd.slope is not None else self.ctx.slope
            if (
                slope is SlopeType.HSC
                and modal.open_lift is not None
                and self.ctx.lift_method is LiftMethod.ADVANCED
            ):
                raise NcFault(
                    ErrorId.LIFT_HSC_SLOPE,
                    cmd.column,
                    "HSC slope (type 3) is not supported with Advanced Lifting",
                )
            modal.slope = slope
            emit(Block(lineno, n, slope=slope, file=tag))
        elif cmd.kind is CommandKind.TIME:
            emit(Block(lineno, n, dwell=cmd.seconds, file=tag))
        elif cmd.kind is CommandKind.TRANSVELMIN:
            v_min = cmd.value * self.gfunctions.unit / 60.0 if cmd.on else 0.0
            emit(Block(lineno, n, trans_vel_min=v_min, file=tag))
        elif cmd.kind is CommandKind.SMOOTHING:
            if cmd.on is not None:
                kind = SMOOTHING_CMD[cmd.smoothing]
                fault = self.gfunctions.smoothing(kind, cmd.on, cmd.column, modal.open_lift)
                if fault is not None:
                    raise fault
        elif cmd.kind is CommandKind.TRANSFORM and modal.open_lift is not None:
            raise NcFault(
                ErrorId.LIFT_ROTATION_IN_RANGE,
                cmd.column,
                f"{cmd.text.split()[0]} inside the lift range (started in line "
                f"{modal.open_lift.line})",
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
