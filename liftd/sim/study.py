"""`liftd study`: `simulate --compare` over a library of NC programs in a process pool.

Each worker runs one program at a time (`compare.compare`, the same call as `simulate
--compare`) and sends back a small `ProgramResult`: one report row and at most
MAX_POINTS_PER_PROGRAM lift points for the figures. The parent gets the results in the order
of the programs, with at most WINDOW_PER_JOB × jobs programs submitted and not yet handed on,
so its memory does not grow with the library. A program that fails in any way (unreadable,
an NC error, not finished within max_time, an exception in liftd, a worker process that died)
is a row that says why, never the end of the study.

May import the core and the rest of `liftd.sim`; the settings reach the workers as values
(`RunSettings`: the channel, the PLC's M acknowledge, max_time) and a callable
(`StudyConfig.sources`, the CLI's `read_sources`) that reads the subroutine files a program
calls, outside the core: in the pool's workers here, on the client for a Dask cluster
(`liftd.sim.cluster`, whose workers get each program's text with its files).
"""

from __future__ import annotations

import concurrent.futures as cf
import dataclasses
import multiprocessing
import resource
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path

from liftd.cnc.params import ChannelParams, NcSources
from liftd.cnc.plc import Schedule
from liftd.sim.compare import METHODS, Comparison, LiftPair, compare
from liftd.sim.summary import JsonObject

Sources = Callable[[Path, str], NcSources]  # program path and text → its subroutine files
WINDOW_PER_JOB = 32
MAX_POINTS_PER_PROGRAM = 400  # lift points a worker sends for the scatter figure
MAX_WHY = 5  # errors spelt out per row (all are counted)
DIED = "the worker process died running it (alone): a crash in liftd or out of memory"


class Status(StrEnum):
    OK = "ok"
    ERROR = "error"  # an NC error stopped the program in either run
    UNFINISHED = "unfinished"  # still running after max_time simulated seconds
    UNREADABLE = "unreadable"
    FAILED = "failed"  # liftd raised, a worker died, or the cluster could not run it


class StudyStopped(Exception):
    """A study that stopped part way (`liftd.sim.cluster`: the scheduler went away, or a
    worker of another liftd version); `results`: those received, in the order of the
    programs, without gaps filled."""

    def __init__(self, message: str, results: list[ProgramResult], lost: bool) -> None:
        super().__init__(message)
        self.results = results
        self.lost = lost  # the scheduler went away (else: a worker of another liftd version)


@dataclass(frozen=True, slots=True)
class RunSettings:
    """What running any program of the study takes besides its text and subroutine files,
    the same for all: pickled once per worker process (scattered once to a cluster)."""

    channel: ChannelParams  # the study's channel; each program's files go in its nc_sources
    m_ack_delay: float  # s, the simulated PLC's M acknowledge
    max_time: float  # simulated seconds per run


@dataclass(frozen=True, slots=True)
class StudyConfig:
    """What every worker of the pool needs; pickled once per worker."""

    run: RunSettings
    sources: Sources  # reads a program's subroutine files (IO: never in the core)


@dataclass(frozen=True, slots=True)
class RowError:
    method: str  # the run it happened in ("advanced", "lifting"), or "" outside the runs
    error_id: int  # ISG id; 0 when liftd itself failed
    line: int
    message: str

    def text(self) -> str:
        if not self.error_id and not self.line:  # not the program's: unreadable, liftd failed
            return self.message
        where = f"{self.method} run, " if self.method else ""
        ident = f"error {self.error_id}" if self.error_id else "failed"
        return f"{where}line {self.line}: {ident}: {self.message}"

    def to_json(self) -> JsonObject:
        return {
            "method": self.method,
            "id": self.error_id,
            "line": self.line,
            "message": self.message,
        }


