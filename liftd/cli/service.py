"""The commands around the running service: `run`, `reload`, `objects`, `plc`, `healthcheck`."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from liftd.cli.common import (
    EXIT_CONFIG,
    EXIT_OK,
    EXIT_RUNTIME,
    EXIT_UNHEALTHY,
    channel_arg,
    load_config,
    schedule_of,
)
from liftd.settings import ConfigError


def cmd_run(args: argparse.Namespace) -> int:
    """The real-time daemon: GEO loop process + ADS server (liftd/service/daemon.py)."""
    from liftd.service import daemon, logs  # noqa: PLC0415
    from liftd.settings.load import program_problem  # noqa: PLC0415

    settings = load_config(args, args.program)
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
    print(
        f"liftd reload: {'applied' if verdict.applied else 'rejected'}: {verdict.detail}",
        file=sys.stdout if verdict.applied else sys.stderr,
    )
    return EXIT_OK if verdict.applied else EXIT_CONFIG


def cmd_objects(args: argparse.Namespace) -> int:
    """Print the CNC object catalogue of the GEO port (what a PLC can read and write)."""
    from liftd.objects.catalog import Catalog  # noqa: PLC0415

    settings = load_config(args)
    ads = settings.config.ads
    catalog = Catalog([c.params for c in settings.machine])
    if args.json:
        keys = ("symbol", "index_group", "index_offset", "type", "unit", "access", "comment")
        objs = [dict(zip(keys, row, strict=True)) for row in catalog.rows()]
        print(json.dumps({"net_id": ads.net_id, "ams_ports": list(ads.ams_ports), "objects": objs}))
        return EXIT_OK
    ports = ", ".join(str(p) for p in ads.ams_ports)
    print(f"AMS NetId {ads.net_id}, port {ports} (GEO), TCP {ads.host}:{ads.port}")
    for ch, logical, index in zip(
        catalog.channels, catalog.ig_logicals, catalog.ig_indexes, strict=True
    ):
        axes = ", ".join(f"{ax.name} {ax.log_axis_nr}" for ax in ch.axes)
        print(
            f"channel {ch.channel_id}: IG 0x{logical:X} (logical: IO = logical axis number × "
            f"0x10000 + element; axes {axes}), index-based IG 0x{index:X}"
        )
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

    settings = load_config(args)
    ads = settings.config.ads
    schedule = schedule_of(args)
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
    ch = channel_arg(settings, args.channel).params
    names = [ax.name for ax in ch.axes]
    if args.axis is not None and args.axis not in names:
        print(
            f"liftd plc: --axis {args.axis}: channel {ch.channel_id} of the configuration "
            f"(-c) has the axes {', '.join(names)}",
            file=sys.stderr,
        )
        return EXIT_CONFIG
    target = plc.Target(
        host=host,
        tcp_port=tcp_port,
        net_id=args.net_id or ads.net_id,
        ams_port=args.port,
        channel=ch.channel_id,
        axis=args.axis or ch.lift_axis,
    )
    cfg_plc = settings.config.plc  # with m_ack = "plc" the loop waits for this PLC's acknowledge
    m_ack_delay = cfg_plc.m_ack_delay_ms * 1e-3 if cfg_plc.m_ack == "plc" else None
    try:
        plc.run(
            target,
            schedule,
            args.cycle_ms,
            args.duration,
            args.json,
            args.timeout_ms,
            args.start,
            m_ack_delay=m_ack_delay,
        )
    except plc.PlcError as exc:  # unreachable, or a read/write failed: never stale data
        print(f"liftd plc: {exc}", file=sys.stderr)
        return EXIT_RUNTIME
    return EXIT_OK


def cmd_healthcheck(args: argparse.Namespace) -> int:
    """0 when the daemon answers over ADS in state RUN and its GEO cycle counter advances,
    1 otherwise (the Docker HEALTHCHECK convention)."""
    from liftd.clients import healthcheck  # noqa: PLC0415

    settings = load_config(args)
    ads = settings.config.ads
    host = args.host or ("127.0.0.1" if ads.host in ("0.0.0.0", "::") else ads.host)
    healthy, message = healthcheck.probe(host, args.port or ads.port, ads.net_id, args.timeout)
    print(message, file=sys.stdout if healthy else sys.stderr)
    return EXIT_OK if healthy else EXIT_UNHEALTHY
