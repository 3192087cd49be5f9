"""Command line (DESIGN.md §3.1). The only place that maps outcomes to exit codes:
0 ok, 1 NC program error, 2 configuration error, 3 runtime failure (`healthcheck`: 1 unhealthy).
A configuration or schedule error raised by any command is printed once, in `main`."""

from __future__ import annotations

import argparse
import contextlib
import functools
import json
import os
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, TextIO

from liftd import __version__
from liftd.cnc.nc import DecoderContext
from liftd.cnc.nc import Severity as NcSeverity
from liftd.cnc.nc.decoder import iter_decode
from liftd.cnc.nc.lift_summary import LiftPlanHook, LiftRangeSummary, LiftRangeTracker
from liftd.cnc.nc.lift_summary import describe as describe_lift
from liftd.cnc.params import ChannelParams, LiftMethod
from liftd.settings import ConfigError, Problem, Settings, Severity, load_settings
from liftd.settings.load import ChannelSettings
from liftd.settings.programs import program_channel, with_program

if TYPE_CHECKING:
    from liftd.cnc.plc import Schedule
    from liftd.sim.simulate import SimResult

EXIT_OK = 0
EXIT_PROGRAM = 1
EXIT_CONFIG = 2
EXIT_RUNTIME = 3
EXIT_UNHEALTHY = 1  # healthcheck: the Docker HEALTHCHECK convention


def _load(args: argparse.Namespace, program: str | None = None) -> Settings:
    settings = load_settings(args.config, program)
    for warning in settings.warnings:
        print(warning, file=sys.stderr)
    return settings


def _schedule(args: argparse.Namespace) -> Schedule:
    """--override / --feedhold as a schedule; raises SpecError (exit 2)."""
    from liftd.cnc.plc import Schedule, parse_feedhold_spec, parse_override_spec  # noqa: PLC0415

    return Schedule(
        tuple(parse_override_spec(args.override or "")),
        tuple(parse_feedhold_spec(args.feedhold or "")),
    )


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
        lifts += block.lift_start is not None and not block.lift_start.implicit
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
        print(f"{path}: {describe_lift(summary, ch.lift_method, plan)}")
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
    settings = _load(args)
    for c in settings.machine:
        ch = c.params
        axes = " ".join(ax.name for ax in ch.axes)
        print(
            f"{settings.path}: ok (channel {ch.channel_id}: axes {axes}, lift axis "
            f"{ch.lift_axis}, method {ch.lift_method.value}, cycle "
            f"{round(ch.cycle_time * 1e6)} µs, look-ahead {ch.look_ahead_blocks} blocks)"
        )
    if args.programs:  # against the channel asked for (default: [cnc] channel)
        chosen = _channel_arg(settings, args.channel)
        runs = [(Path(p), chosen.params) for p in args.programs]
    else:  # every channel's configured program against its channel
        runs = [(c.program, c.params) for c in settings.machine if c.program is not None]
    failed = sum(check_program(settings, path, ch) > 0 for path, ch in runs)
    return EXIT_PROGRAM if failed else EXIT_OK


def _channel_arg(settings: Settings, channel: int | None) -> ChannelSettings:
    """--channel N: a channel of the start-up list (default: [cnc] channel); else exit 2."""
    if channel is None:
        return settings.machine[settings.primary_index]
    chosen = settings.channel_by_id(channel)
    if chosen is None:
        ids = ", ".join(str(c.params.channel_id) for c in settings.machine)
        message = f"no such channel (channels: {ids})"
        raise ConfigError(
            [Problem(Severity.ERROR, str(settings.path), None, "--channel", str(channel), message)]
        )
    return chosen


