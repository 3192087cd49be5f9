"""Command line (docs/reference/design.md §3.1): the parser and the dispatch here, one module per
group of commands (`check`; `simulate`; `study`; the service commands; `common`: what they share).
The only place that maps outcomes to exit codes: 0 ok, 1 NC program error, 2 configuration
error, 3 runtime failure (`healthcheck`: 1 unhealthy). A configuration or schedule error
raised by any command is printed once, in `main`."""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence

from liftd import __version__
from liftd.cli.check import cmd_check
from liftd.cli.common import EXIT_CONFIG, EXIT_SIGPIPE, EXIT_UNHEALTHY
from liftd.cli.service import cmd_healthcheck, cmd_objects, cmd_plc, cmd_reload, cmd_run
from liftd.cli.simulate import cmd_simulate
from liftd.cli.study import cmd_study
from liftd.cli.view import cmd_view
from liftd.runtime.core import core_build
from liftd.settings import ConfigError


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="liftd",
        description="Emulated TwinCAT 3 CNC GEO task: collision avoidance by lifting, over ADS.",
    )
    version = f"liftd {__version__} (GEO core: {core_build()})"
    parser.add_argument("--version", action="version", version=version)
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
        "--channel",
        type=int,
        metavar="N",
        help="channel whose objects are polled (default: the [cnc] channel)",
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
        "--view",
        action="store_true",
        help="then serve the run's trace in the browser (liftd view; a temporary trace "
        "without --trace)",
    )
    sim.add_argument(
        "--compare",
        action="store_true",
        help="run Advanced Lifting and path-based Lifting on the same program and schedule; "
        "--json/--plot then show both per lift, --trace writes OUT.advanced.csv and "
        "OUT.lifting.csv",
    )
    sim.add_argument(
        "--step-times",
        action="store_true",
        help="step every GEO cycle alone, so that step_cpu_us is each step's own time "
        "(slower; the same run, trace and summary otherwise)",
    )
    sim.add_argument(
        "--max-time",
        type=float,
        default=3600.0,
        metavar="S",
        help="stop after S simulated seconds (default 3600)",
    )
    sim.set_defaults(func=cmd_simulate)

    view = sub.add_parser(
        "view", help="the live view's page over a recorded trace (simulate/run --trace)"
    )
    view.add_argument("trace", metavar="TRACE.csv", help="trace; OUT.chN.csv siblings too")
    view.add_argument("-c", "--config", help="liftd.toml (the channels, axes and programs)")
    view.add_argument("--program", help="NC program drawn (default: the configured one)")
    view.add_argument("--host", help="listen address (default: [ui] host, 127.0.0.1)")
    view.add_argument("--port", type=int, help="TCP port (default: [ui] port, 8551; 0 = any)")
    view.add_argument("--duration", type=float, metavar="S", help=argparse.SUPPRESS)
    view.set_defaults(func=cmd_view)

    st = sub.add_parser(
        "study",
        help="simulate --compare over a library of NC programs in parallel; a report in --out",
    )
    st.add_argument("paths", nargs="+", metavar="DIR|FILE", help="directories of *.nc, or programs")
    st.add_argument("-c", "--config", help="liftd.toml")
    st.add_argument("--jobs", type=int, metavar="N", help="worker processes (default: all cores)")
    st.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="run on the Dask cluster of this scheduler (e.g. tcp://10.0.0.5:8786) instead of "
        "local processes; needs the cluster extra: pip install 'liftd[cluster]'",
    )
    st.add_argument(
        "--timeout",
        type=float,
        metavar="S",
        help="with --scheduler: seconds to wait for the scheduler, then for a worker (default 30)",
    )
    st.add_argument(
        "--channel", type=int, metavar="N", help="run the programs in channel N (default: [cnc])"
    )
    st.add_argument(
        "--out",
        default="study",
        metavar="DIR",
        help="where report.csv, report.json and report.html go (default: ./study)",
    )
    st.add_argument(
        "--max-time",
        type=float,
        default=3600.0,
        metavar="S",
        help="stop a run after S simulated seconds (default 3600)",
    )
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
    except BrokenPipeError:  # `liftd objects | head`: the reader has gone, as SIGPIPE ends a tool
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # no error at exit
        return EXIT_SIGPIPE
    return code
