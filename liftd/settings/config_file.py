"""liftd.toml as a file: where it is (DESIGN.md §3.1: `-c CONFIG`, `$LIFTD_CONFIG`,
`./config/liftd.toml`, the default configuration shipped inside the package), its text
validated against the model with every problem located (file, line, key, value), and the
error any configuration problem raises."""

from __future__ import annotations

import os
import re
import tomllib
from importlib import resources
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from liftd.settings.isg_list import Problem, Severity
from liftd.settings.model import LiftdConfig


class ConfigError(Exception):
    """The configuration cannot be used; `problems` lists every error and warning found."""

    def __init__(self, problems: list[Problem]) -> None:
        self.problems = problems
        errors = [p for p in problems if p.severity is Severity.ERROR]
        super().__init__("\n".join(str(p) for p in errors) or "configuration error")


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
    # the n-th table of an array of tables ([[channel]]): loc ("channel", n, "id")
    nth = loc[1] if len(loc) > 1 and isinstance(loc[1], int) else None
    lines = text.splitlines()
    header = re.compile(r"^\s*\[(\[?)\s*([A-Za-z0-9_.]+)\s*\]")
    assign = re.compile(r"^\s*([A-Za-z0-9_]+)\s*=")

    def headers() -> list[tuple[int, str, int | None]]:
        seen: dict[str, int] = {}
        out = []
        for lineno, line in enumerate(lines, start=1):
            m = header.match(line)
            if m:
                name = m.group(2)
                index = seen[name] = seen.get(name, -1) + 1
                out.append((lineno, name, index if m.group(1) else None))
        return out

    tables = headers()
    for depth in range(len(keys) - 1, 0, -1):
        section, key = ".".join(keys[:depth]), keys[depth]
        current, index, starts = "", None, {n for n, _, _ in tables}
        at = {n: (name, i) for n, name, i in tables}
        for lineno, line in enumerate(lines, start=1):
            if lineno in starts:
                current, index = at[lineno]
                continue
            m = assign.match(line)
            if m and m.group(1) == key and current == section and (nth is None or index == nth):
                return lineno
    wanted = ".".join(keys)
    for lineno, name, index in tables:
        if name == wanted and (nth is None or index is None or index == nth):
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
            message = err["msg"].removeprefix("Value error, ")  # liftd's own validators' text
            if err["type"] == "extra_forbidden":
                message = "unknown key"
            if key == "ui.token":  # a secret: never printed, also not a wrong one
                value = "(hidden)"
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
