"""`liftd simulate`: one method, --compare, every channel of the machine."""

from __future__ import annotations

import argparse
import contextlib
import json
import sys
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, TextIO

from liftd.settings import Settings
from liftd.settings.programs import with_program

if TYPE_CHECKING:
    from liftd.cnc.plc import Schedule
    from liftd.sim.simulate import SimResult
from liftd.cli.common import (
    EXIT_CONFIG,
    EXIT_OK,
    EXIT_PROGRAM,
    EXIT_RUNTIME,
    load_config,
    schedule_of,
)


def cmd_simulate(args: argparse.Namespace) -> int:
    """simulate, then with --view its trace in the browser (a temporary one without --trace)."""
    if not getattr(args, "view", False):
        return _cmd_simulate(args)
    if args.compare:
        print("liftd simulate: --view shows one run; drop --compare", file=sys.stderr)
        return EXIT_CONFIG
    from liftd.cli.view import serve_trace  # noqa: PLC0415

    with tempfile.TemporaryDirectory(prefix="liftd-view-") as tmp:
        if not args.trace:
            args.trace = str(Path(tmp) / "trace.csv")
        code = _cmd_simulate(args)
        if code not in (EXIT_OK, EXIT_PROGRAM):
            return code
        settings = load_config(args)
        program = Path(args.program)
        text = program.read_text(encoding="utf-8", errors="replace")
        view = serve_trace(with_program(settings, program, text), args.trace, None, None)
        return code if view == EXIT_OK else view


def _cmd_simulate(args: argparse.Namespace) -> int:
    from liftd.sim import plot  # noqa: PLC0415

    schedule = schedule_of(args)
    if args.compare and args.method != "config":
        print("liftd simulate: --compare runs both methods; drop --method", file=sys.stderr)
        return EXIT_CONFIG
    if not args.max_time > 0:  # also NaN
        print(f"liftd simulate: --max-time {args.max_time}: must be > 0 s", file=sys.stderr)
        return EXIT_CONFIG
    if args.plot and not plot.available():
        print(f"liftd simulate: --plot: {plot.HINT}", file=sys.stderr)
        return EXIT_RUNTIME
    if args.plot and (why := plot.format_problem(args.plot)):
        print(f"liftd simulate: --plot {args.plot}: {why}", file=sys.stderr)
        return EXIT_CONFIG
    settings = load_config(args)
    program = Path(args.program)
    try:
        text = program.read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        print(f"{program}: error: cannot read program: {exc.strerror or exc}", file=sys.stderr)
        return EXIT_PROGRAM
    settings = with_program(settings, program, text)  # its subroutine files
    methods = ("advanced", "lifting") if args.compare else (args.method,)
    names = _trace_names(args.trace, methods) if args.trace else {}
    if args.plot and any(Path(args.plot).resolve() == Path(n).resolve() for n in names.values()):
        print(
            f"liftd simulate: --plot {args.plot} is a trace's file too: name another",
            file=sys.stderr,
        )
        return EXIT_CONFIG
    traces: dict[str, TextIO] = {}
    try:
        with contextlib.ExitStack() as stack:
            for method, name in names.items():
                traces[method] = stack.enter_context(open(name, "w", encoding="utf-8", newline=""))
            if args.compare:
                return _compare(args, settings, program, text, schedule, traces)
            if len(settings.machine) > 1:
                return _simulate_machine(args, settings, schedule, stack)
            return _simulate(args, settings, program, text, schedule, traces.get(args.method))
    except OSError as exc:
        what = "the plot" if args.plot and exc.filename == args.plot else "the trace"
        # a failed write or close (ENOSPC, EIO) names no file: the traces it writes
        name = exc.filename or ", ".join(names.values()) or args.plot
        print(f"{name}: error: cannot write {what}: {exc.strerror}", file=sys.stderr)
        return EXIT_RUNTIME


def _trace_names(trace: str, methods: tuple[str, ...]) -> dict[str, str]:
    """One trace per run: OUT.csv, or OUT.advanced.csv and OUT.lifting.csv with --compare."""
    if len(methods) == 1:
        return {methods[0]: trace}
    out = Path(trace)
    return {m: str(out.with_name(f"{out.stem}.{m}{out.suffix or '.csv'}")) for m in methods}


def _report_run(program: Path, result: SimResult, max_time: float, tag: str = "") -> None:
    if not result.finished:
        print(
            f"liftd simulate: the program did not end within {max_time} s simulated (--max-time)",
            file=sys.stderr,
        )
    for item in result.summary.errors:
        where = item.file or program  # an error in a subroutine file: that file, as check says
        print(f"{where}:{item.line}: error {item.error_id}: {item.message}{tag}", file=sys.stderr)


def _simulate(
    args: argparse.Namespace,
    settings: Settings,
    program: Path,
    text: str,
    schedule: Schedule,
    trace: TextIO | None,
) -> int:
    from liftd.sim import plot  # noqa: PLC0415
    from liftd.sim.simulate import channel_for, simulate  # noqa: PLC0415
    from liftd.sim.summary import describe  # noqa: PLC0415

    ch = channel_for(settings.channel, args.method)
    delay = settings.config.plc.m_ack_delay_ms * 1e-3
    result = simulate(
        ch,
        text,
        schedule,
        delay,
        trace,
        args.max_time,
        series=bool(args.plot),
        batch=not args.step_times,
    )
    _report_run(program, result, args.max_time)
    summary = result.summary
    if args.plot:
        title = f"{program.name}: {describe(summary)}"
        rows, z = result.series.rows, ch.lift_axis_index
        plot.plot_run(Path(args.plot), rows, ch.axis_names, z, summary.lifts, title)
    text_out = json.dumps(summary.to_json()) if args.json else describe(summary)
    return _output(text_out, result.program_error, result.finished)


