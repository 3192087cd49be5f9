"""Syntax of ISG ASCII parameter lists (start-up, channel and axis lists).

Rules (docs/reference/isg-cnc.md §3.1, Beckhoff TF5200 "comments in ASCII list files",
https://infosys.beckhoff.com/content/1033/tf5200_external_variables/103714955.html):

* one entry per line, ``<key> <value>``; keys are dotted paths with ``[i]`` indices;
* a line starting with ``#`` followed by a blank (or ``#`` alone) is a comment; blank lines
  are allowed;
* after a *numeric* value everything after whitespace is a comment;
* after a *string* value a comment starts with ``(``; a string that itself contains ``(``
  must be written in double quotes;
* numbers may be decimal, signed, floating point or hexadecimal (``0x200000``);
* flag sets are strings joined by ``|`` (``FCT_DEFAULT | FCT_LIFT_UP_TIME``);
* a trailing ``End`` line is accepted and ignored (not documented either way).

This module only splits lines into raw entries; types and meaning come from `isg_schema`.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from enum import Enum
from pathlib import Path


class Severity(Enum):
    ERROR = "error"
    WARNING = "warning"


@dataclass(frozen=True, slots=True)
class Problem:
    """A configuration problem with its location; `str()` is the user-facing message."""

    severity: Severity
    file: str
    line: int | None
    key: str | None
    value: str | None
    message: str

    def __str__(self) -> str:
        where = self.file if self.line is None else f"{self.file}:{self.line}"
        what = ""
        if self.key is not None:
            what = f" {self.key}" + (f" = {self.value!r}" if self.value is not None else "")
        return f"{where}:{what} {self.severity.value}: {self.message}"


@dataclass(frozen=True, slots=True)
class RawEntry:
    key: str
    value: str  # the value text without its comment, quotes removed
    numeric: bool  # True when the value was read as a number (rest of line is a comment)
    line: int
    file: str


_HEX = re.compile(r"[+-]?0[xX][0-9a-fA-F]+\Z")
_INT = re.compile(r"[+-]?\d+\Z")
_FLOAT = re.compile(r"[+-]?(\d+\.\d*|\.\d+|\d+)([eE][+-]?\d+)?\Z")
_KEY = re.compile(r"[A-Za-z_][A-Za-z0-9_]*(\[\d+\])?(\.[A-Za-z_][A-Za-z0-9_]*(\[\d+\])?)*\Z")


def parse_number(text: str) -> int | float | None:
    """Parse an ISG list number: decimal, hex (0x..) or floating point; None if not a number."""
    if _HEX.match(text):
        return int(text, 16)
    if _INT.match(text):
        return int(text, 10)
    if _FLOAT.match(text):
        return float(text)
    return None


@dataclass(frozen=True, slots=True)
class ParsedList:
    file: str
    entries: tuple[RawEntry, ...]
    problems: tuple[Problem, ...]


def parse_list_text(text: str, file: str) -> ParsedList:
    """Split the text of one list into raw entries; never raises on content."""
    entries: list[RawEntry] = []
    problems: list[Problem] = []
    for lineno, raw_line in enumerate(text.splitlines(), start=1):
        line = raw_line.strip()
        if not line or line == "#" or line.startswith(("# ", "#\t")):
            continue
        if line == "End":
            continue
        parts = line.split(None, 1)
        key = parts[0]
        if not _KEY.match(key):
            problems.append(Problem(Severity.ERROR, file, lineno, key, None, "malformed key"))
            continue
        rest = parts[1].strip() if len(parts) > 1 else ""
        if not rest:
            problems.append(Problem(Severity.ERROR, file, lineno, key, None, "missing value"))
            continue
        if rest.startswith('"'):
            end = rest.find('"', 1)
            if end < 0:
                problems.append(
                    Problem(Severity.ERROR, file, lineno, key, rest, "unterminated quoted string")
                )
                continue
            entries.append(RawEntry(key, rest[1:end], False, lineno, file))
            continue
        first = rest.split(None, 1)[0]
        if parse_number(first) is not None:
            entries.append(RawEntry(key, first, True, lineno, file))
            continue
        paren = rest.find("(")
        value = (rest if paren < 0 else rest[:paren]).strip()
        if not value:
            problems.append(Problem(Severity.ERROR, file, lineno, key, None, "missing value"))
            continue
        entries.append(RawEntry(key, value, False, lineno, file))
    return ParsedList(file, tuple(entries), tuple(problems))


UTF8_BOM = b"\xef\xbb\xbf"


def read_list(path: Path) -> ParsedList:
    """Read and split one list file. Raises OSError for unreadable files."""
    # ISG lists are plain ASCII; CP1252 is the CNC's code page for strings
    # (docs/reference/isg-cnc.md §1.1). A file an editor on Windows saved as UTF-8 starts with a
    # byte order mark: it is not part of the first key (read as CP1252 it was "ï»¿# ..."), and the
    # rest is UTF-8.
    data = path.read_bytes()
    if data.startswith(UTF8_BOM):
        text = data[len(UTF8_BOM) :].decode("utf-8", errors="replace")
    else:
        text = data.decode("cp1252", errors="replace")
    return parse_list_text(text, str(path))
