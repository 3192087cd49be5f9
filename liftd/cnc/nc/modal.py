"""One NC block against the decoder's modal state: `ModalDecoder` owns the position, F, R, the
P parameters, the slope, the lift range open (or refused) and the program end, and interprets a
block's words: the motion target, dwell, M functions and the lift commands, applying its G
functions through the `GFunctions` it holds (`gfunctions.py`: G groups, zero offsets,
inch/metric, tool radius compensation's selection, smoothing). Every part of a block that can be
applied is applied, so a rejected word does not take the block's modal state with it; the first
problem is raised as an `NcFault` at the end of the block. The program decoder (`decoder.py`)
holds it and runs the lines, the subroutines and the reporting.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TypeVar

from liftd.cnc.nc import lift_rules
from liftd.cnc.nc.arcs import build_arc
from liftd.cnc.nc.blocks import (
    Block,
    ErrorId,
    LiftEnd,
    LiftEndCause,
    LiftStart,
    Motion,
    MotionKind,
    NcError,
    NcFault,
)
from liftd.cnc.nc.context import DecoderContext
from liftd.cnc.nc.expr import Params
from liftd.cnc.nc.gfunctions import GFunctions
from liftd.cnc.nc.lift_words import LiftKeyword, LiftWords
from liftd.cnc.nc.report import AlreadyReported, Report
from liftd.cnc.nc.words import Words

# M functions the ISG kernel handles internally when m_synch does not configure them
# (P-CHAN-00041 default NO_SYNCH for M0/1/2/17/29/30/3/4/19, docs/reference/isg-cnc.md §3.3); any
# other unconfigured M function is an error.
INTERNAL_M = frozenset({0, 1, 2, 3, 4, 17, 19, 29, 30})
INF = float("inf")
REFUSED_FEED = 0.1  # m/s: stands in after a refused F (those blocks never run)
_T = TypeVar("_T")


class ModalDecoder:
    """The modal state of one channel's decoder and the interpretation of one block."""

    def __init__(self, ctx: DecoderContext, gfunctions: GFunctions, report: Report) -> None:
        self.ctx = ctx
        self.gfunctions = gfunctions  # the G functions' modal state
        self.report = report  # warnings, and the call depth (M17/M29, M02/M30)
        self.pos = tuple(ctx.start_position)
        self.z = gfunctions.z  # the configured lift axis
        self.axes = frozenset(ctx.axis_names)
        self.axis_index = gfunctions.axis_index
        self.limits = tuple((lo - 1e-12, hi + 1e-12) for lo, hi in ctx.sw_limits)
        self.feed: float | None = None  # m/s
        # an F word was refused while no feed was in effect: the blocks after it that need one
        # are that error's consequence, not errors of their own (the program stops at the
        # first error, so they never run)
        self.feed_refused = False
        self.radius: float | None = None  # m, modal R
        self.slope = ctx.slope
        self.params: Params = {}
        self.open_lift: LiftStart | None = None
        # (axis, line) of a refused LIFT_START (POS_LIMIT missing, POS beyond the software
        # limit, HSC slope ...): its range counts as started until its LIFT_END, which closes
        # it silently, so one root cause gives one error (not a 21559 at the LIFT_END, nor a
        # silent second LIFT_START)
        self.refused_lift: tuple[str, int] | None = None
        self.ended = False  # M02/M30 seen
        self.return_after = False  # M17/M29 in this block
        self.tag = ""  # Block.file of the line being decoded

    # -- modal state ---------------------------------------------------------------------------
    def close_lift(self, cause: LiftEndCause) -> LiftEnd:
        assert self.open_lift is not None
        start = self.open_lift
        pos = list(self.pos)
        pos[self.axis_index[start.axis]] = start.target
        self.pos = tuple(pos)
        self.open_lift = None
        return LiftEnd(start.axis, cause, start.line)

    def interpret(self, lineno: int, w: Words) -> Block | None:
        """Interpret one block's words: every part that can be applied is applied (modal G
        functions, F, R, D, the motion, the lift command), so that a rejected word does not
        take the block's modal state with it; the first problem is raised at the end."""
        values = w.values
        faults: list[NcFault] = []
        dwell = g92 = False
        if w.refused_start is not None and self.open_lift is None and self.refused_lift is None:
            self.refused_lift = (w.refused_start, lineno)  # its words could not be read
        if w.gcodes:
            dwell, g92 = self.gfunctions.apply(w, faults, self.open_lift)
        if w.bare and (not dwell or len(w.bare) > 1):
            # A value without an address letter is the time of G04 only (`G04 2.5`, TF5200
            # programming manual, dwell time: https://infosys.beckhoff.com/content/1033/
            # tf5200_programming_manual/206132747.html); elsewhere (`G01 X10 5`: a lost axis
            # letter) it was dropped silently. No kernel id found for it: liftd's syntax error.
            col = w.bare[1 if dwell else 0][1]
            message = "a value without an address letter (only G04 takes one: its time)"
            faults.append(NcFault(ErrorId.SYNTAX, col, message))
        feed_word = values.get("F")
        if dwell and not w.bare and self.ctx.axis_names[0] not in values:
            feed_word = None  # G04 F<s>: F is the time there (lenient form), not a feed rate
        if feed_word is not None:
            if feed_word[0] <= 0.0:
                faults.append(NcFault(ErrorId.FEED_ZERO, feed_word[1], "feed rate F must be > 0"))
                self.feed_refused = self.feed is None
            else:
                self.feed = (
                    feed_word[0] * self.gfunctions.unit / 60.0
                )  # mm/min (G71) or inch/min (G70)
        if "R" in values:
            self.radius = values["R"][0] * self.gfunctions.unit
        if "D" in values:
            attempt(faults, self.gfunctions.tool, values["D"])
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
            self.gfunctions.g92_words(w)
        elif dwell:
            seconds = attempt(faults, self._dwell, lineno, w)
            if seconds is not None:
                # its M functions, lift command and program end as in any block (they were
                # dropped unchecked: `G04 X1 M30` never ended the program, M1234 was no error)
                block = self._motion_block(lineno, w, faults, dwell=seconds)
        else:
            block = self._motion_block(lineno, w, faults)
        if faults:
            raise faults[0]
        return block

    def _motion_block(
        self, lineno: int, w: Words, faults: list[NcFault], dwell: float | None = None
    ) -> Block:
        """A block's motion (none in a G04 block: its axis word is the time), M functions,
        lift command and program end."""
        m = attempt(faults, self._m_functions, w) if w.m else None
        m_funcs, program_end = m if m is not None else ((), False)
        lift = w.lift[1] if w.lift is not None else None
        start: LiftStart | None = None
        if lift is not None and lift.keyword in (LiftKeyword.START, LiftKeyword.SINGLE):
            assert w.lift is not None
            start = attempt(faults, self._lift_start, lineno, w.lift[0], lift, w.lift[2])
        motion: Motion | None = None
        try:
            motion = self.motion_of(lineno, w) if dwell is None else None
        except NcFault as fault:
            faults.append(fault)
        end: LiftEnd | None = None
        if lift is not None and lift.keyword is LiftKeyword.SINGLE:
            # the single block's own range (also when refused after it opened, 990029); a
            # refused LIFT inside an open range (120604) leaves that range open
            if self.open_lift is not None and self.open_lift.single_block:
                end = self.close_lift(LiftEndCause.SINGLE_BLOCK)
        elif lift is not None and lift.keyword is LiftKeyword.END:
            assert w.lift is not None
            end = attempt(faults, self._lift_end, w.lift[0], w.lift[2])
        if program_end and self.open_lift is not None and end is None:
            end = self.close_lift(LiftEndCause.PROGRAM_END)  # vendor §2.4
        if program_end:
            self.refused_lift = None
        self.ended = program_end
        return Block(
            lineno,
            w.n,
            motion=motion,
            dwell=dwell,
            m_functions=m_funcs,
            lift_start=start,
            lift_end=end,
            program_end=program_end,
            file=self.tag,
        )

    def _dwell(self, lineno: int, w: Words) -> float:
        """G04 X<s> (first main axis), G04 <s>, lenient G04 F<s> (docs/reference/isg-cnc.md
        §4.9)."""
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
                self.report.warn(
                    ErrorId.DWELL_WITH_AXES, col, f"{letter} in a G04 block is ignored"
                )
        return chosen[0]

    def _m_functions(self, w: Words) -> tuple[tuple[int, ...], bool]:
        numbers = []
        end = False
        for number, col in w.m:
            if number in (17, 29):
                if self.report.depth() <= 1:
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
                if self.report.depth() > 1:
                    # the manual: a program abort with M02/M30 in a subroutine gives a warning
                    self.report.warn(
                        ErrorId.PROGRAM_END_IN_SUBROUTINE,
                        col,
                        f"M{number:02d} in a subroutine ends the whole program",
                    )
            numbers.append(number)
        return tuple(numbers), end

    def motion_of(self, lineno: int, w: Words) -> Motion | None:
        values = w.values
        start = self.pos
        end = list(start)
        column = 0  # column of the first axis word, for messages
        g = self.gfunctions
        unit = g.unit
        offset = g.offset
        incremental = g.incremental
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
        kind = g.motion
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
            if self.feed is None and self.feed_refused:
                feed = REFUSED_FEED  # reported once, at the F word
            elif self.feed is None:
                raise NcFault(
                    ErrorId.FEED_ZERO,
                    column,
                    "no feed rate: program F before the first G01/G02/G03",
                )
            else:
                feed = self.feed
        end_t = tuple(end)
        if is_arc:
            i = values.get("I")
            j = values.get("J")
            r_word = values.get("R")
            if r_word is not None and (i is not None or j is not None):
                # ID 21024: "Circle centre point and radius are not permitted at the same time"
                # (its example: G02 X200 I50 J50 R50)
                # https://infosys.beckhoff.com/content/1033/tf5200_diagnosis/253243787.html
                raise NcFault(
                    ErrorId.CENTRE_AND_RADIUS,
                    r_word[1],
                    "circle with both a centre (I/J) and a radius (R): program one of them",
                )
            ij = (i[0] * unit if i else None, j[0] * unit if j else None)
            if g.center_absolute:  # G161: the centre is a position, offsets apply
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
                g.center_absolute,
                self.radius,
                self.ctx.max_radius_diff,
                column,
            )
            motion = Motion(kind, start, end_t, feed, center, sweep)
        elif start == end_t:
            self.report.warn(ErrorId.ZERO_LENGTH, column, "motion block without motion, skipped")
            return None
        else:
            motion = Motion(kind, start, end_t, feed)
        self.pos = end_t
        if not g.trc.engaged:  # under TRC the compensated path is checked (Execution)
            if beyond >= 0:
                self.ctx.check_position(beyond, end_t[beyond], column)
            if is_arc:
                self.ctx.check_motion(motion, column)
        return motion

    # -- lift commands -------------------------------------------------------------------------
    def _lift_start(self, lineno: int, axis: str, words: LiftWords, column: int) -> LiftStart:
        warnings: list[NcError] = []
        zi = self.axis_index.get(axis, self.z)  # any axis of the channel may lift (issue 18)
        refused = self.refused_lift
        try:
            self.open_lift = lift_rules.open_range(
                self.ctx,
                words,
                axis=axis,
                z0=self.pos[zi],
                slope=self.slope,
                open_lift=self.open_lift,
                lineno=lineno,
                column=column,
                warnings=warnings,
                unit=self.gfunctions.unit,
                offset=self.gfunctions.offset[zi],
                refused_line=refused[1] if refused is not None else None,
            )
        except NcFault:
            if words.keyword is LiftKeyword.START and self.open_lift is None and refused is None:
                self.refused_lift = (axis, lineno)
            raise
        for warning in warnings:
            self.report.warn(ErrorId(warning.id), warning.column, warning.message)
        if self.gfunctions.trc.side != 0 and zi in (0, 1):
            raise NcFault(
                ErrorId.TRC_LIFT_AXIS,
                column,
                f"the lift axis {axis} lies in the plane of the active tool radius "
                "compensation (vendor §2.4: it must not take part in TRC)",
            )
        return self.open_lift

    def _lift_end(self, axis: str, column: int) -> LiftEnd | None:
        refused = self.refused_lift
        if self.open_lift is None and refused is not None:
            # the LIFT_END of a refused LIFT_START: its error was reported at the start
            lift_rules.check_end_axis(axis, refused[0], f"line {refused[1]}, refused", column)
            self.refused_lift = None
            return None
        lift_rules.check_end(self.ctx, axis, self.open_lift, column)
        return self.close_lift(LiftEndCause.PROGRAMMED)


def attempt(faults: list[NcFault], fn: Callable[..., _T], *args: object) -> _T | None:
    """Run one part of a block; its NcFault is kept for the end of the block."""
    try:
        return fn(*args)
    except AlreadyReported:
        faults.append(AlreadyReported())
    except NcFault as fault:
        faults.append(fault)
    return None
