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

from liftd.cnc import units
from liftd.cnc.params import AxisParams, ChannelParams
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
    subroutine_dirs: tuple[Path, ...] = ()  # [nc] subroutine_dirs, resolved


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
    """Line of key `loc` (section, …, key) in TOML `text`; None if not found (default used).

    The deepest key that is written on a line of its own wins: `[nc.tools]` + `D1 = 0.1`
    finds the D1 line, `tools = { D1 = 0.1 }` under `[nc]` the tools line."""
    keys = [part for part in loc if isinstance(part, str) and part != "[key]"]
    if not keys:
        return None
    lines = text.splitlines()
    header = re.compile(r"^\s*\[\s*([A-Za-z0-9_.]+)\s*\]")
    assign = re.compile(r"^\s*([A-Za-z0-9_]+)\s*=")
    for depth in range(len(keys) - 1, 0, -1):
        section, key = ".".join(keys[:depth]), keys[depth]
        current = ""
        for lineno, line in enumerate(lines, start=1):
            m = header.match(line)
            if m:
                current = m.group(1)
                continue
            m = assign.match(line)
            if m and m.group(1) == key and current == section:
                return lineno
    wanted = ".".join(keys)
    for lineno, line in enumerate(lines, start=1):
        m = header.match(line)
        if m and m.group(1) == wanted:
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
            key = ".".join(str(p) for p in loc if p != "[key]")
            value = str(loc[-2]) if loc[-1:] == ("[key]",) else _value_at(data, loc)
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
    program_path: Path | None = None
    if program is not None:
        program_path = Path(program)
    elif config.program.file:
        program_path = base / config.program.file
    startup = base / config.cnc.startup_list
    nc = config.nc
    lists, problems = read_channel_lists(
        startup,
        config.cnc.channel,
        base / nc.tool_list if nc.tool_list else None,
        base / nc.zero_offset_list if nc.zero_offset_list else None,
    )
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
    zero_offsets = lists.zero_offsets if lists is not None else ()
    if lists is not None:
        zero_offsets = _zero_offsets(config, text, str(path), lists.axes, zero_offsets, problems)
    if lists is None or any(p.severity is Severity.ERROR for p in problems):
        raise ConfigError(problems)
    tools = dict(lists.tool_radii)
    for key, radius_mm in nc.tools.items():
        tools[int(key[1:])] = units.mm_to_m(radius_mm)
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
        tool_radii=tuple(sorted(tools.items())),
        zero_offsets=zero_offsets,
        zero_offset_default=lists.zero_offset_default,
        g53_offsets=lists.g53_offsets or "G53" in nc.zero_offsets,
        max_executed_blocks=nc.max_executed_blocks,
    )
    return Settings(
        path=path,
        config=config,
        channel=channel,
        program=program_path,
        warnings=tuple(p for p in problems if p.severity is Severity.WARNING),
        files=(str(path), *lists.files),
        subroutine_dirs=tuple(base / d for d in nc.subroutine_dirs),
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


def _zero_offsets(
    config: LiftdConfig,
    text: str,
    file: str,
    axes: tuple[AxisParams, ...],
    from_list: tuple[tuple[int, tuple[float, ...]], ...],
    problems: list[Problem],
) -> tuple[tuple[int, tuple[float, ...]], ...]:
    """The zero-offset list's groups with liftd.toml's [nc.zero_offsets] over them (mm)."""
    groups = {g: list(v) for g, v in from_list}
    names = [ax.name for ax in axes]
    for key, values in config.nc.zero_offsets.items():
        group = int(key[1:]) - 53
        row = groups.setdefault(group, [0.0] * len(axes))
        for name, mm in values.items():
            if name not in names:
                problems.append(
                    Problem(
                        Severity.ERROR,
                        file,
                        toml_line(text, ("nc", "zero_offsets", key, name)),
                        f"nc.zero_offsets.{key}.{name}",
                        str(mm),
                        f"not an axis of the channel (axes: {', '.join(names)})",
                    )
                )
                continue
            row[names.index(name)] = units.mm_to_m(mm)
    return tuple((g, tuple(v)) for g, v in sorted(groups.items()))
