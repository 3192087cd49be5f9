"""Find, read and validate the configuration: liftd.toml plus the ISG lists it points at.

Search order (DESIGN.md §3.1): `-c CONFIG`, `$LIFTD_CONFIG`, `./config/liftd.toml`, the default
configuration shipped inside the package. Every problem names file, line, key and value.
"""

from __future__ import annotations

import os
import re
import tomllib
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from liftd.cnc.params import ChannelParams
from liftd.settings.cnc_lists import read_channel_lists
from liftd.settings.isg_list import Problem, Severity
from liftd.settings.model import LiftdConfig


class ConfigError(Exception):
    """The configuration cannot be used; `problems` lists every error and warning found."""

    def __init__(self, problems: list[Problem]) -> None:
        self.problems = problems
        errors = [p for p in problems if p.severity is Severity.ERROR]
        super().__init__("\n".join(str(p) for p in errors) or "configuration error")


@dataclass(frozen=True, slots=True)
class Settings:
    """Everything liftd needs from its configuration files."""

    path: Path  # the liftd.toml that was used
    config: LiftdConfig
    channel: ChannelParams
    program: Path | None
    warnings: tuple[Problem, ...]
    files: tuple[str, ...]  # every file read, for messages and reloads


def default_config_path() -> Path:
    """The configuration shipped with the package (wheel) or the source tree (editable)."""
    packaged = resources.files("liftd") / "_config" / "liftd.toml"
    if packaged.is_file():
        return Path(str(packaged))
    return Path(__file__).resolve().parents[2] / "config" / "liftd.toml"


def find_config(explicit: str | None) -> Path:
    if explicit:
        return Path(explicit)
    env = os.environ.get("LIFTD_CONFIG")
    if env:
        return Path(env)
    local = Path("config/liftd.toml")
    if local.is_file():
        return local
    return default_config_path()


def toml_line(text: str, loc: tuple[str | int, ...]) -> int | None:
    """Line of key `loc` (section, key) in TOML `text`; None if not found (default used)."""
    if not loc:
        return None
    keys = [str(part) for part in loc if isinstance(part, str)]
    section, key = (keys[0], keys[1]) if len(keys) >= 2 else ("", keys[0])
    current = ""
    header = re.compile(r"^\s*\[\s*([A-Za-z0-9_.]+)\s*\]")
    assign = re.compile(r"^\s*([A-Za-z0-9_]+)\s*=")
    for lineno, line in enumerate(text.splitlines(), start=1):
        m = header.match(line)
        if m:
            current = m.group(1)
            if not section and current == key:
                return lineno
            continue
        m = assign.match(line)
        if m and m.group(1) == key and current == section:
            return lineno
    return None


def parse_config_text(text: str, file: str) -> LiftdConfig:
    """Validate the text of a liftd.toml. Raises ConfigError naming file, line, key, value."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        m = re.search(r"line (\d+)", str(exc))
        line = int(m.group(1)) if m else None
        raise ConfigError(
            [Problem(Severity.ERROR, file, line, None, None, f"TOML syntax: {exc}")]
        ) from None
    try:
        return LiftdConfig.model_validate(data)
    except ValidationError as exc:
        problems = []
        for err in exc.errors():
            loc = tuple(err["loc"])
            key = ".".join(str(p) for p in loc)
            value = _value_at(data, loc)
            message = err["msg"]
            if err["type"] == "extra_forbidden":
                message = "unknown key"
            problems.append(
                Problem(Severity.ERROR, file, toml_line(text, loc), key, value, message)
            )
        raise ConfigError(problems) from None


def _value_at(data: dict[str, Any], loc: tuple[Any, ...]) -> str | None:
    node: Any = data
    for part in loc:
        if (isinstance(node, dict) and part in node) or (
            isinstance(node, list | tuple) and isinstance(part, int) and part < len(node)
        ):
            node = node[part]
        else:
            return None
    return None if isinstance(node, dict) else str(node)


def load_settings(explicit: str | None = None, program: str | None = None) -> Settings:
    """Load liftd.toml and the CNC lists. Raises ConfigError with every problem found."""
    path = find_config(explicit)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        reason = getattr(exc, "strerror", None) or str(exc)
        raise ConfigError(
            [Problem(Severity.ERROR, str(path), None, None, None, f"cannot read: {reason}")]
        ) from None
    config = parse_config_text(text, str(path))
    base = path.parent
    startup = base / config.cnc.startup_list
    lists, problems = read_channel_lists(startup, config.cnc.channel)
    if lists is not None:
        names = [ax.name for ax in lists.axes]
        if config.cnc.lift_axis not in names:
            problems.append(
                Problem(
                    Severity.ERROR,
                    str(path),
                    toml_line(text, ("cnc", "lift_axis")),
                    "cnc.lift_axis",
                    config.cnc.lift_axis,
                    f"not an axis of channel {config.cnc.channel} (axes: {', '.join(names)})",
                )
            )
    if lists is None or any(p.severity is Severity.ERROR for p in problems):
        raise ConfigError(problems)
    channel = ChannelParams(
        channel_id=lists.channel_id,
        axes=lists.axes,
        lift_axis=config.cnc.lift_axis,
        lift_method=lists.lift_method,
        cycle_time=config.cnc.cycle_time_us * 1e-6,
        lift_min_dist=lists.lift_min_dist,
        slope=lists.slope,
        look_ahead_blocks=lists.look_ahead_blocks,
        max_radius_diff=lists.max_radius_diff,
        m_synch=lists.m_synch,
        path_prep_flags=lists.path_prep_flags,
        ipo_flags=lists.ipo_flags,
    )
    program_path: Path | None = None
    if program is not None:
        program_path = Path(program)
    elif config.program.file:
        program_path = base / config.program.file
    return Settings(
        path=path,
        config=config,
        channel=channel,
        program=program_path,
        warnings=tuple(p for p in problems if p.severity is Severity.WARNING),
        files=(str(path), *lists.files),
    )


def program_problem(settings: Settings, explicit: str | None = None) -> Problem | None:
    """The program `liftd run` would start cannot be read: an error naming the file, and the
    line, key and value of liftd.toml that name it (None when there is no program or it reads).
    `liftd check` reports the same as a program error instead."""
    program = settings.program
    if program is None:
        return None
    try:
        with program.open("rb"):
            return None
    except OSError as exc:
        reason = exc.strerror or str(exc)
    if explicit is not None:
        return Problem(Severity.ERROR, explicit, None, None, None, f"cannot read program: {reason}")
    try:
        text = settings.path.read_text(encoding="utf-8")
    except OSError:
        text = ""
    return Problem(Severity.ERROR, str(settings.path), toml_line(text, ("program", "file")),
                   "program.file", settings.config.program.file,
                   f"cannot read the program {program}: {reason}")  # fmt: skip
