"""`liftd study`: `simulate --compare` over a library of programs into a report, in a local
process pool or, with --scheduler, on a Dask distributed cluster (`liftd.sim.cluster`)."""

from __future__ import annotations

import argparse
import functools
import os
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from liftd import __version__
from liftd.cli.common import (
    EXIT_CONFIG,
    EXIT_OK,
    EXIT_PROGRAM,
    EXIT_RUNTIME,
    channel_arg,
    load_config,
)
from liftd.settings.programs import read_sources

if TYPE_CHECKING:
    from liftd.cnc.params import ChannelParams
    from liftd.settings import Settings
    from liftd.sim.cluster import Cluster
    from liftd.sim.study import ProgramResult, StudyConfig
    from liftd.sim.summary import JsonObject

INSTALL_CLUSTER = "pip install 'liftd[cluster]'"


def study_programs(paths: Sequence[str]) -> list[str]:
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


def study_config(settings: Settings, channel: ChannelParams, max_time: float) -> StudyConfig:
    """What the study's workers need: the channel, the simulated PLC's M acknowledge and
    max_time, and the reader of the subroutine files a program calls (run by the pool's
    workers, or by the client of a cluster)."""
    from liftd.sim import study  # noqa: PLC0415

    delay = settings.config.plc.m_ack_delay_ms * 1e-3
    reader = functools.partial(read_sources, dirs=settings.subroutine_dirs)
    return study.StudyConfig(study.RunSettings(channel, delay, max_time), reader)


def _arguments_problem(args: argparse.Namespace) -> str | None:
    if (args.jobs is not None and args.jobs < 1) or not args.max_time > 0:
        return "--jobs must be >= 1 and --max-time > 0"
    if args.scheduler is None:
        return "--timeout is for --scheduler" if args.timeout is not None else None
    if args.jobs is not None:
        return "--jobs is for a local study: a cluster's workers have their own threads"
    if args.timeout is not None and not args.timeout > 0:
        return f"--timeout {args.timeout}: must be > 0 s"
    return None


def cmd_study(args: argparse.Namespace) -> int:
    """`simulate --compare` over a library of programs, into a report."""
    from liftd.sim import study  # noqa: PLC0415

    settings = load_config(args)
    chosen = channel_arg(settings, args.channel)
    programs = study_programs(args.paths)
    if not programs:
        print(f"liftd study: no NC programs (*.nc) in {' '.join(args.paths)}", file=sys.stderr)
        return EXIT_CONFIG
    if problem := _arguments_problem(args):
        print(f"liftd study: {problem}", file=sys.stderr)
        return EXIT_CONFIG
    cfg = study_config(settings, chosen.params, args.max_time)
    meta: JsonObject = {"liftd": __version__, "config": str(settings.path),
            "method": chosen.params.lift_method.value, "programs": len(programs)}  # fmt: skip
    if args.scheduler is None:
        jobs = min(args.jobs or len(os.sched_getaffinity(0)), len(programs))
        return _study(args, meta, {"jobs": jobs}, lambda done: study.run_programs(
            programs, cfg, jobs, done))  # fmt: skip
    try:
        from liftd.sim import cluster  # noqa: PLC0415
    except ImportError as exc:
        print(f"liftd study: --scheduler needs the Dask client ({exc}): {INSTALL_CLUSTER}",
              file=sys.stderr)  # fmt: skip
        return EXIT_CONFIG
    timeout = args.timeout if args.timeout is not None else cluster.CONNECT_TIMEOUT_S
    try:
        connected = cluster.connect(args.scheduler, timeout)
    except cluster.ClusterError as exc:
        print(f"liftd study: {exc}", file=sys.stderr)
        return EXIT_CONFIG
    try:
        return _study(args, meta, _cluster_run(connected), lambda done: cluster.run_programs(
            connected, programs, cfg, done))  # fmt: skip
    finally:
        cluster.close(connected.client)


def _cluster_run(c: Cluster) -> JsonObject:
    return {"jobs": c.threads, "scheduler": c.address, "workers": c.workers}


def _study(
    args: argparse.Namespace,
    meta: JsonObject,
    run: JsonObject,
    results: Callable[[Callable[[ProgramResult], None]], Iterator[ProgramResult]],
) -> int:
    """Run the study into the report; exit 3 when the report cannot be written or the
    scheduler went away (the rows so far are written), 2 for a worker of another liftd."""
    from liftd.sim import plot, report, study  # noqa: PLC0415
    from liftd.sim.progress import ProgressBar  # noqa: PLC0415

    out = Path(args.out)
    bar = ProgressBar(int(str(meta["programs"])), sys.stderr)

    def done(result: study.ProgramResult) -> None:
        bar.advance(failed=result.row.status is not study.Status.OK)

    stop: study.StudyStopped | None = None
    t0 = time.perf_counter()
    try:
        with report.ReportWriter(out, meta) as writer:
            try:
                for result in results(done):
                    writer.add(result)
            except study.StudyStopped as exc:
                stop = exc
                for result in exc.results:
                    writer.add(result)
            bar.close()
            run |= {
                "wall_s": round(time.perf_counter() - t0, 3),
                "max_rss_mib": {"parent": round(study.max_rss_kib() / 1024, 1),
                                "worker": round(writer.aggregate.max_rss_kib / 1024, 1)},
            }  # fmt: skip
            if stop is not None:
                run["stopped"] = str(stop)
            figures = plot.study_figures(writer.aggregate) if plot.available() else None
            summary = writer.finish(run, figures)
    except OSError as exc:
        bar.close()
        name = exc.filename or out  # a failed write or close names no file
        print(f"{name}: error: cannot write the report: {exc.strerror}", file=sys.stderr)
        return EXIT_RUNTIME
    for row in writer.aggregate.not_run:
        print(f"{row.program}: {row.status.value}: {row.why}", file=sys.stderr)
    print(report.describe(summary, run, out))
    if stop is not None:
        print(f"liftd study: stopped: {stop}", file=sys.stderr)
        return EXIT_RUNTIME if stop.lost else EXIT_CONFIG
    return EXIT_OK if summary["status"]["ok"] == summary["programs"] else EXIT_PROGRAM