def _channel_trace(trace: str, channel_id: int) -> str:
    """The trace of a further channel next to the [cnc] channel's: OUT.ch2.csv by OUT.csv."""
    out = Path(trace)
    return str(out.with_name(f"{out.stem}.ch{channel_id}{out.suffix or '.csv'}"))


def _simulate_machine(
    args: argparse.Namespace, settings: Settings, schedule: Schedule, stack: contextlib.ExitStack
) -> int:
    """Every channel of the start-up list in one GEO task: the [cnc] channel runs PROGRAM
    with the --override/--feedhold schedule, the others their [[channel]] programs with
    none; one trace per channel (OUT.csv, OUT.ch<N>.csv) and summary."""
    from liftd.cnc.plc import Schedule  # noqa: PLC0415
    from liftd.settings import ConfigError  # noqa: PLC0415
    from liftd.settings.load import program_problem  # noqa: PLC0415
    from liftd.settings.programs import machine_programs  # noqa: PLC0415
    from liftd.sim import plot  # noqa: PLC0415
    from liftd.sim.simulate import channel_for, simulate_machine  # noqa: PLC0415
    from liftd.sim.summary import ChannelSummary, describe, machine_json  # noqa: PLC0415

    primary = settings.primary_index
    # a [[channel]] program that cannot be read is liftd.toml's error (line, key, value), as
    # in run and check; PROGRAM itself was read already
    problem = program_problem(settings, args.program)
    if problem is not None:
        raise ConfigError([problem])
    try:
        programs = machine_programs(settings)
    except OSError as exc:
        print(f"{exc.filename}: error: cannot read program: {exc.strerror}", file=sys.stderr)
        return EXIT_PROGRAM
    channels = [(channel_for(ch, args.method), text) for ch, text in programs]
    traces: list[TextIO | None] = [None] * len(channels)
    if args.trace:
        for i, (ch, _) in enumerate(channels):
            name = args.trace if i == primary else _channel_trace(args.trace, ch.channel_id)
            traces[i] = stack.enter_context(open(name, "w", encoding="utf-8", newline=""))  # noqa: SIM115
    schedules = [schedule if i == primary else Schedule() for i in range(len(channels))]
    delay = settings.config.plc.m_ack_delay_ms * 1e-3
    results = simulate_machine(
        channels, schedules, delay, traces, args.max_time, series=bool(args.plot)
    )
    entries = []
    for c, (ch, _), result in zip(settings.machine, channels, results, strict=True):
        name = str(c.program) if c.program is not None else ""
        if c.program is not None:
            _report_run(c.program, result, args.max_time, f" (channel {ch.channel_id})")
        entries.append(ChannelSummary(ch.channel_id, name, result.summary))
    main = results[primary]
    if args.plot:
        ch = channels[primary][0]
        program = settings.machine[primary].program or Path("-")
        title = f"{program.name}: {describe(main.summary)}"
        plot.plot_run(
            Path(args.plot),
            main.series.rows,
            ch.axis_names,
            ch.lift_axis_index,
            main.summary.lifts,
            title,
        )
    if args.json:
        text_out = json.dumps(machine_json(main.summary, tuple(entries)))
    else:
        text_out = "\n".join(f"channel {e.channel_id}: {describe(e.summary)}" for e in entries)
    ran = [r for c, r in zip(settings.machine, results, strict=True) if c.program is not None]
    return _output(text_out, any(r.program_error for r in ran), all(r.finished for r in ran))


def _output(text: str, program_error: bool, finished: bool) -> int:
    print(text)
    if program_error:
        return EXIT_PROGRAM
    return EXIT_OK if finished else EXIT_RUNTIME


def _compare(
    args: argparse.Namespace,
    settings: Settings,
    program: Path,
    text: str,
    schedule: Schedule,
    traces: dict[str, TextIO],
) -> int:
    from liftd.sim import compare, plot  # noqa: PLC0415

    ch = settings.channel
    delay = settings.config.plc.m_ack_delay_ms * 1e-3
    result = compare.compare(
        ch, text, schedule, delay, traces, args.max_time, program.name, not args.step_times,
        plot=bool(args.plot),
    )  # fmt: skip
    for method, run in result.results.items():
        _report_run(program, run, args.max_time, f" ({method} run)")
    summary = result.summary
    if args.plot:
        z = ch.axis(ch.lift_axis)
        warn = summary.lifting.z_overload.warning_ratio
        title = f"{program.name}: Advanced Lifting (red) vs path-based Lifting (blue)"
        plot.plot_compare(Path(args.plot), result, z.a_max, warn, title)
    text_out = json.dumps(summary.to_json()) if args.json else compare.describe(summary)
    return _output(text_out, result.program_error, result.finished)
