"""What the GEO process gets from the settings (`loop_config`, a trace file per channel, each
program decoded once and its problems logged) and what a reload may change (`shape`: the
channels and axes it may not; `needs_restart`: keys only a restart applies). Changes with the
configuration's contents; the daemon (daemon.py) composes and runs the parts."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from liftd.cnc.nc import DecoderContext, Severity, decode
from liftd.runtime.loop_config import ChannelConfig, LoopConfig
from liftd.runtime.rt import RtRequest
from liftd.settings import Settings
from liftd.settings.model import LiftdConfig
from liftd.settings.programs import program_channel, read_program

RESTART_KEYS = ("host", "port", "net_id", "extra_net_ids", "ams_ports")
RESTART_SECTIONS = ("rt", "log", "metrics", "ui")  # applied when the processes start
RELOADED = ("ui.token", "ui.token_file")  # but the live view's token a reload applies


def needs_restart(running: LiftdConfig, new: LiftdConfig) -> list[str]:
    """The keys of `new` that differ from what the daemon runs with and that only a restart
    applies: the listen address and AMS identity, the real-time, log and metrics settings."""
    keys = [f"ads.{k}" for k in RESTART_KEYS if getattr(new.ads, k) != getattr(running.ads, k)]
    for name in RESTART_SECTIONS:
        old_s, new_s = getattr(running, name), getattr(new, name)
        keys += [
            f"{name}.{k}"
            for k in type(new_s).model_fields
            if getattr(new_s, k) != getattr(old_s, k) and f"{name}.{k}" not in RELOADED
        ]
    return keys


def loop_config(settings: Settings) -> LoopConfig:
    """What the GEO process runs: every channel in channel order. A channel without a program
    idles in READY, serving its objects, until a reload brings one (an empty program: a PLC
    START ends at once)."""
    cfg = settings.config
    channels = []
    for c in settings.machine:
        program = c.program
        text = read_program(program)
        channels.append(
            ChannelConfig(
                channel=program_channel(settings, program, text, c.params),  # + subroutines
                program_text=text,
                program_name=str(program) if program else "(none)",
                autostart=c.autostart and program is not None,
                repeat=c.repeat and program is not None,
            )
        )
    return LoopConfig(
        channels=tuple(channels),
        m_ack_auto=cfg.plc.m_ack == "auto",
        m_ack_delay_s=cfg.plc.m_ack_delay_ms * 1e-3,
        rt=RtRequest(**cfg.rt.model_dump(exclude={"stall_timeout_ms"})),
    )


def trace_names(trace: str, settings: Settings) -> list[str]:
    """One trace per channel: the [cnc] channel's at OUT.csv, channel N's at OUT.chN.csv."""
    out = Path(trace)
    return [
        trace
        if i == settings.primary_index
        else str(out.with_name(f"{out.stem}.ch{c.params.channel_id}{out.suffix or '.csv'}"))
        for i, c in enumerate(settings.machine)
    ]


def shape(settings: Settings) -> tuple[tuple[int, int, tuple[int, ...]], ...]:
    """What a reload cannot change: the channels, their axis counts and, with several
    channels, which logical axes each has (channels take a reload one at a time, each at its
    own program boundary: an axis moving between channels would be in two for a while)."""
    several = len(settings.machine) > 1
    return tuple(
        (
            c.params.channel_id,
            len(c.params.axes),
            tuple(ax.log_axis_nr for ax in c.params.axes) if several else (),
        )
        for c in settings.machine
    )


def log_programs(settings: Settings, cfg: LoopConfig, log: Any) -> None:
    """Each channel's program decoded once as the loop will run it: its problems logged
    (nc.problem), its size (daemon.program), or that the channel idles without one."""
    several = len(cfg.channels) > 1
    for c, run in zip(settings.machine, cfg.channels, strict=True):
        tag = {"channel": c.params.channel_id} if several else {}
        if c.program is None:
            idle = "no program: the channel idles until a reload brings one"
            if not several:
                idle = "no [program] file: the channel idles until a reload brings one"
            log.warning("daemon.no_program", detail=idle, **tag)
            continue
        ch = run.channel  # with the program's subroutine files
        home = tuple(0.0 for _ in ch.axes)
        result = decode(run.program_text, DecoderContext.from_channel(ch, home))
        for err in result.errors:
            level = "warning" if err.severity is Severity.WARNING else "error"
            getattr(log, level)(
                "nc.problem",
                file=err.file or str(c.program),
                line=err.line,
                id=err.id,
                message=err.message,
                **tag,
            )
        log.info("daemon.program", file=str(c.program), blocks=len(result.blocks), **tag)