def cmd_simulate(args: argparse.Namespace) -> int:
    from liftd.sim import plot  # noqa: PLC0415

    schedule = _schedule(args)
    if args.compare and args.method != "config":
        print("liftd simulate: --compare runs both methods; drop --method", file=sys.stderr)
        return EXIT_CONFIG
    if args.plot and not plot.available():
        print(f"liftd simulate: --plot: {plot.HINT}", file=sys.stderr)
        return EXIT_RUNTIME
    settings = _load(args)
    program = Path(args.program)
    try:
        text = program.read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        print(f"{program}: error: cannot read program: {exc.strerror or exc}", file=sys.stderr)
        return EXIT_PROGRAM
    settings = with_program(settings, program, text)  # its subroutine files
    methods = ("advanced", "lifting") if args.compare else (args.method,)
    names = _trace_names(args.trace, methods) if args.trace else {}
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
        print(f"{exc.filename}: error: cannot write the trace: {exc.strerror}", file=sys.stderr)
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
        print(f"{program}:{item.line}: error {item.error_id}: {item.message}{tag}", file=sys.stderr)


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
    result = simulate(ch, text, schedule, delay, trace, args.max_time)
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
    from liftd.settings.programs import machine_programs  # noqa: PLC0415
    from liftd.sim import plot  # noqa: PLC0415
    from liftd.sim.simulate import channel_for, simulate_machine  # noqa: PLC0415
    from liftd.sim.summary import ChannelSummary, describe, machine_json  # noqa: PLC0415

    primary = settings.primary_index
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
    results = simulate_machine(channels, schedules, delay, traces, args.max_time)
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
        plot.plot_run(Path(args.plot), main.series.rows, ch.axis_names, ch.lift_axis_index,
                      main.summary.lifts, title)  # fmt: skip
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
    result = compare.compare(ch, text, schedule, delay, traces, args.max_time, program.name)
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


def _study_programs(paths: Sequence[str]) -> list[str]:
    """The programs named: a directory stands for the *.nc files in it (not in its
    subdirectories, where CAM libraries keep the subroutine files their jobs call)."""
    out: list[str] = []
    for name in paths:
        path = Path(name)
        if path.is_dir():
            files = (f for f in path.iterdir() if f.suffix.lower() == ".nc" and f.is_file())
            out.extend(sorted(str(f) for f in files))
        else:
            out.append(name)  # unreadable ones are reported as such, with the others
    return list(dict.fromkeys(out))


def cmd_study(args: argparse.Namespace) -> int:
    """`simulate --compare` over a library of programs in parallel, into a report."""
    from liftd.sim import plot, report, study  # noqa: PLC0415
    from liftd.sim.progress import ProgressBar  # noqa: PLC0415

    settings = _load(args)
    chosen = _channel_arg(settings, args.channel)
    programs = _study_programs(args.paths)
    if not programs:
        print(f"liftd study: no NC programs (*.nc) in {' '.join(args.paths)}", file=sys.stderr)
        return EXIT_CONFIG
    if (args.jobs is not None and args.jobs < 1) or args.max_time <= 0:
        print("liftd study: --jobs must be >= 1 and --max-time > 0", file=sys.stderr)
        return EXIT_CONFIG
    jobs = min(args.jobs or len(os.sched_getaffinity(0)), len(programs))
    cfg = study.StudyConfig(
        # the channel's parameters with the subroutine files, read in the worker
        functools.partial(program_channel, settings, channel=chosen.params),
        settings.config.plc.m_ack_delay_ms * 1e-3,
        args.max_time,
    )
    meta = {"liftd": __version__, "config": str(settings.path),
            "method": chosen.params.lift_method.value, "programs": len(programs)}  # fmt: skip
    out = Path(args.out)
    bar = ProgressBar(len(programs), sys.stderr)

    def done(result: study.ProgramResult) -> None:
        bar.advance(failed=result.row.status is not study.Status.OK)

    t0 = time.perf_counter()
    try:
        with report.ReportWriter(out, meta) as writer:
            for result in study.run_programs(programs, cfg, jobs, done):
                writer.add(result)
            bar.close()
            run = {
                "jobs": jobs,
                "wall_s": round(time.perf_counter() - t0, 3),
                "max_rss_mib": {"parent": round(study.max_rss_kib() / 1024, 1),
                                "worker": round(writer.aggregate.max_rss_kib / 1024, 1)},
            }  # fmt: skip
            figures = plot.study_figures(writer.aggregate) if plot.available() else None
            summary = writer.finish(run, figures)
    except OSError as exc:
        bar.close()
        print(f"{exc.filename}: error: cannot write the report: {exc.strerror}", file=sys.stderr)
        return EXIT_RUNTIME
    for row in writer.aggregate.not_run:
        print(f"{row.program}: {row.status.value}: {row.why}", file=sys.stderr)
    print(report.describe(summary, run, out))
    return EXIT_OK if summary["status"]["ok"] == summary["programs"] else EXIT_PROGRAM


