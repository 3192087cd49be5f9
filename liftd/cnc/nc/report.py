"""What the NC decoder reports, and where it is: `Report` owns the frame stack (the sections
being run, `sources.Frame`) and the line being decoded, which locate every error and warning,
the errors and warnings found (each reported once per place), and the count of the blocks run
approximated ("not emulated", one warning per kind). The G functions, the modal decoder, the
subroutine calls and the program decoder all report through it; whether the program still runs
after an error is `execution.Execution`'s.
"""

from __future__ import annotations

from liftd.cnc.nc.blocks import CallSite, ErrorId, NcError, NcFault, Severity, chain_text
from liftd.cnc.nc.sources import Frame


class AlreadyReported(NcFault):
    """An error that was reported where it was found (raised to reject its block only)."""

    def __init__(self) -> None:
        super().__init__(ErrorId.FILE_NOT_FOUND, 1, "")


class Report:
    """The decoder's errors, warnings and not-emulated counts, located by its frame stack."""

    def __init__(self, program: str) -> None:
        self.program = program  # the program's file name (`NcSources.program`)
        self.stack: list[Frame] = []  # the sections being run, the innermost last
        self.line = 0  # the line being decoded, for messages
        self.errors: list[NcError] = []
        self.seen: set[tuple[str, int, int, int]] = set()
        self.not_emulated: dict[str, int] = {}

    # -- where the decoder is ------------------------------------------------------------------
    def depth(self) -> int:
        """Sections on the call stack: 1 in the main program."""
        return len(self.stack)

    def file(self, frame: Frame | None = None) -> str:
        f = frame or (self.stack[-1] if self.stack else None)
        return f.source.name if f is not None else self.program

    def chain(self) -> tuple[CallSite, ...]:
        return tuple(f.site for f in self.stack if f.site is not None)

    # -- findings --------------------------------------------------------------------------------
    def where(self, line: int | None, file: str | None) -> tuple[int, str]:
        """The line and file of a finding: the line being decoded in the innermost section
        unless given."""
        return (self.line if line is None else line), (self.file() if file is None else file)

    def add(
        self,
        eid: ErrorId | int,
        column: int,
        message: str,
        line: int,
        file: str,
        severity: Severity,
    ) -> None:
        """One finding, once per place (file, line, column, id), with its call chain."""
        chain = self.chain()
        key = (file, line, column, int(eid))
        if key in self.seen:
            return
        self.seen.add(key)
        if chain:
            message += f" (call chain: {chain_text(chain)})"
        file_tag = "" if file == self.program else file
        self.errors.append(NcError(int(eid), line, column, message, severity, file_tag, chain))

    def warn(self, eid: ErrorId, column: int, message: str) -> None:
        line, file = self.where(None, None)
        self.add(eid, column, message, line, file, Severity.WARNING)

    def count(
        self, kind: str, column: int, message: str, eid: ErrorId = ErrorId.NOT_EMULATED
    ) -> None:
        """Something accepted but run approximated: one warning per kind, counted per block."""
        if kind not in self.not_emulated:
            self.not_emulated[kind] = 0
            self.warn(eid, column, message)
        self.not_emulated[kind] += 1
