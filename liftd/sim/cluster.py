"""`liftd study --scheduler`: the study's programs as tasks on a Dask distributed cluster,
through the library's own client (https://distributed.dask.org/en/stable/client.html).

The workers need liftd installed, not the files: the client reads each program and the
subroutine files it calls (`read_one`, as the local pool's workers do) and a task carries the
program's text and those files; what every task shares (the channel, the PLC's M acknowledge,
max_time: `RunSettings`) is scattered once to every worker (`client.scatter(...,
broadcast=True)`), and so is a subroutine file once a second program calls it (a CAM
library's shape files), up to MAX_SHARED_FILES. The worker runs `run_text`, the local pool's
call, so the rows are the same. Results are handed on in the order of the programs with at
most WINDOW_PER_THREAD × the workers' threads (and WINDOW_BYTES of programs) submitted and not
yet handed on: the client's memory does not grow with the library.

A worker that dies running a task: Dask runs the task again on another worker, up to the
scheduler's `allowed-failures`, then raises KilledWorker. Programs that were on a dying worker
are run again one at a time, alone (as the local pool does), so only the program that kills
its worker alone gets the FAILED row. A task is a function pickled by value that first compares
the worker's liftd version with the client's and refuses to run on another (no mixed results);
its arguments are plain Python values, so a worker of another version unpickles them too.

Raises `ClusterError` (no cluster to run on: nothing written), `StudyStopped` (the scheduler
went away or a worker of another version joined: the results so far come with it). The CLI
maps them to exit codes. May import `liftd.sim`, `liftd.cnc` and distributed (the `cluster`
extra); only `liftd study --scheduler` imports this module.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import itertools
import logging
import pickle
import queue
import uuid
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import CancelledError
from dataclasses import dataclass
from typing import Any

import distributed
from distributed.comm.addressing import get_address_host_port

from liftd import __version__
from liftd.cnc.params import NcFile, NcSources
from liftd.sim.study import (
    ProgramResult,
    ProgramRow,
    RunSettings,
    Status,
    StudyConfig,
    StudyStopped,
    read_one,
    run_text,
)

CONNECT_TIMEOUT_S = 30.0  # to the scheduler, then for a first worker (--timeout)
WINDOW_PER_THREAD = 16  # tasks submitted and not yet handed on, per worker thread
WINDOW_BYTES = 256 * 2**20  # … and their texts at most (one task always)
MAX_SEND_BYTES = 32 * 2**20  # a program with its subroutine files; larger: a FAILED row
MAX_SHARED_FILES = 256  # subroutine files scattered once (called by two programs or more)
MAX_SHARED_BYTES = 64 * 2**20
MAX_SIGHTINGS = 8192  # subroutine files remembered to find the second caller
MAX_RENEWALS = 20  # times the shared data is scattered again after every holder died
CANCELLED = "cancelled"
POLL_S = 1.0  # how often a wait for results looks at the client's connection
DIED = (
    "the Dask workers running it died (alone on its worker: Dask gave up after its "
    "allowed-failures): a crash in liftd or out of memory"
)
File = tuple[str, str, Any, str | None]  # NcFile's fields; the text may be a scattered Future


class TaskFailed(Exception):
    """liftd raised on the worker (the task returns it as text)."""


class ClusterError(Exception):
    """No study on this cluster (unreachable, no worker, another liftd version)."""


@dataclass(frozen=True, slots=True)
class Cluster:
    """A connected client and what the study needs to know of its workers."""

    client: distributed.Client
    address: str
    workers: int
    threads: int


def _make_probe() -> Callable[[], str]:
    def liftd_version() -> str:
        import liftd  # noqa: PLC0415 (the worker's own)

        return str(liftd.__version__)

    return liftd_version  # nested: pickled by value, runs on a worker of any liftd version


def _make_task() -> Callable[..., tuple[str, object]]:
    def liftd_study(
        version: str, settings: bytes, program: str, text: str, name: str, files: list[File]
    ) -> tuple[str, object]:
        import liftd  # noqa: PLC0415 (the worker's own: refuse before unpickling any of ours)

        if liftd.__version__ != version:
            import distributed  # noqa: PLC0415

            return "refused", (str(liftd.__version__), distributed.get_worker().address)
        try:
            from liftd.sim.cluster import work  # noqa: PLC0415

            return "done", work(settings, program, text, name, files)
        except Exception as exc:  # as text: an exception Dask cannot pickle hangs the client
            return "failed", f"{type(exc).__name__}: {exc}"

    return liftd_study  # nested: pickled by value, so any worker runs it and can refuse


def work(settings: bytes, program: str, text: str, name: str, files: list[File]) -> ProgramResult:
    """A task on a worker: the local pool's `run_text` on what the task carried."""
    sources = NcSources(name, tuple(NcFile(*f) for f in files))
    return run_text(_settings(settings), program, text, sources)