def cmd_run(args: argparse.Namespace) -> int:
    """The real-time daemon: GEO loop process + ADS server (liftd/service/daemon.py)."""
    from liftd.service import daemon, logs  # noqa: PLC0415
    from liftd.settings.load import program_problem  # noqa: PLC0415

    settings = _load(args, args.program)
    problem = program_problem(settings, args.program)
    if problem is not None:
        raise ConfigError([problem])
    log = settings.config.log
    logs.configure(log.level, log.format, log.queue_lines)
    if args.duration is not None and args.duration <= 0:
        print(f"--duration: must be > 0 seconds, got {args.duration}", file=sys.stderr)
        return EXIT_CONFIG
    ok = daemon.run(settings, args.config, args.program, args.trace, args.duration)
    return EXIT_OK if ok else EXIT_RUNTIME


def cmd_reload(args: argparse.Namespace) -> int:
    """Ask the running daemon to reload and wait for its verdict (systemd's ExecReload)."""
    from liftd.service import control  # noqa: PLC0415

    path = control.socket_path(explicit=args.socket) or Path(
        control.DEFAULT_RUNTIME_DIRECTORY, control.SOCKET_NAME
    )
    try:
        verdict = control.request_reload(path, args.timeout)
    except OSError as exc:
        print(f"liftd reload: no answer on {path}: {exc}", file=sys.stderr)
        return EXIT_RUNTIME
    print(f"liftd reload: {'applied' if verdict.applied else 'rejected'}: {verdict.detail}",
          file=sys.stdout if verdict.applied else sys.stderr)  # fmt: skip
    return EXIT_OK if verdict.applied else EXIT_CONFIG


def cmd_objects(args: argparse.Namespace) -> int:
    """Print the CNC object catalogue of the GEO port (what a PLC can read and write)."""
    from liftd.objects.catalog import Catalog  # noqa: PLC0415

    settings = _load(args)
    ads = settings.config.ads
    catalog = Catalog([c.params for c in settings.machine])
    if args.json:
        keys = ("symbol", "index_group", "index_offset", "type", "unit", "access", "comment")
        objs = [dict(zip(keys, row, strict=True)) for row in catalog.rows()]
        print(json.dumps({"net_id": ads.net_id, "ams_ports": list(ads.ams_ports), "objects": objs}))
        return EXIT_OK
    ports = ", ".join(str(p) for p in ads.ams_ports)
    print(f"AMS NetId {ads.net_id}, port {ports} (GEO), TCP {ads.host}:{ads.port}")
    for ch, logical, index in zip(catalog.channels, catalog.ig_logicals, catalog.ig_indexes,
                                  strict=True):  # fmt: skip
        axes = ", ".join(f"{ax.name} {ax.log_axis_nr}" for ax in ch.axes)
        print(f"channel {ch.channel_id}: IG 0x{logical:X} (logical: IO = logical axis number × "
              f"0x10000 + element; axes {axes}), index-based IG 0x{index:X}")  # fmt: skip
    print(
        "index-based addressing: IO = position in the channel × 0x10000 + element; element "
        "attributes at IG + 0x100 (name), + 0x200 (type), + 0x300 (length), + 0x400 (unit), "
        "+ 0x500 (write flag), + 0x600 (address)"
    )
    head = ("symbol", "IG", "IO", "type", "unit", "access", "comment")
    rows = [head, *catalog.rows()]
    widths = [max(len(r[i]) for r in rows) for i in range(6)]
    for row in rows:
        print("  ".join(c.ljust(w) for c, w in zip(row[:6], widths, strict=True)) + "  " + row[6])
    return EXIT_OK