@dataclass(frozen=True, slots=True)
class ProgramRow:
    """One program of the report. Clearance, peak height and their ratios are over the
    `compared` lifts: those both runs completed and path-based Lifting lifted (the pairs of
    `simulate --compare` with a clearance_ratio); means of the per-lift values [mm]. A program
    that did not run (unreadable, liftd failed) has only its status and errors."""

    program: str
    status: Status
    errors: tuple[RowError, ...] = ()
    lifts: int = 0  # lift pairs (a range either run started)
    compared: int = 0
    suppressed: int = 0
    open: int = 0  # ranges an error stopped the program in (either run)
    clearance_advanced_mm: float | None = None
    clearance_lifting_mm: float | None = None
    clearance_ratio_mean: float | None = None
    clearance_ratio_min: float | None = None
    peak_height_advanced_mm: float | None = None  # how far Z rose above its start
    peak_height_lifting_mm: float | None = None
    duration_advanced_s: float | None = None
    duration_lifting_s: float | None = None
    time_difference_s: float | None = None  # path-based − Advanced: what path-based costs
    lifting_z_overload_cycles: int = 0  # above the P-AXIS-00441 level (00442 included)
    lifting_z_error_cycles: int = 0  # above the P-AXIS-00442 level
    lifting_z_a_max_ratio: float = 0.0  # the largest of its lifts
    unfinished_after: float = 0.0  # unfinished: the simulated seconds it ran (`why` says so)

    @classmethod
    def failed(cls, program: str, status: Status, message: str) -> ProgramRow:
        return cls(program, status, (RowError("", 0, 0, message),))

    @classmethod
    def of(cls, program: str, cmp: Comparison, max_time: float = 0.0) -> ProgramRow:
        s = cmp.summary
        whole = [p for p in s.lifts if p.clearance_ratio is not None]
        adv = [p.advanced for p in whole if p.advanced is not None]
        lift = [p.lifting for p in whole if p.lifting is not None]
        errors = tuple(
            RowError(m, e.error_id, e.line, e.message) for m in METHODS for e in s.run(m).errors
        )
        if cmp.program_error:
            status = Status.ERROR
        elif not cmp.finished:
            status = Status.UNFINISHED
        else:
            status = Status.OK
        return cls(
            program=program,
            status=status,
            lifts=len(s.lifts),
            compared=len(whole),
            suppressed=sum(p.ref.suppressed for p in s.lifts),
            open=sum(_open(p) for p in s.lifts),
            clearance_advanced_mm=_mean(x.mean_clearance_mm for x in adv),
            clearance_lifting_mm=_mean(x.mean_clearance_mm for x in lift),
            clearance_ratio_mean=s.totals.mean_clearance_ratio,
            clearance_ratio_min=s.totals.min_clearance_ratio,
            peak_height_advanced_mm=_mean(x.height_mm for x in adv),
            peak_height_lifting_mm=_mean(x.height_mm for x in lift),
            duration_advanced_s=s.advanced.duration_s,
            duration_lifting_s=s.lifting.duration_s,
            time_difference_s=round(s.lifting.duration_s - s.advanced.duration_s, 6),
            lifting_z_overload_cycles=s.lifting.z_overload.cycles,
            lifting_z_error_cycles=s.lifting.z_overload.error_cycles,
            lifting_z_a_max_ratio=s.totals.z_a_max_ratio.lifting,
            errors=errors,
            unfinished_after=max_time if status is Status.UNFINISHED else 0.0,
        )

    @property
    def why(self) -> str:
        """The first MAX_WHY errors as one line each, joined by "; "."""
        more = len(self.errors) - MAX_WHY
        texts = [e.text() for e in self.errors[:MAX_WHY]]
        if self.unfinished_after:
            texts.insert(
                0, f"did not finish within {self.unfinished_after:g} s simulated (--max-time)"
            )
        return "; ".join(texts) + (f"; … {more} more" if more > 0 else "")

    def value(self, column: str) -> object:
        """The value of a report column (`errors` counts them, `why` spells them out)."""
        if column == "errors":
            return len(self.errors)
        if column == "why":
            return self.why
        if column == "status":
            return self.status.value
        return getattr(self, column)

    def to_json(self) -> JsonObject:
        out = {c: self.value(c) for c in COLUMNS if c != "why"}
        out["errors"] = [e.to_json() for e in self.errors]
        return out

    def csv_row(self) -> list[str]:
        return ["" if (v := self.value(c)) is None else str(v) for c in COLUMNS]


