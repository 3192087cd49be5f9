"""NC decoder: text → typed blocks with absolute positions (m), lift ranges and ISG error ids.

Execution stops at the first error ("the path motion is always executed up to the last
correctly decoded point", vendor text §2.1.3 case 2), but decoding goes on so that `liftd check`
can report every problem of a program.
"""

from __future__ import annotations

from liftd.cnc import units
from liftd.cnc.nc import lift_rules
from liftd.cnc.nc.arcs import build_arc
from liftd.cnc.nc.blocks import (
    Block,
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
from liftd.cnc.nc.lexer import LexError, tokenize
from liftd.cnc.nc.lift_words import LiftKeyword, LiftWords
from liftd.cnc.nc.words import Words, collect, collect_plain
from liftd.cnc.params import LiftMethod, SlopeType
from liftd.cnc.path.geometry import ArcSeg

# M functions the ISG kernel handles internally when m_synch does not configure them
# (P-CHAN-00041 default NO_SYNCH for M0/1/2/17/29/30/3/4/19, isg-cnc.md §3.3); any other
# unconfigured M function is an error.
INTERNAL_M = frozenset({0, 1, 2, 3, 4, 17, 19, 29, 30})
MOTION_G = {0: MotionKind.RAPID, 1: MotionKind.LINEAR, 2: MotionKind.ARC_CW, 3: MotionKind.ARC_CCW}
INF = float("inf")
MODE_G = frozenset({17, 71, 94, 163})  # XY plane, metric, F in mm/min, radius programming


def decode(text: str, ctx: DecoderContext) -> DecodeResult:
    """Decode a whole program. Never raises for any text: problems come back as NcErrors."""
    return _Decoder(ctx).run(text)


class _Decoder:
    def __init__(self, ctx: DecoderContext) -> None:
        self.ctx = ctx
        self.pos = tuple(ctx.start_position)
        self.z = ctx.axis_names.index(ctx.lift_axis)
        self.axes = frozenset(ctx.axis_names)
        self.motion = MotionKind.LINEAR
        self.incremental = False
        self.center_absolute = False  # G161 absolute, G162 (default) relative centre
        self.feed: float | None = None  # m/s
        self.radius: float | None = None  # m, modal R
        self.slope = ctx.slope
        self.open_lift: LiftStart | None = None
        self.blocks: list[Block] = []
        self.errors: list[NcError] = []
        self.stopped = False  # an error was found: no further blocks are executed
        self.open_at_error: LiftStart | None = None  # lift range open at the first error
        self.ended = False  # M02/M30 seen

    def run(self, text: str) -> DecodeResult:
        in_comment: int | None = None
        last_line = 0
        for lineno, line in enumerate(text.splitlines(), start=1):
            last_line = lineno
            head = line.lstrip()
            if head.startswith("#"):
                upper = " ".join(head.upper().split())
                if in_comment is not None:
                    if upper.startswith("#COMMENT END"):
                        in_comment = None
                    continue
                if upper.startswith("#COMMENT BEGIN"):
                    in_comment = lineno
                    continue
            if in_comment is not None:
                continue
            if not head or head.startswith("%") or self.ended:
                continue  # blank, program name, text after M30/M02
            try:
                self._line(lineno, line)
            except NcFault as err:
                self._error(lineno, err.error_id, err.column, err.message)
            except LexError as err:
                eid = ErrorId.NUMBER if "number" in err.message else ErrorId.SYNTAX
                self._error(lineno, eid, err.column, err.message)
        if in_comment is not None:
            self._error(in_comment, ErrorId.COMMENT_OPEN, 1, "#COMMENT BEGIN without #COMMENT END")
        if self.open_lift is not None and not self.stopped and not self.ended:
            self._emit(Block(last_line, lift_end=self._close_lift(LiftEndCause.PROGRAM_END)))
        return DecodeResult(tuple(self.blocks), tuple(self.errors), self.open_at_error)

    # -- helpers ---------------------------------------------------------------------------
    def _error(self, line: int, eid: ErrorId, column: int, message: str) -> None:
        self.errors.append(NcError(int(eid), line, column, message))
        if not self.stopped:
            self.open_at_error = self.open_lift
        self.stopped = True

    def _emit(self, block: Block) -> None:
        if block.motion is not None:
            if not self.stopped:
                self.blocks.append(block)
            return
        empty = (
            block.motion is None
            and block.dwell is None
            and not block.m_functions
            and block.flush is None
            and block.slope is None
            and block.lift_start is None
            and block.lift_end is None
            and not block.program_end
        )
        if not self.stopped and not empty:
            self.blocks.append(block)

    def _close_lift(self, cause: LiftEndCause) -> LiftEnd:
        assert self.open_lift is not None
        start = self.open_lift
        pos = list(self.pos)
        pos[self.z] = start.target
        self.pos = tuple(pos)
        self.open_lift = None
        return LiftEnd(start.axis, cause, start.line)

    # -- one line ----------------------------------------------------------------------------
    def _line(self, lineno: int, line: str) -> None:
        plain = None
        if "[" not in line and "#" not in line and "(" not in line and ";" not in line:
            plain = collect_plain(line, self.axes)
        w = plain if plain is not None else collect(tokenize(line), self.axes)
        if w.command is not None:
            self._command(lineno, w.n, parse_command(w.command))
            return
        values = w.values
        dwell = self._gcodes(w) if w.gcodes else False
        feed_word = values.get("F")
        if feed_word is not None:
            if feed_word[0] <= 0.0:
                raise NcFault(ErrorId.FEED_ZERO, feed_word[1], "feed rate F must be > 0")
            self.feed = units.mm_min_to_m_s(feed_word[0])
        if "R" in values:
            self.radius = units.mm_to_m(values["R"][0])
        if "K" in values:
            raise NcFault(
                ErrorId.UNSUPPORTED,
                values["K"][1],
                "K (G18/G19 circles) is not emulated; liftd circles are in the G17 plane",
            )
        if dwell:
            self._emit(Block(lineno, w.n, dwell=self._dwell(lineno, w)))
            return
        m_funcs, program_end = self._m_functions(w) if w.m else ((), False)
        lift = w.lift[1] if w.lift is not None else None
        start: LiftStart | None = None
        if lift is not None and lift.keyword in (LiftKeyword.START, LiftKeyword.SINGLE):
            assert w.lift is not None
            start = self._lift_start(lineno, w.lift[0], lift, w.lift[2])
        motion = self._motion(lineno, w)
        end: LiftEnd | None = None
        if lift is not None and lift.keyword is LiftKeyword.SINGLE:
            end = self._close_lift(LiftEndCause.SINGLE_BLOCK)
        elif lift is not None and lift.keyword is LiftKeyword.END:
            assert w.lift is not None
            end = self._lift_end(w.lift[0], w.lift[2])
        if program_end and self.open_lift is not None and end is None:
            end = self._close_lift(LiftEndCause.PROGRAM_END)  # vendor §2.4
        self._emit(
            Block(
                lineno,
                w.n,
                motion=motion,
                m_functions=m_funcs,
                lift_start=start,
                lift_end=end,
                program_end=program_end,
            )
        )
        self.ended = program_end

    def _gcodes(self, w: Words) -> bool:
        dwell = False
        motion_seen = False
        for code, col in w.gcodes:
            if code in MOTION_G:
                if motion_seen:
                    raise NcFault(ErrorId.AXIS_TWICE, col, "two motion G functions in one block")
                motion_seen = True
                self.motion = MOTION_G[code]
            elif code == 4:
                dwell = True
            elif code in (90, 91):
                self.incremental = code == 91
            elif code in (161, 162):
                self.center_absolute = code == 161
            elif code not in MODE_G:
                raise NcFault(ErrorId.UNSUPPORTED, col, f"G{code:02d} is not emulated by liftd")
        return dwell

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
                self.errors.append(
                    NcError(
                        int(ErrorId.DWELL_WITH_AXES),
                        lineno,
                        col,
                        f"{letter} in a G04 block is ignored",
                        Severity.WARNING,
                    )
                )
        return chosen[0]

    def _m_functions(self, w: Words) -> tuple[tuple[int, ...], bool]:
        numbers = []
        for number, col in w.m:
            if number in (17, 29):
                raise NcFault(ErrorId.UNSUPPORTED, col, "subprograms are not emulated by liftd")
            if number not in INTERNAL_M and number not in self.ctx.configured_m:
                raise NcFault(
                    ErrorId.M_NOT_CONFIGURED,
                    col,
                    f"M{number} has no synchronisation "
                    "configured (m_synch[...] in the channel list, P-CHAN-00041)",
                )
            numbers.append(number)
        return tuple(numbers), any(n in (2, 30) for n in numbers)

    def _motion(self, lineno: int, w: Words) -> Motion | None:
        values = w.values
        start = self.pos
        end = list(start)
        column = 0  # column of the first axis word, for messages
        for k, name in enumerate(self.ctx.axis_names):
            word = values.get(name)
            if word is not None:
                value = word[0] * units.M_PER_MM
                end[k] = start[k] + value if self.incremental else value
                if not column or word[1] < column:
                    column = word[1]
        kind = self.motion
        is_arc = kind is MotionKind.ARC_CW or kind is MotionKind.ARC_CCW
        if not column:
            if not (is_arc and ("I" in values or "J" in values)):
                return None
            column = min(col for _, col in values.values())
        lift_word = values.get(self.ctx.lift_axis)
        if self.open_lift is not None and lift_word is not None:
            raise NcFault(
                ErrorId.LIFT_AXIS_PROGRAMMED,
                lift_word[1],
                f"the lift axis {self.ctx.lift_axis} must not be programmed inside a lift range",
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
            ij = (units.mm_to_m(i[0]) if i else None, units.mm_to_m(j[0]) if j else None)
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
            self.errors.append(
                NcError(
                    int(ErrorId.ZERO_LENGTH),
                    lineno,
                    column,
                    "motion block without motion, skipped",
                    Severity.WARNING,
                )
            )
            return None
        else:
            motion = Motion(kind, start, end_t, feed)
        self._check_limits(motion, column)
        self.pos = end_t
        return motion

    def _check_limits(self, motion: Motion, column: int) -> None:
        # the start was checked as the previous end
        for k, (value, (neg, pos)) in enumerate(zip(motion.end, self.ctx.sw_limits, strict=True)):
            if not neg - 1e-12 <= value <= pos + 1e-12:
                self.ctx.check_position(k, value, column)
        if motion.center is not None:
            arc = ArcSeg.make(motion.start, motion.end, motion.center, motion.sweep)
            for k, (lo, hi) in enumerate(arc.axis_extent()):
                self.ctx.check_position(k, lo, column)
                self.ctx.check_position(k, hi, column)

    # -- lift commands -------------------------------------------------------------------------
    def _lift_start(self, lineno: int, axis: str, words: LiftWords, column: int) -> LiftStart:
        self.open_lift = lift_rules.open_range(
            self.ctx, words, axis=axis, z0=self.pos[self.z], slope=self.slope,
            open_lift=self.open_lift, lineno=lineno, column=column, warnings=self.errors,
        )  # fmt: skip
        return self.open_lift

    def _lift_end(self, axis: str, column: int) -> LiftEnd:
        lift_rules.check_end(self.ctx, axis, self.open_lift, column)
        return self._close_lift(LiftEndCause.PROGRAMMED)

    # -- # commands ----------------------------------------------------------------------------
    def _command(self, lineno: int, n: int | None, cmd: CommandResult) -> None:
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
                self._emit(Block(lineno, n, flush=cmd.flush, lift_end=end))
                restart = LiftStart(
                    interrupted.axis,
                    interrupted.target,
                    interrupted.target,
                    interrupted.pos_limit,
                    interrupted.down,
                    interrupted.line,
                    implicit=True,
                )
                self.open_lift = restart
                self._emit(Block(lineno, n, lift_start=restart))
                return
            self._emit(Block(lineno, n, flush=cmd.flush))
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
            self._emit(Block(lineno, n, slope=slope))
        elif cmd.kind is CommandKind.TIME:
            self._emit(Block(lineno, n, dwell=cmd.seconds))
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