def cmd_plc(args: argparse.Namespace) -> int:
    """A simulated PLC polling the lift status over ADS (liftd/plc.py)."""
    from liftd.clients import plc  # noqa: PLC0415

    settings = _load(args)
    ads = settings.config.ads
    schedule = _schedule(args)
    try:
        host, tcp_port = plc.parse_host(args.host or ads.host, ads.port)
    except ValueError as exc:
        print(f"liftd plc: {exc}", file=sys.stderr)
        return EXIT_CONFIG
    if not 0.5 <= args.cycle_ms <= 10_000 or (args.duration is not None and args.duration <= 0):
        print("liftd plc: --cycle-ms must be 0.5..10000 and --duration > 0", file=sys.stderr)
        return EXIT_CONFIG
    if host in ("0.0.0.0", "::", ""):
        host = "127.0.0.1"  # the daemon listens on every address; reach it on loopback
    ch = _channel_arg(settings, args.channel).params
    target = plc.Target(
        host=host, tcp_port=tcp_port, net_id=args.net_id or ads.net_id, ams_port=args.port,
        channel=ch.channel_id, axis=args.axis or ch.lift_axis,
    )  # fmt: skip
    try:
        plc.run(target, schedule, args.cycle_ms, args.duration, args.json, args.timeout_ms,
                args.start)  # fmt: skip
    except plc.PlcError as exc:  # unreachable, or a read/write failed: never stale data
        print(f"liftd plc: {exc}", file=sys.stderr)
        return EXIT_RUNTIME
    return EXIT_OK


