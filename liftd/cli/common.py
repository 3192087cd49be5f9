"""What every command shares: the exit codes, loading liftd.toml (its warnings to stderr),
the PLC schedule of --override/--feedhold and the --channel choice."""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING

from liftd.settings import ConfigError, Problem, Settings, Severity, load_settings
from liftd.settings.load import ChannelSettings

if TYPE_CHECKING:
    from liftd.cnc.plc import Schedule


EXIT_OK = 0
EXIT_PROGRAM = 1
EXIT_CONFIG = 2
EXIT_RUNTIME = 3
EXIT_UNHEALTHY = 1  # healthcheck: the Docker HEALTHCHECK convention
EXIT_SIGPIPE = 141  # stdout's reader closed it: what a shell shows for a tool SIGPIPE ended


def load_config(args: argparse.Namespace, program: str | None = None) -> Settings:
    settings = load_settings(args.config, program)
    for warning in settings.warnings:
        print(warning, file=sys.stderr)
    return settings


def schedule_of(args: argparse.Namespace) -> Schedule:
    """--override / --feedhold as a schedule; raises SpecError (exit 2)."""
    from liftd.cnc.plc import Schedule, parse_feedhold_spec, parse_override_spec  # noqa: PLC0415

    return Schedule(
        tuple(parse_override_spec(args.override or "")),
        tuple(parse_feedhold_spec(args.feedhold or "")),
    )


def channel_arg(settings: Settings, channel: int | None) -> ChannelSettings:
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