@functools.lru_cache(maxsize=4)
def _settings(payload: bytes) -> RunSettings:
    value = pickle.loads(payload)  # from the study's client, as Dask unpickles its tasks
    assert isinstance(value, RunSettings)
    return value


@contextlib.contextmanager
def _quiet_dask() -> Iterator[None]:
    """distributed logs each reconnect attempt with a traceback; the CLI says what happened."""
    log = logging.getLogger("distributed")
    level = log.level
    log.setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        log.setLevel(level)


def connect(address: str, timeout: float) -> Cluster:
    """A client of the scheduler at `address` with at least one worker, all of this liftd
    version, within `timeout` seconds each; else ClusterError."""
    try:
        get_address_host_port(address)
    except ValueError as exc:  # before a Client, which would try it for `timeout`
        raise ClusterError(
            f"{address} is not a scheduler address such as tcp://10.0.0.5:8786: {exc}"
        ) from None
    client = distributed.Client.__new__(distributed.Client)  # ours to close when it fails
    try:
        with _quiet_dask():
            client.__init__(address, timeout=timeout, set_as_default=False)  # type: ignore[misc]
    except Exception as exc:  # refused, timed out, a peer that is no scheduler
        _abandon(client)
        if isinstance(exc, OSError | TimeoutError):
            why = f"{type(exc).__name__}: {exc}"
        else:  # e.g. MemoryError: an HTTP server's reply read as a Dask frame's length
            why = f"it does not answer as a Dask scheduler ({type(exc).__name__})"
        raise ClusterError(
            f"cannot reach the Dask scheduler at {address} within {timeout:g} s: {why}"
        ) from None
    try:
        client.wait_for_workers(1, timeout=timeout)
        versions = client.run(_make_probe(), on_error="return")
        other = {w: v for w, v in versions.items() if v != __version__}
        if other:
            worker, version = sorted(other.items())[0]
            raise ClusterError(_mismatch(str(worker), version, len(other)))
        info = client.scheduler_info(n_workers=-1)
        threads = sum(int(w.get("nthreads", 1)) for w in info["workers"].values())
        return Cluster(client, address, len(info["workers"]), max(1, threads))
    except ClusterError:
        close(client)
        raise
    except Exception as exc:  # no worker in time, or the scheduler went away meanwhile
        close(client)
        what = "no Dask worker joined" if isinstance(exc, TimeoutError) else "the scheduler failed"
        raise ClusterError(
            f"{what} at {address} within {timeout:g} s: {type(exc).__name__}: {exc}"
        ) from None


def _mismatch(worker: str, version: object, count: int = 1) -> str:
    text = version if isinstance(version, str) else f"{type(version).__name__}: {version}"
    more = f" (and {count - 1} more)" if count > 1 else ""
    return (f"the Dask worker {worker}{more} runs liftd {text}, this client liftd {__version__}: "
            "install the same liftd on every worker")  # fmt: skip


