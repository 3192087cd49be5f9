"""What a lift command means in its program and when it is refused (vendor text §2–§4,
docs/reference/isg-cnc.md §4): LIFT_START / single-block LIFT and LIFT_END checked against the lift
method, the lift axis, the open range, the slope and the software limits; POS and POS_LIMIT made
absolute (G91: relative to the lift axis at LIFT_START). The syntax of the words is in
lift_words.py; the decoder keeps the state and calls these."""

from __future__ import annotations

from liftd.cnc import units
from liftd.cnc.nc.blocks import ErrorId, LiftStart, NcError, NcFault, Severity
from liftd.cnc.nc.context import DecoderContext
from liftd.cnc.nc.lift_words import LiftKeyword, LiftWords
from liftd.cnc.params import LiftMethod, SlopeType


def require_method(ctx: DecoderContext, column: int) -> None:
    if ctx.lift_method is LiftMethod.NONE:
        raise NcFault(
            ErrorId.LIFT_NO_METHOD,
            column,
            "lift command, but no lift method is "
            "enabled (FCT_LIFT_UP_TIME or FCT_LIFT_UP in the start-up list)",
        )


def open_range(
    ctx: DecoderContext,
    words: LiftWords,
    *,
    axis: str,
    z0: float,
    slope: SlopeType,
    open_lift: LiftStart | None,
    lineno: int,
    column: int,
    warnings: list[NcError],
    unit: float = units.M_PER_MM,
    offset: float = 0.0,
    refused_line: int | None = None,
) -> LiftStart:
    """The range a LIFT_START / LIFT opens with the lift axis at z0 (m); NcFault if it is
    refused, warnings appended as found. `unit`: m per program length unit (G71 mm, G70
    inch, vendor §3 "[mm, inch]"); `offset`: the lift axis' zero offset, added to absolute
    POS / POS_LIMIT like to any absolute coordinate (G91 values are relative to z0).
    `refused_line`: a refused LIFT_START whose LIFT_END has not come yet (its range counts as
    started, so a second start is refused like inside an open range)."""
    require_method(ctx, column)
    if open_lift is not None or refused_line is not None:
        started = (
            f"started in line {open_lift.line}"
            if open_lift is not None
            else f"the refused LIFT_START in line {refused_line} counts as started"
        )
        if words.keyword is LiftKeyword.SINGLE:
            raise NcFault(
                ErrorId.LIFT_SECOND_START,
                column,
                f"LIFT while a lift range is active ({started}), LIFT_END expected first",
            )
        raise NcFault(
            ErrorId.LIFT_ALREADY_ACTIVE,
            column,
            f"LIFT already active ({started}), LIFT_END expected",
        )
    if axis not in ctx.axis_names:  # any axis of the channel may lift (vendor §3, issue 18)
        raise NcFault(
            ErrorId.UNKNOWN_AXIS,
            column,
            f"{axis} is not an axis of the channel ({', '.join(ctx.axis_names)})",
        )
    if words.pos_limit_mm is None:
        raise NcFault(ErrorId.LIFT_POS_LIMIT_MISSING, column, "POS_LIMIT= is mandatory")
    if words.down and ctx.lift_method is LiftMethod.LIFTING:
        raise NcFault(
            ErrorId.LIFT_DOWN_PATH_BASED,
            column,
            "DOWN cannot be programmed with path-based Lifting (vendor §2.2)",
        )
    if slope is SlopeType.HSC and ctx.lift_method is LiftMethod.ADVANCED:
        raise NcFault(
            ErrorId.LIFT_HSC_SLOPE,
            column,
            "HSC slope (type 3) is not supported with Advanced Lifting",
        )
    if slope is SlopeType.STEP and ctx.lift_method is LiftMethod.LIFTING:
        warnings.append(
            NcError(
                int(ErrorId.LIFT_STEP_SLOPE),
                lineno,
                column,
                "STEP slope with path-based Lifting: the lift axis can be overloaded "
                "(vendor §2.2.1 asks for TRAPEZ)",
                Severity.WARNING,
            )
        )
    base = z0 if words.incremental else offset
    target = z0 if words.pos_mm is None else base + words.pos_mm * unit
    limit = base + words.pos_limit_mm * unit
    z = ctx.axis_names.index(axis)
    ctx.check_position(z, target, column)  # POS beyond the software limits: 50041 / 50042
    # A lift height (or DOWN depth) beyond the software limit cannot be reached anyway: the
    # limit is the software limit, with a warning (issue 15 item 3; the vendor's own §3
    # example programs POS_LIMIT=300). DOWN with POS_LIMIT above start and POS is special
    # case 1 mirrored (§2.1.3: the limit has no effect, Z goes to POS at the start).
    neg, pos = ctx.sw_limits[z]
    programmed: float | None = None
    if not neg - 1e-12 <= limit <= pos + 1e-12:
        programmed = limit
        limit = min(max(limit, neg), pos)
        side = "positive" if programmed > pos else "negative"
        warnings.append(
            NcError(
                int(ErrorId.LIFT_LIMIT_CLAMPED),
                lineno,
                column,
                f"POS_LIMIT {programmed * 1e3:.4f} mm lies beyond the {side} software limit "
                f"{limit * 1e3:.4f} mm of {axis}: the lift is limited to the software limit",
                Severity.WARNING,
            )
        )
    return LiftStart(
        axis,
        z0,
        target,
        limit,
        words.down,
        lineno,
        single_block=words.keyword is LiftKeyword.SINGLE,
        limit_programmed=programmed,
    )


def check_end(ctx: DecoderContext, axis: str, open_lift: LiftStart | None, column: int) -> None:
    """NcFault unless a LIFT_END on `axis` closes the open range."""
    require_method(ctx, column)
    if open_lift is None:
        raise NcFault(
            ErrorId.LIFT_NOT_ACTIVE, column, "LIFT already deactivated, LIFT_START expected"
        )
    check_end_axis(axis, open_lift.axis, f"line {open_lift.line}", column)


def check_end_axis(axis: str, start_axis: str, started: str, column: int) -> None:
    """NcFault 120605 unless the LIFT_END is on the axis of its LIFT_START."""
    if axis != start_axis:
        raise NcFault(
            ErrorId.LIFT_AXIS_MISMATCH,
            column,
            f"LIFT_END for {axis}, but LIFT_START ({started}) was for {start_axis}",
        )