def cmd_healthcheck(args: argparse.Namespace) -> int:
    """0 when the daemon answers over ADS in state RUN and its GEO cycle counter advances,
    1 otherwise (the Docker HEALTHCHECK convention)."""
    from liftd.clients import healthcheck  # noqa: PLC0415

    settings = _load(args)
    ads = settings.config.ads
    host = args.host or ("127.0.0.1" if ads.host in ("0.0.0.0", "::") else ads.host)
    healthy, message = healthcheck.probe(host, args.port or ads.port, ads.net_id, args.timeout)
    print(message, file=sys.stdout if healthy else sys.stderr)
    return EXIT_OK if healthy else EXIT_UNHEALTHY


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="liftd",
        description="Emulated TwinCAT 3 CNC GEO task: collision avoidance by lifting, over ADS.",
    )
    parser.add_argument("--version", action="version", version=f"liftd {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)

    check = sub.add_parser("check", help="validate the configuration and NC programs")
    check.add_argument(
        "-c",
        "--config",
        help="liftd.toml (default: $LIFTD_CONFIG, ./config/liftd.toml, the packaged default)",
    )
    check.add_argument(
        "programs", nargs="*", help="NC programs (default: every channel's configured one)"
    )
    check.add_argument(
        "--channel", type=int, metavar="N", help="check PROGRAMs in channel N (default: [cnc])"
    )
    check.set_defaults(func=cmd_check)

    run = sub.add_parser("run", help="run the GEO task in real time and serve it over ADS")
    run.add_argument("-c", "--config", help="liftd.toml")
    run.add_argument("--program", help="NC program (default: the configured one)")
    run.add_argument(
        "--trace", metavar="OUT.csv", help="record every GEO cycle (the simulate CSV contract)"
    )
    run.add_argument(
        "--duration", type=float, metavar="S", help="stop cleanly after S seconds (default: run)"
    )
    run.set_defaults(func=cmd_run)

    objects = sub.add_parser("objects", help="print the CNC objects and symbols served over ADS")
    objects.add_argument("-c", "--config", help="liftd.toml")
    objects.add_argument("--json", action="store_true", help="as JSON")
    objects.set_defaults(func=cmd_objects)

    plc = sub.add_parser(
        "plc",
        help="a simulated PLC: poll lift_active/lift_suppressed over ADS, print transitions",
    )
    plc.add_argument("-c", "--config", help="liftd.toml the defaults come from")
    plc.add_argument("--host", metavar="HOST[:PORT]", help="daemon address (default: [ads])")
    plc.add_argument("--net-id", help="the daemon's AMS NetId (default: [ads] net_id)")
    plc.add_argument("--port", type=int, default=551, help="AMS port (default 551, GEO)")
    plc.add_argument("--cycle-ms", type=float, default=10.0, help="PLC cycle (default 10 ms)")
    plc.add_argument("--duration", type=float, metavar="S", help="stop after S seconds")
    plc.add_argument(
        "--channel", type=int, metavar="N", help="channel whose objects are polled (default: 1)"
    )
    plc.add_argument("--axis", help="axis whose lift status is polled (default: lift_axis)")
    plc.add_argument("--override", metavar="SPEC", help='write override steps "T:PERCENT,…"')
    plc.add_argument("--feedhold", metavar="SPEC", help='write feed hold "T:DURATION,…"')
    plc.add_argument("--json", action="store_true", help="one JSON object per transition")
    plc.add_argument("--start", action="store_true", help="send NC start once at connect")
    plc.add_argument(
        "--timeout-ms", type=int, default=1000, help="ADS request timeout (default 1000 ms)"
    )
    plc.set_defaults(func=cmd_plc)

    health = sub.add_parser(
        "healthcheck", help="exit 0 when the running daemon is in RUN and its GEO loop cycles"
    )
    health.add_argument("-c", "--config", help="liftd.toml")
    health.add_argument("--host", help="daemon address (default: [ads] host, loopback if any)")
    health.add_argument("--port", type=int, help="TCP port (default: [ads] port)")
    health.add_argument("--timeout", type=float, default=2.0, help="seconds (default 2)")
    health.set_defaults(func=cmd_healthcheck, config_error_exit=EXIT_UNHEALTHY)

    reload = sub.add_parser(
        "reload",
        help="ask the running daemon to reload liftd.toml; exit 0 only when it was applied "
        "(systemd's ExecReload)",
    )
    reload.add_argument(
        "--socket",
        help="control socket (default: $RUNTIME_DIRECTORY/control.sock, else "
        "/run/liftd/control.sock)",
    )
    reload.add_argument("--timeout", type=float, default=90.0, help="seconds (default 90)")
    reload.set_defaults(func=cmd_reload)

    sim = sub.add_parser("simulate", help="run a program on a virtual clock, as fast as possible")
    sim.add_argument("program", help="NC program")
    sim.add_argument("-c", "--config", help="liftd.toml")
    sim.add_argument(
        "--method",
        choices=["advanced", "lifting", "config"],
        default="config",
        help="lift method: as the lists enable it (config) or forced",
    )
    sim.add_argument(
        "--override", metavar="SPEC", help='override steps "T:PERCENT,…", e.g. "0:100,0.4:150"'
    )
    sim.add_argument("--feedhold", metavar="SPEC", help='feed hold "T:DURATION,…"')
    sim.add_argument("--trace", metavar="OUT.csv", help="write one CSV row per GEO cycle")
    sim.add_argument("--plot", metavar="OUT.png", help="write a figure of the run")
    sim.add_argument("--json", action="store_true", help="print the JSON summary on stdout")
    sim.add_argument(
        "--compare",
        action="store_true",
        help="run Advanced Lifting and path-based Lifting on the same program and schedule; "
        "--json/--plot then show both per lift, --trace writes OUT.advanced.csv and "
        "OUT.lifting.csv",
    )
    sim.add_argument(
        "--max-time",
        type=float,
        default=3600.0,
        metavar="S",
        help="stop after S simulated seconds (default 3600)",
    )
    sim.set_defaults(func=cmd_simulate)

    st = sub.add_parser(
        "study",
        help="simulate --compare over a library of NC programs in parallel; a report in --out",
    )
    st.add_argument("paths", nargs="+", metavar="DIR|FILE", help="directories of *.nc, or programs")
    st.add_argument("-c", "--config", help="liftd.toml")
    st.add_argument("--jobs", type=int, metavar="N", help="worker processes (default: all cores)")
    st.add_argument(
        "--channel", type=int, metavar="N", help="run the programs in channel N (default: [cnc])"
    )
    st.add_argument(
        "--out", default="study", metavar="DIR",
        help="where report.csv, report.json and report.html go (default: ./study)",
    )  # fmt: skip
    st.add_argument(
        "--max-time", type=float, default=3600.0, metavar="S",
        help="stop a run after S simulated seconds (default 3600)",
    )  # fmt: skip
    st.set_defaults(func=cmd_study)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    from liftd.cnc.plc import SpecError  # noqa: PLC0415

    try:
        code: int = args.func(args)
    except ConfigError as err:
        for problem in err.problems:
            print(problem, file=sys.stderr)
        return int(getattr(args, "config_error_exit", EXIT_CONFIG))
    except SpecError as exc:
        print(f"liftd {args.command}: {exc}", file=sys.stderr)
        return EXIT_CONFIG
    except KeyboardInterrupt:
        return 130
    return code