def _abandon(client: distributed.Client) -> None:
    """A client whose start failed: stop it without its `__del__` retrying the close for
    2 × timeout and printing a traceback when the object is collected."""
    with _quiet_dask(), contextlib.suppress(Exception):
        client.close(timeout=1)
    if getattr(client, "status", "closed") != "closed":
        client.status = "closed"
        with contextlib.suppress(Exception):
            client._loop_runner.stop()


def close(client: distributed.Client) -> None:
    with _quiet_dask(), contextlib.suppress(Exception):  # a scheduler gone: nothing to close
        client.close(timeout=5)


class _SharedFiles:
    """Subroutine files scattered once to every worker, from a file's second caller on."""

    def __init__(self, client: distributed.Client) -> None:
        self.client = client
        self.seen: set[bytes] = set()
        self.shared: dict[bytes, distributed.Future[Any]] = {}
        self.bytes = 0

    def text(self, f: NcFile) -> Any:
        """The file's text, or a Future of it on the workers."""
        if f.text is None:
            return None
        key = hashlib.blake2b(f"{f.path}\0{f.text}".encode(), digest_size=16).digest()
        if (fut := self.shared.get(key)) is not None:
            return fut
        size = len(f.text.encode())
        full = len(self.shared) >= MAX_SHARED_FILES or self.bytes + size > MAX_SHARED_BYTES
        if key not in self.seen or full:
            if len(self.seen) < MAX_SIGHTINGS:
                self.seen.add(key)
            return f.text
        fut = self.client.scatter(f.text, broadcast=True, hash=False)
        self.shared[key], self.bytes = fut, self.bytes + size
        return fut


class _Scattered:
    """What the tasks share on the workers: the settings and the library's files. Scattered
    data has no lineage: when every worker holding it has died, Dask cancels the tasks that
    need it ("lost dependencies") while the scheduler is still there; `renew` scatters it
    again, as a new generation, and those tasks are submitted again."""

    def __init__(self, client: distributed.Client, payload: bytes) -> None:
        self.client = client
        self.payload = payload
        self.generation = -1
        self.renew()

    def renew(self) -> None:
        self.generation += 1
        self.settings = self.client.scatter(self.payload, broadcast=True, hash=False)
        self.files = _SharedFiles(self.client)


def run_programs(
    cluster: Cluster,
    programs: Sequence[str],
    cfg: StudyConfig,
    on_done: Callable[[ProgramResult], None] | None = None,
) -> Iterator[ProgramResult]:
    """Every program's result in the order of `programs`, from the cluster's workers (as
    `study.run_programs` from a local pool). Raises StudyStopped."""
    with _quiet_dask():  # the reasons are the rows' and StudyStopped's: no reconnect tracebacks
        yield from _run(cluster, programs, cfg, on_done)


