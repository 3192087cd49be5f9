"""The blocks an NC program runs, up to its first error: `Execution` owns the blocks decoded and
not yet streamed (`out`), the stop at the first error ("the path motion is always executed up
to the last correctly decoded point", vendor text §2.1.3 case 2) and the lift range open at it.
It passes the blocks through tool radius compensation when that is engaged (`trc.Trc`, whose
selection the G functions own) and checks the compensated path. Errors that stop the program
are reported here, warnings straight to `report.Report`.
"""

from __future__ import annotations

from liftd.cnc.nc.blocks import Block, ErrorId, LiftStart, NcFault, Severity
from liftd.cnc.nc.context import DecoderContext
from liftd.cnc.nc.modal import ModalDecoder
from liftd.cnc.nc.report import Report
from liftd.cnc.nc.trc import Trc


class Execution:
    """The blocks run (`out`) and the stop at the first error (`stopped`, `open_at_error`)."""

    def __init__(self, ctx: DecoderContext, report: Report, modal: ModalDecoder, trc: Trc) -> None:
        self.ctx = ctx
        self.report = report
        self.modal = modal  # its lift range open at the first error
        self.trc = trc  # engaged or not as the G functions select it
        self.out: list[Block] = []  # decoded, not yet streamed
        self.stopped = False  # an error was found: no further blocks are executed
        self.open_at_error: LiftStart | None = None  # lift range open at the first error

    def error(
        self,
        eid: ErrorId | int,
        column: int,
        message: str,
        *,
        line: int | None = None,
        file: str | None = None,
        severity: Severity = Severity.ERROR,
    ) -> None:
        """Report a finding at the line being decoded (or the one given); the first error stops
        the program (the block TRC holds was decoded correctly: it runs)."""
        lineno, where = self.report.where(line, file)
        if severity is Severity.ERROR and not self.stopped:
            self.open_at_error = self.modal.open_lift
            for b in self.trc.flush():
                self.put(b)
            self.stopped = True
        self.report.add(eid, column, message, lineno, where, severity)

    def emit(self, block: Block) -> None:
        """A decoded block: through TRC when engaged (its compensated path is checked)."""
        if self.stopped:
            return
        if self.trc.engaged:
            for b in self.trc.process(block):
                self._checked(b)
            return
        if block.motion is not None:
            self.out.append(block)
            return
        self.put(block)

    def flush(self) -> None:
        """The program's end: the block TRC still holds runs as it is."""
        for b in self.trc.flush():
            self.put(b)

    def put(self, block: Block) -> None:
        """A final block, unless it carries nothing."""
        if (
            block.motion is None
            and block.dwell is None
            and not block.m_functions
            and block.flush is None
            and block.slope is None
            and block.lift_start is None
            and block.lift_end is None
            and not block.program_end
        ):
            return
        self.out.append(block)

    def _checked(self, block: Block) -> None:
        """A block of the compensated path: its motion is checked against the limits."""
        motion = block.motion
        if motion is None:
            self.put(block)
            return
        try:
            self.ctx.check_motion(motion, 1)
        except NcFault as err:
            where = block.file or self.ctx.sources.program
            self.error(err.error_id, err.column, err.message, line=block.line, file=where)
            return
        self.out.append(block)
