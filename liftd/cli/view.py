"""`liftd view TRACE.csv`: the live view's page over a recorded trace (and its OUT.chN.csv
siblings), with a timeline; `simulate --view` calls it after the run."""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import signal
import sys
from pathlib import Path

from liftd.cli.common import EXIT_CONFIG, EXIT_OK, EXIT_RUNTIME, load_config
from liftd.settings import Settings


def cmd_view(args: argparse.Namespace) -> int:
    settings = load_config(args, args.program)
    return serve_trace(settings, args.trace, args.host, args.port, args.duration)


def serve_trace(
    settings: Settings,
    trace: str,
    host: str | None,
    port: int | None,
    duration: float | None = None,
) -> int:
    """Serve the page on `trace` until Ctrl-C / SIGTERM (or `duration` s)."""
    import structlog  # noqa: PLC0415

    from liftd.objects.catalog import Catalog  # noqa: PLC0415
    from liftd.service.loop_settings import trace_names  # noqa: PLC0415
    from liftd.settings.programs import machine_programs  # noqa: PLC0415
    from liftd.ui import geometry  # noqa: PLC0415
    from liftd.ui.player import TraceSession  # noqa: PLC0415
    from liftd.ui.trace import TraceError, load_traces  # noqa: PLC0415
    from liftd.ui.web import UiServer, WebConfig  # noqa: PLC0415

    catalog = Catalog([c.params for c in settings.machine])
    try:
        views = load_traces(catalog, trace_names(trace, settings), settings.primary_index)
    except TraceError as exc:
        print(f"liftd view: {exc}", file=sys.stderr)
        return EXIT_CONFIG
    try:
        programs = machine_programs(settings)
    except OSError as exc:
        print(f"{exc.filename}: error: cannot read program: {exc.strerror}", file=sys.stderr)
        return EXIT_CONFIG
    drawings = [geometry.build(ch, text) if text else None for ch, text in programs]
    ui = settings.config.ui
    cfg = WebConfig(
        host if host is not None else ui.host,
        port if port is not None else ui.port,
        False,
        None,
        ui.hosts,
        ui.max_connections,
        ui.max_message_bytes,
        mode="trace",
    )
    log = structlog.get_logger("liftd").bind(part="ui")
    player = TraceSession(views, drawings, ui.rate_hz)  # (its drawings for /drawing/…)
    server = UiServer(
        cfg, lambda: TraceSession(views, drawings, ui.rate_hz), log, drawings=player.drawing
    )

    async def main() -> int:
        try:
            await server.start()
        except OSError as exc:
            print(
                f"liftd view: cannot listen on {cfg.host}:{cfg.port}: {exc.strerror}",
                file=sys.stderr,
            )
            return EXIT_RUNTIME
        shown = "127.0.0.1" if cfg.host in ("0.0.0.0", "") else cfg.host
        rows = sum(tr.n for tr in views.traces if tr is not None)
        print(
            f"liftd view: http://{shown}:{server.port}/ ({Path(trace).name}, {rows} rows, "
            f"{views.t0:.3f}..{views.t1:.3f} s); Ctrl-C stops",
            flush=True,
        )
        stop = asyncio.Event()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, stop.set)
        with contextlib.suppress(TimeoutError):
            await asyncio.wait_for(stop.wait(), duration)
        await server.close()
        return EXIT_OK

    return asyncio.run(main())