def _run(
    cluster: Cluster,
    programs: Sequence[str],
    cfg: StudyConfig,
    on_done: Callable[[ProgramResult], None] | None,
) -> Iterator[ProgramResult]:
    client = cluster.client
    task = _make_task()
    tag = uuid.uuid4().hex[:8]
    keys = itertools.count()  # a program run again alone gets a new key
    shared = _Scattered(client, pickle.dumps(cfg.run))
    done: queue.Queue[tuple[int, distributed.Future[Any]]] = queue.Queue()
    window = WINDOW_PER_THREAD * cluster.threads
    # position → (task, its bytes, the generation of the shared data it uses)
    flight: dict[int, tuple[distributed.Future[Any], int, int]] = {}
    ready: dict[int, ProgramResult] = {}
    suspects: deque[int] = deque()  # were on a worker that died: run again, alone
    alone: int | None = None
    submitted = handed = 0

    def submit(i: int) -> ProgramResult | None:
        read = read_one(cfg, programs[i], MAX_SEND_BYTES)
        if isinstance(read, ProgramResult):
            return read
        text, sources = read
        files = [(f.name, f.path, shared.files.text(f), f.error) for f in sources.files]
        fut = client.submit(task, __version__, shared.settings, programs[i], text,
                            sources.program, files, key=f"liftd-study-{tag}-{next(keys)}",
                            pure=False)  # fmt: skip
        fut.add_done_callback(lambda f: done.put((i, f)))
        flight[i] = (fut, len(text), shared.generation)
        return None

    def finish(i: int, result: ProgramResult) -> None:
        ready[i] = result
        if on_done is not None:
            on_done(result)

    def stopped(message: str, lost: bool) -> StudyStopped:
        for fut, _, _ in flight.values():
            fut.cancel()
        return StudyStopped(message, [r for _, r in sorted(ready.items())], lost)

    try:
        while handed < len(programs):
            normal = not (suspects or alone is not None)
            while (
                normal
                and submitted < min(len(programs), handed + window)
                and (not flight or sum(b for _, b, _ in flight.values()) < WINDOW_BYTES)
            ):
                if (result := submit(submitted)) is not None:
                    finish(submitted, result)
                submitted += 1
            if suspects and not flight:
                alone = suspects.popleft()
                if (result := submit(alone)) is not None:
                    finish(alone, result)
                    alone = None
            if flight:
                i, outcome = _next(done, client)
                if outcome is None or (isinstance(outcome, str) and client.status != "running"):
                    raise stopped(_lost(cluster.address, len(ready) + handed, len(programs)), True)
                _, _, generation = flight.pop(i)
                if isinstance(outcome, str):  # CANCELLED, the scheduler there: the workers lost
                    # the shared data (every worker that held it died): scatter it again
                    if shared.generation >= MAX_RENEWALS:
                        raise stopped(_renewals(cluster.address), True)
                    if generation == shared.generation:
                        shared.renew()
                    if (result := submit(i)) is not None:
                        finish(i, result)
                    continue
                if isinstance(outcome, BaseException):
                    if isinstance(outcome, distributed.KilledWorker) and i != alone:
                        suspects.append(i)
                        continue
                    outcome = _failed(programs[i], outcome)
                elif isinstance(outcome, tuple):
                    raise stopped(_mismatch(outcome[1], outcome[0]), False)
                if i == alone:
                    alone = None
                finish(i, outcome)
            while handed in ready:
                yield ready.pop(handed)
                handed += 1
    finally:
        for fut, _, _ in flight.values():
            fut.cancel()


def _next(
    done: queue.Queue[tuple[int, distributed.Future[Any]]], client: distributed.Client
) -> tuple[int, ProgramResult | BaseException | tuple[str, str] | str | None]:
    """The next task to finish: its result, its exception, (the other liftd version, worker)
    that refused it, CANCELLED (the scheduler went away, or the data it needed was lost), or
    None when the client has closed."""
    while True:
        try:
            i, fut = done.get(timeout=POLL_S)
        except queue.Empty:
            if client.status in ("closing", "closed"):
                return -1, None
            continue
        if fut.status == "cancelled":
            return i, CANCELLED
        if fut.status == "error":
            return i, fut.exception()
        try:
            kind, value = fut.result()
        except CancelledError:  # finished, but its worker died before the result came over
            return i, CANCELLED
        except Exception as exc:
            return i, exc
        if kind == "refused":
            version, worker = value
            return i, (str(version), str(worker))
        if kind == "failed":
            return i, TaskFailed(str(value))
        assert isinstance(value, ProgramResult)
        return i, value


def _failed(program: str, exc: BaseException) -> ProgramResult:
    if isinstance(exc, distributed.KilledWorker):
        reason = DIED
    elif isinstance(exc, TaskFailed):  # raised by liftd outside run_text, which catches its own
        reason = f"liftd failed: {exc}"
    else:
        reason = f"the cluster could not run it: {type(exc).__name__}: {exc}"
    return ProgramResult(ProgramRow.failed(program, Status.FAILED, reason))


def _renewals(address: str) -> str:
    return (f"the Dask workers at {address} lost the study's shared data {MAX_RENEWALS} times "
            "(every worker holding it died)")  # fmt: skip


def _lost(address: str, received: int, total: int) -> str:
    return (f"the Dask scheduler at {address} went away: {received} of {total} programs "
            "received")  # fmt: skip
