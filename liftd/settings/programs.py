"""Read an NC program's global subroutine files before it is decoded (the decoder is pure:
no file IO inside the core). The files a program calls with ``L <name>`` (and
``L SEQUENCE [NAME=<name> ..]``), and the files those call, are looked up

1. as written, when the name is an absolute path;
2. next to the calling program (TF5200: "path from which the main program was loaded");
3. in liftd.toml's ``[nc] subroutine_dirs``, in order (the CNC's configured program paths,
   P-STUP-00018 ``pfad[i].prg[j]`` / P-CHAN-00401 ``path[i].dir``
   https://infosys.beckhoff.com/content/1033/tf5200_startup_list/123545483.html).

A name that does not match exactly is matched ignoring case (TwinCAT runs on Windows, where
CAM output's ``L PART1.NC`` finds part1.nc). A file that cannot be found or read is passed on
with the reason; the decoder reports it where the program calls it (file, line, call chain).
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Sequence
from pathlib import Path

from liftd.cnc.params import ChannelParams, NcFile, NcSources
from liftd.settings.load import Settings

MAX_FILES = 1000  # distinct subroutine files per program
# `L name` / `L<digits>` (not `LL`, not inside a word), and NAME= of L SEQUENCE
_CALL = re.compile(r"(?<![A-Za-z0-9_.$])[Ll](?:[ \t]+([^\s;(\[]+)|(\d+))")
_SEQ_NAME = re.compile(r"NAME\s*=\s*\"?([^\s\]\"]+)", re.IGNORECASE)
_NOT_FILES = frozenset({"SEQUENCE", "CYCLE"})


def called_names(text: str) -> list[str]:
    """Global subroutine names a text may call, in order of first appearance."""
    names: dict[str, None] = {}
    for m in _CALL.finditer(text):
        name = m.group(1) or m.group(2)
        if name.upper() in _NOT_FILES or name.upper().startswith("V."):
            continue
        names.setdefault(name, None)
    for m in _SEQ_NAME.finditer(text):
        names.setdefault(m.group(1), None)
    return list(names)


def _find(name: str, dirs: Sequence[Path]) -> Path | None:
    path = Path(name.replace("\\", "/"))
    if path.is_absolute():
        return path if path.exists() else None
    for d in dirs:
        candidate = d / path
        if candidate.exists():  # a file, or something that will not read as one
            return candidate
        if len(path.parts) == 1 and d.is_dir():
            lower = name.lower()
            try:
                for entry in d.iterdir():
                    if entry.name.lower() == lower and entry.is_file():
                        return entry
            except OSError:
                continue
    return None


def read_sources(program: Path | None, text: str, dirs: Sequence[Path]) -> NcSources:
    """The program's display name and every global subroutine file it reaches."""
    search = ([program.parent] if program is not None else []) + list(dirs)
    files: list[NcFile] = []
    seen: set[str] = set()
    queue = called_names(text)
    while queue and len(files) < MAX_FILES:
        name = queue.pop(0)
        if name in seen:
            continue
        seen.add(name)
        found = _find(name, search)
        if found is None:
            where = ", ".join(str(d) for d in search) or "no directory"
            files.append(
                NcFile(
                    name,
                    name,
                    error=f"not found (searched next to the program and in "
                    f"[nc] subroutine_dirs: {where})",
                )
            )
            continue
        try:
            body = found.read_text(encoding="utf-8", errors="replace")
        except OSError as exc:
            files.append(NcFile(name, str(found), error=f"cannot be read: {exc.strerror or exc}"))
            continue
        files.append(NcFile(name, str(found), body))
        queue.extend(n for n in called_names(body) if n not in seen)
    return NcSources(str(program) if program is not None else "", tuple(files))


def program_channel(
    settings: Settings, program: Path | None, text: str, channel: ChannelParams | None = None
) -> ChannelParams:
    """The channel parameters (default: the [cnc] channel's) with the program's subroutine
    files, ready for the decoder."""
    sources = read_sources(program, text, settings.subroutine_dirs)
    return dataclasses.replace(channel or settings.channel, nc_sources=sources)


def with_program(settings: Settings, program: Path | None, text: str) -> Settings:
    """Settings whose [cnc] channel runs `program` and carries its subroutine files."""
    channel = program_channel(settings, program, text)
    machine = list(settings.machine)
    machine[settings.primary_index] = dataclasses.replace(
        machine[settings.primary_index], params=channel, program=program
    )
    return dataclasses.replace(settings, channel=channel, program=program, channels=tuple(machine))


def read_program(path: Path | None) -> str:
    """A program's text ("" for none); OSError when it cannot be read."""
    return path.read_text(encoding="utf-8", errors="replace") if path is not None else ""


def machine_programs(settings: Settings) -> list[tuple[ChannelParams, str]]:
    """Every channel in channel order with its program's text and subroutine files (a channel
    without a program: ""). OSError names the program that cannot be read."""
    out = []
    for c in settings.machine:
        text = read_program(c.program)
        out.append((program_channel(settings, c.program, text, c.params), text))
    return out
