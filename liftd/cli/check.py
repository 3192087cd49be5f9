"""`liftd check`: liftd.toml, the ISG lists and NC programs, with one line per lift range."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from liftd.cli.common import (
    EXIT_CONFIG,
    EXIT_OK,
    EXIT_PROGRAM,
    channel_arg,
    load_config,
)
from liftd.cnc.nc import DecoderContext
from liftd.cnc.nc import Severity as NcSeverity
from liftd.cnc.nc.decoder import iter_decode
from liftd.cnc.nc.lift_summary import LiftPlanHook, LiftRangeSummary, LiftRangeTracker
from liftd.cnc.nc.lift_summary import describe as describe_lift
from liftd.cnc.params import ChannelParams, LiftMethod
from liftd.settings import Settings
from liftd.settings.load import program_problem
from liftd.settings.programs import program_channel


def check_program(settings: Settings, path: Path, channel: ChannelParams | None = None) -> int:
    """Decode one program (streamed: its expansion is never held) for `channel` (default: the
    [cnc] channel) and print its problems, then one line saying what liftd runs approximated;
    returns the number of errors."""
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        print(f"{path}: error: cannot read program: {exc.strerror or exc}", file=sys.stderr)
        return 1
    ch = program_channel(settings, path, text, channel)
    stream, decoder = iter_decode(text, DecoderContext.from_channel(ch))
    blocks = lifts = 0
    ranges = LiftRangeTracker(ch.lift_min_dist)
    for block in stream:
        blocks += 1
        lifts += block.lift_start is not None
        ranges.feed(block)
    result = decoder.result(())
    errors = 0
    for problem in result.errors:
        print(problem.located(str(path)), file=sys.stderr)
        errors += problem.severity is NcSeverity.ERROR
    summaries = ranges.finish()
    plan = None
    if not errors and ch.lift_method is LiftMethod.ADVANCED and summaries:
        plan = _lift_plan(settings, ch, text)
    for summary in summaries:  # one line per lift range (issue 15)
        print(f"{path}: {describe_lift(summary, ch.lift_method, plan, str(path))}")
    if not errors:
        print(f"{path}: ok ({blocks} blocks, {lifts} lift ranges)")
    approx = ", ".join(f"{kind} in {n} block{'s' * (n != 1)}" for kind, n in result.not_emulated)
    print(f"{path}: not emulated: {approx or 'nothing (everything runs as on the CNC)'}")
    return errors


CHECK_PLAN_SECONDS = 120.0  # simulated seconds of a program `check` plans lifts over


def _lift_plan(settings: Settings, ch: ChannelParams, text: str) -> LiftPlanHook:
    """Advanced Lifting's planned peak and nominal time per range, from the GEO core run over
    the program's first CHECK_PLAN_SECONDS (a few seconds of CPU at most)."""
    from liftd.sim.simulate import plan_lifts  # noqa: PLC0415

    planned = plan_lifts(ch, text, settings.config.plc.m_ack_delay_ms * 1e-3, CHECK_PLAN_SECONDS)

    def hook(r: LiftRangeSummary) -> tuple[float, float] | None:
        got = planned.get(r.index)
        if got is None or got[0] != r.start.line:
            return None
        return got[1], got[2]

    return hook


def cmd_check(args: argparse.Namespace) -> int:
    settings = load_config(args)
    problem = None if args.programs else program_problem(settings)
    if problem is not None:  # as `liftd run` says it: the liftd.toml line that names it
        print(problem, file=sys.stderr)
        return EXIT_CONFIG
    for c in settings.machine:
        ch = c.params
        axes = " ".join(ax.name for ax in ch.axes)
        print(
            f"{settings.path}: ok (channel {ch.channel_id}: axes {axes}, lift axis "
            f"{ch.lift_axis}, method {ch.lift_method.value}, cycle "
            f"{round(ch.cycle_time * 1e6)} µs, look-ahead {ch.look_ahead_blocks} blocks)"
        )
    if args.programs:  # against the channel asked for (default: [cnc] channel)
        chosen = channel_arg(settings, args.channel)
        runs = [(Path(p), chosen.params) for p in args.programs]
    else:  # every channel's configured program against its channel
        runs = [(c.program, c.params) for c in settings.machine if c.program is not None]
    failed = sum(check_program(settings, path, ch) > 0 for path, ch in runs)
    return EXIT_PROGRAM if failed else EXIT_OK
