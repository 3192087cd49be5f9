"""The structure of one NC file: local subroutines (``%L name`` … ``M17``/``M29``) and the main
program part (``%name``), split once into lines; the decoder runs sections of it, one `Frame`
per level of its call stack, and ``L SEQUENCE`` selects a section by block numbers
(`sequence_args`, `sequence_range`).

TF5200 programming manual:
* local subroutines: "%L" + separator + name; all of them before the main program; ended by
  M17/M29, or by the next "%" when M17/M29 is missing; called with ``LL name``
  https://infosys.beckhoff.com/content/1033/tf5200_programming_manual/206828043.html
* global subroutines: a file of their own, called with ``L <file name>``; the ``%name`` line
  is only needed after local subroutines of that file
  https://infosys.beckhoff.com/content/1033/tf5200_programming_manual/206834699.html
* no NC commands are permitted before the definition of a program (same page as local)
* at most P-STUP-00053 (default 50) local subroutine definitions, else ID 20365
  https://infosys.beckhoff.com/content/1033/tf5200_diagnosis/251420299.html
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

from liftd.cnc.nc.blocks import CallSite, ErrorId, NcFault
from liftd.cnc.nc.lexer import strip_comments
from liftd.cnc.pause import pause

MAX_LOCAL_SUBROUTINES = 50  # P-STUP-00053 default
_LOCAL = re.compile(r"\s*%\s*L[ \t]+(\S+)", re.IGNORECASE)
_N_WORD = re.compile(r"\s*N(\d+)", re.IGNORECASE)
# Lines end at LF, CR LF or CR only: what editors and Python's universal newlines
# (the CLI's read_text) count. str.splitlines also breaks at VT, FF, FS/GS/RS, NEL, U+2028/9,
# which shifted every later line number and cut a comment holding one in two (the second half
# an NC error); inside a line those characters are no NC separators (TF5200 programming manual,
# program structure: CR, LF, ETX, TAB, NUL, blank ...), so the lexer reports them at their column.
_LINE_END = re.compile(r"\r\n|\r|\n")


@dataclass(frozen=True, slots=True)
class Section:
    name: str  # local subroutine name as written, or the main program's name
    start: int  # index of the first body line (after the % line)
    end: int  # index after the last body line
    local: bool


@dataclass(frozen=True, slots=True)
class SourceProblem:
    line: int  # 1-based
    error_id: ErrorId
    message: str


@dataclass(slots=True)
class Source:
    """One NC file, split into lines once. `cache` holds per line what the decoder may reuse
    when the line runs again (subroutine bodies): bounded by the file, not by the calls."""

    name: str  # for messages: the program path or the subroutine file's path
    lines: list[str]
    locals: dict[str, Section]  # upper-case name -> section
    main: Section | None
    problems: list[SourceProblem]
    cache: dict[int, object] = field(default_factory=dict)

    def block_number_line(self, number: int, start: int, end: int) -> int | None:
        """Index of the first line in [start, end) whose block number is N<number>."""
        for idx in range(start, end):
            m = _N_WORD.match(self.lines[idx])
            if m is not None and int(m.group(1)) == number:
                return idx
        return None

    def section_of(self, idx: int) -> Section | None:
        if self.main is not None and self.main.start <= idx < self.main.end:
            return self.main
        for sec in self.locals.values():
            if sec.start <= idx < sec.end:
                return sec
        return None


def _has_words(line: str) -> bool:
    text = strip_comments(line).strip()
    return bool(text) and not text.upper().startswith("#COMMENT")


SPLIT_CHUNK = 4096  # characters split at once between two pause points (~30 µs here)


def split_lines(text: str) -> list[str]:
    """The lines of a program text as an editor numbers them (`_LINE_END`); a last line
    break ends the last line (no empty line after it), as with str.splitlines. Split in
    pieces that end at a LF (a CR LF is never cut), with a pause point between them."""
    lines: list[str] = []
    pos, n = 0, len(text)
    while True:
        cut = text.find("\n", pos + SPLIT_CHUNK) if n - pos > SPLIT_CHUNK else -1
        if cut < 0:
            lines += _LINE_END.split(text[pos:] if pos else text)
            break
        piece = _LINE_END.split(text[pos : cut + 1])  # ends with its line break: "" last
        piece.pop()
        lines += piece
        pos = cut + 1
        pause()
    if lines and not lines[-1]:
        lines.pop()
    return lines


def _percent_lines(lines: list[str]) -> list[int]:
    """The indices of the % lines, with a pause point every 256 lines."""
    out: list[int] = []
    step = 256
    for a in range(0, len(lines), step):
        out += [i for i in range(a, min(a + step, len(lines))) if lines[i].lstrip()[:1] == "%"]
        pause()
    return out


def parse_source(name: str, text: str, called: bool = False) -> Source:
    """Split a file into its sections; structural problems are kept for the decoder to
    report where the file is first run. `called`: a global subroutine file (L name), whose
    misplaced % lines are ID 21313 instead of the main program's 20193. A leading byte
    order mark (programs saved as UTF-8 by Windows tools) is not part of the first line."""
    lines = split_lines(text.removeprefix("\ufeff"))
    headers = _percent_lines(lines)
    problems: list[SourceProblem] = []
    locals_: dict[str, Section] = {}
    if not headers:
        return Source(name, lines, locals_, Section("", 0, len(lines), False), problems)
    # "The execution of a main program is also started if the first character found in the
    # file outside comments is neither a space nor a %" -- then every % line is inside that
    # program part: ID 20193 (main program) / 21313 (global subroutine) at the % line
    # https://infosys.beckhoff.com/content/1033/tf5200_diagnosis/251054731.html
    # https://infosys.beckhoff.com/content/1033/tf5200_diagnosis/254175115.html
    percent = ErrorId.PERCENT_IN_SUBROUTINE if called else ErrorId.PERCENT_IN_MAIN
    main: Section | None = None
    after = ""
    first_words = next((i for i in range(headers[0]) if _has_words(lines[i])), None)
    if first_words is not None:
        main = Section("", first_words, headers[0], False)
        after = f" (the NC words in line {first_words + 1} began an unnamed program part)"
    for k, h in enumerate(headers):
        end = headers[k + 1] if k + 1 < len(headers) else len(lines)
        m = _LOCAL.match(lines[h])
        if m is None:
            if main is not None:
                problems.append(SourceProblem(h + 1, percent, "a second main program part" + after))
                continue
            title = lines[h].strip()[1:].strip()
            main = Section(title, h + 1, end, False)
            continue
        sub = m.group(1)
        if main is not None:
            problems.append(
                SourceProblem(
                    h + 1,
                    percent,
                    f"local subroutine {sub} after the main program part: local subroutines "
                    "are defined before it" + after,
                )
            )
            continue
        key = sub.upper()
        if key in locals_:
            problems.append(
                SourceProblem(
                    h + 1,
                    ErrorId.DUPLICATE_SUBROUTINE,
                    f"local subroutine {sub} is defined twice (first at line {locals_[key].start})",
                )
            )
            continue
        if len(locals_) >= MAX_LOCAL_SUBROUTINES:
            problems.append(
                SourceProblem(
                    h + 1,
                    ErrorId.TOO_MANY_LOCAL_SUBS,
                    f"more than {MAX_LOCAL_SUBROUTINES} local subroutines (P-STUP-00053)",
                )
            )
            continue
        locals_[key] = Section(sub, h + 1, end, True)
    return Source(name, lines, locals_, main, problems)


class Frame:
    """One level of the call stack: a section of a file being run."""

    __slots__ = ("cached", "comment", "end", "pos", "reps", "site", "source", "start", "tag")

    def __init__(
        self,
        source: Source,
        start: int,
        end: int,
        site: CallSite | None,
        reps: int = 0,
        tag: str = "",
    ) -> None:
        self.source = source
        self.tag = tag  # Block.file of its lines: "" in the program's own file
        self.start = start
        self.end = end
        self.pos = start
        self.site = site
        self.reps = reps  # further runs of the section after this one (L SEQUENCE REPEAT)
        self.cached = site is not None  # subroutine lines run again: keep their words
        self.comment: int | None = None  # line of an open #COMMENT BEGIN


def sequence_args(content: str, col: int) -> tuple[str, int, int, int]:
    """L SEQUENCE [ [NAME=<file>] N.. [N..] [REPEAT=..] ] (programming manual
    https://infosys.beckhoff.com/content/1033/tf5200_programming_manual/206866443.html);
    REPEAT is read as the number of runs. String labels and ENDTAG are not emulated."""
    name = ""
    numbers: list[int] = []
    repeat = 1
    for item in content.replace(",", " ").split():
        upper = item.upper()
        if upper.startswith("NAME="):
            name = item[5:].strip("\"'")
        elif upper.startswith("REPEAT="):
            try:
                repeat = int(float(upper[7:]))
            except (ValueError, OverflowError):  # REPEAT=x, REPEAT=1e999
                raise NcFault(ErrorId.NUMBER, col, "REPEAT= needs a finite number") from None
            if repeat < 1:
                raise NcFault(ErrorId.NUMBER, col, "REPEAT= must be at least 1")
        elif upper.startswith("N") and upper[1:].isdigit():
            numbers.append(int(upper[1:]))
        else:
            raise NcFault(ErrorId.UNSUPPORTED, col, f"L SEQUENCE: {item} is not emulated by liftd")
    if not 1 <= len(numbers) <= 2:
        raise NcFault(ErrorId.SYNTAX, col, "L SEQUENCE needs one or two block numbers N..")
    return name, numbers[0], numbers[-1], repeat - 1


def sequence_range(
    source: Source, first: int, last: int, col: int, within: tuple[int, int] | None
) -> tuple[int, int]:
    """Lines [start, end) from block N`first` to block N`last` inside `within` (default: the
    file's main program part)."""
    if within is None:
        main = source.main
        within = (main.start, main.end) if main is not None else (0, len(source.lines))
    lo, hi = within
    start = source.block_number_line(first, lo, hi)
    if start is None:
        raise NcFault(ErrorId.SEQUENCE_NOT_FOUND, col, f"L SEQUENCE: no block N{first}")
    stop = source.block_number_line(last, start, hi)
    if stop is None:
        raise NcFault(
            ErrorId.SEQUENCE_NOT_FOUND, col, f"L SEQUENCE: no block N{last} after N{first}"
        )
    return start, stop + 1
