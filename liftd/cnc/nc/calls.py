"""Subroutine calls of the NC decoder: `SubroutineCalls` owns the global subroutine files (read by
the caller into `DecoderContext.sources`, parsed once; a missing one reported once) and the
bodies run once for checking after the first error, and pushes each call as a frame on the
frame stack (`report.Report.stack`): ``LL name`` (a local subroutine of the calling file),
``L file`` (a global subroutine file's main program part) and ``L SEQUENCE [..]`` (a block
range, repeated). Changes with how the decoder finds and calls subroutines; the program decoder
(`decoder.py`) runs the frames and returns from them.
"""

from __future__ import annotations

from liftd.cnc.nc.blocks import CallSite, ErrorId, NcFault
from liftd.cnc.nc.context import DecoderContext
from liftd.cnc.nc.execution import Execution
from liftd.cnc.nc.lexer import Token
from liftd.cnc.nc.report import AlreadyReported, Report
from liftd.cnc.nc.sources import Frame, Section, Source, parse_source, sequence_args, sequence_range


class SubroutineCalls:
    """The calls' part of the program decoder: finds the called section, pushes its frame."""

    def __init__(self, ctx: DecoderContext, report: Report, execution: Execution) -> None:
        self.ctx = ctx
        self.report = report
        self.stack = report.stack  # the frame stack the calls push on
        self.execution = execution  # stopped at the first error: each body is checked once
        self.files: dict[str, Source] = {}  # global subroutine files parsed, by name
        self.missing: set[str] = set()  # global subroutine files not found (reported once)
        self.visited_after_stop: set[tuple[str, int]] = set()

    # -- subroutines ---------------------------------------------------------------------------
    def call(self, frame: Frame, tok: Token, lineno: int) -> None:
        """The call `tok` in line `lineno` of `frame`: push the called section's frame."""
        kind, name, col = tok.letter, tok.text, tok.column
        written = (
            f"{'LL ' if kind == 'LL' else 'L '}{name}"
            if kind != "SEQ"
            else (f"L SEQUENCE [{name}]")
        )
        if len(self.stack) > self.ctx.max_call_depth:
            # https://infosys.beckhoff.com/content/1033/tf5200_diagnosis/251402891.html
            raise NcFault(
                ErrorId.CALL_DEPTH,
                col,
                f"{written}: subroutines nested deeper than {self.ctx.max_call_depth} levels "
                "(endless recursion?)",
            )
        reps = 0
        if kind == "LL":
            source = frame.source
            section: Section | None = source.locals.get(name.upper())
            if section is None:
                raise NcFault(
                    ErrorId.SUBROUTINE_NOT_FOUND,
                    col,
                    f"LL {name}: no local subroutine %L {name} in this file",
                )
            start, end = section.start, section.end
        else:
            target = name
            if kind == "SEQ":
                target, first, last, reps = sequence_args(name, col)
            source = frame.source if kind == "SEQ" and not target else self._global(target, col)
            if kind == "SEQ":
                # without NAME the sequence runs in the current program part, else in the
                # named file's main program part
                own = (frame.start, frame.end) if not target else None
                start, end = sequence_range(source, first, last, col, own)
            else:
                if source.main is None:
                    raise NcFault(
                        ErrorId.PROGRAM_STRUCTURE,
                        col,
                        f"L {name}: the file has no main program part to run",
                    )
                start, end = source.main.start, source.main.end
        if self.execution.stopped:  # checking only: each body once
            key = (source.name, start)
            if key in self.visited_after_stop:
                return
            self.visited_after_stop.add(key)
            reps = 0
        site = CallSite(self.report.file(frame) or "(program)", lineno, written)
        tag = "" if source.name == self.ctx.sources.program else source.name
        self.stack.append(Frame(source, start, end, site, reps, tag))

    def _global(self, name: str, col: int) -> Source:
        cached = self.files.get(name)
        if cached is not None:
            return cached
        if name in self.missing:  # one root cause, one error
            raise AlreadyReported
        nc_file = self.ctx.sources.find(name)
        if nc_file is None or nc_file.text is None:
            self.missing.add(name)
            reason = nc_file.error if nc_file is not None and nc_file.error else "not found"
            self.execution.error(
                ErrorId.FILE_NOT_FOUND, col, f"L {name}: global subroutine {reason}"
            )
            raise AlreadyReported
        source = parse_source(nc_file.path, nc_file.text, called=True)
        self.files[name] = source
        self.source_problems(source)
        return source

    def source_problems(self, source: Source) -> None:
        """The structure errors found parsing a file, at their lines."""
        for p in source.problems:
            self.execution.error(p.error_id, 1, p.message, line=p.line, file=source.name)