COLUMNS = (  # report.csv, in this order; report.json's rows have the same keys
    "program",
    "status",
    "lifts",
    "compared",
    "suppressed",
    "open",
    "clearance_advanced_mm",
    "clearance_lifting_mm",
    "clearance_ratio_mean",
    "clearance_ratio_min",
    "peak_height_advanced_mm",
    "peak_height_lifting_mm",
    "duration_advanced_s",
    "duration_lifting_s",
    "time_difference_s",
    "lifting_z_overload_cycles",
    "lifting_z_error_cycles",
    "lifting_z_a_max_ratio",
    "errors",
    "why",
)


def _mean(values: Iterator[float] | Sequence[float]) -> float | None:
    items = list(values)
    return round(sum(items) / len(items), 6) if items else None


@dataclass(frozen=True, slots=True)
class ProgramResult:
    """What a worker sends back: the row, the compared lifts as (clearance advanced,
    clearance path-based) in mm (at most MAX_POINTS_PER_PROGRAM, evenly thinned), all their
    clearance ratios, and the worker's peak RSS so far [KiB]."""

    row: ProgramRow
    points: tuple[tuple[float, float], ...] = ()
    ratios: tuple[float, ...] = ()
    max_rss_kib: int = 0

    @classmethod
    def of(cls, program: str, cmp: Comparison, max_time: float = 0.0) -> ProgramResult:
        pairs = [p for p in cmp.summary.lifts if p.clearance_ratio is not None]
        stride = -(-len(pairs) // MAX_POINTS_PER_PROGRAM) or 1
        points = tuple(
            (p.advanced.mean_clearance_mm, p.lifting.mean_clearance_mm)
            for p in pairs[::stride]
            if p.advanced is not None and p.lifting is not None
        )
        ratios = tuple(p.clearance_ratio for p in pairs if p.clearance_ratio is not None)
        return cls(ProgramRow.of(program, cmp, max_time), points, ratios, max_rss_kib())


def _open(pair: LiftPair) -> bool:
    """A range the program stopped inside, in either run (counted once, not per run)."""
    return any(x is not None and x.open for x in (pair.advanced, pair.lifting))


def read_one(
    cfg: StudyConfig, program: str, max_bytes: int | None = None
) -> tuple[str, NcSources] | ProgramResult:
    """A program's text (UTF-8, an undecodable byte replaced by U+FFFD as `simulate` reads it:
    the decoder reports it where it is not in a comment) and its subroutine files, or the row
    that says why not: unreadable, or more than `max_bytes` with its files."""
    path = Path(program)
    try:
        size = path.stat().st_size
        if max_bytes is not None and size > max_bytes:
            return ProgramResult(
                ProgramRow.failed(program, Status.FAILED, too_large(size, max_bytes))
            )
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        reason = f"cannot read program: {exc.strerror or exc}"
        return ProgramResult(ProgramRow.failed(program, Status.UNREADABLE, reason))
    try:
        files = cfg.sources(path, text)
    except Exception as exc:  # a bug in liftd, reported with the program that shows it
        return ProgramResult(ProgramRow.failed(program, Status.FAILED, liftd_failed(exc)))
    if max_bytes is not None:
        size = len(text.encode()) + sum(len(f.text.encode()) for f in files.files if f.text)
        if size > max_bytes:
            return ProgramResult(
                ProgramRow.failed(program, Status.FAILED, too_large(size, max_bytes))
            )
    return text, files


def too_large(size: int, limit: int) -> str:
    return (
        f"too large to send to the cluster: {size / 2**20:.1f} MiB with its subroutine "
        f"files (at most {limit / 2**20:.0f} MiB); run it in a local study"
    )


def liftd_failed(exc: Exception) -> str:
    return f"liftd failed: {type(exc).__name__}: {exc}"


def run_text(run: RunSettings, program: str, text: str, files: NcSources) -> ProgramResult:
    """`simulate --compare` of one program's text with its subroutine files, as a result
    (never raises for the program's sake: an exception in liftd becomes a FAILED row)."""
    try:
        ch = dataclasses.replace(run.channel, nc_sources=files)
        name = Path(program).name
        cmp = compare(ch, text, Schedule(), run.m_ack_delay, None, run.max_time, name, plot=False)
        return ProgramResult.of(program, cmp, run.max_time)
    except Exception as exc:  # a bug in liftd, reported with the program that shows it
        return ProgramResult(ProgramRow.failed(program, Status.FAILED, liftd_failed(exc)))


def run_one(cfg: StudyConfig, program: str) -> ProgramResult:
    """Read one program and its files, then `run_text`: what a worker of the pool does."""
    read = read_one(cfg, program)
    return read if isinstance(read, ProgramResult) else run_text(cfg.run, program, *read)


# -- the pool --------------------------------------------------------------------------------
_config: StudyConfig | None = None  # a worker's configuration, set once by its initializer


def _init_worker(cfg: StudyConfig) -> None:
    global _config  # noqa: PLW0603 (per worker process, set once before any task)
    _config = cfg


def _work(program: str) -> ProgramResult:
    assert _config is not None, "the pool's initializer sets it"
    return run_one(_config, program)


def run_programs(
    programs: Sequence[str],
    cfg: StudyConfig,
    jobs: int,
    on_done: Callable[[ProgramResult], None] | None = None,
) -> Iterator[ProgramResult]:
    """Every program's result, in the order of `programs`, from `jobs` worker processes.
    `on_done` sees each result as it completes (in any order: the progress bar).

    A worker process that dies (a crash in a native library, the OOM killer) breaks the pool
    and fails every program submitted to it; those are run again in a new pool, one at a time,
    so that only the program that kills its worker again is reported FAILED."""
    ctx = multiprocessing.get_context("forkserver")  # no fork of a parent with threads
    ctx.set_forkserver_preload(["liftd.sim.study"])
    window = WINDOW_PER_JOB * jobs
    index: dict[cf.Future[ProgramResult], int] = {}  # in flight → position in `programs`
    ready: dict[int, ProgramResult] = {}  # done, waiting for an earlier one to be handed on
    suspects: deque[int] = deque()  # submitted to a pool that broke: run again, alone
    alone: int | None = None
    submitted = handed = 0

    def pool() -> cf.ProcessPoolExecutor:
        return cf.ProcessPoolExecutor(jobs, ctx, initializer=_init_worker, initargs=(cfg,))

    executor = pool()
    broken = False
    try:
        while handed < len(programs):
            if broken and not index:
                executor.shutdown(wait=True)
                executor, broken = pool(), False
            if not broken and suspects and not index:
                alone = suspects.popleft()
                index[executor.submit(_work, programs[alone])] = alone
            normal = not (broken or suspects or alone is not None)
            while normal and submitted < min(len(programs), handed + window):
                index[executor.submit(_work, programs[submitted])] = submitted
                submitted += 1
            assert index, "the next program to hand on is in flight"
            done, _ = cf.wait(index, return_when=cf.FIRST_COMPLETED)
            for fut in done:
                i = index.pop(fut)
                try:
                    result = fut.result()
                except BrokenProcessPool:
                    broken = True
                    if i != alone:
                        suspects.append(i)
                        continue
                    result = ProgramResult(ProgramRow.failed(programs[i], Status.FAILED, DIED))
                if i == alone:
                    alone = None
                ready[i] = result
                if on_done is not None:
                    on_done(result)
            while handed in ready:
                yield ready.pop(handed)
                handed += 1
    finally:
        executor.shutdown(wait=True, cancel_futures=True)


def max_rss_kib() -> int:
    """The calling process's peak RSS [KiB] (ru_maxrss is KiB on Linux)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
