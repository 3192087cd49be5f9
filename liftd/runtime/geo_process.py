"""The GEO process as the daemon sees it, behind one object: start it (`python -m
liftd.runtime`, a clean interpreter), hand it its configuration, know when it cycles, pass its
events on, notice when it dies or stalls, hand over a reload, stop it and summarise its run.

This is the daemon's only seam to the real-time side. It runs in the daemon's event loop but
logs nothing itself: events go to `on_event`, failures are returned by `supervise()`, the
summary is a value. What it publishes each cycle the daemon reads from
the shared block itself. The block's name is removed as soon as the child holds its
descriptor, so nothing is left in /dev/shm whichever process ends first, or how.
"""

from __future__ import annotations

import asyncio
import os
import subprocess
import sys
import time
from collections.abc import Callable
from typing import NamedTuple

from liftd.cnc.snapshot import Event, LoopStats
from liftd.runtime.cycle import percentile_us
from liftd.runtime.loop_config import LoopConfig
from liftd.runtime.records import EventReader, pack_message
from liftd.runtime.shared import Shared

READY_CYCLES = 10  # "cycling": this many cycles published
START_TIMEOUT_S = 20.0
STOP_WAIT_S = 1.5  # a stop waits this long for a cycle boundary, then kills
LOAD_TIMEOUT_S = 60.0  # a cycle that decodes and plans a program (START, reload) may take this
POLL_S = 0.05
EVENT_POLL_S = 0.005  # the loop's events reach the log within this (the stream holds 64 KiB)
QUANTILES = (0.5, 0.99, 0.999)


class GeoStartError(Exception):
    """The GEO process did not start cycling (it exited, or took too long)."""


class GeoGone(Exception):
    """The GEO process is not there to take a reload (dead, or stopping)."""


class GeoFailure(NamedTuple):
    """Why the GEO process no longer serves: `event` is the log event name."""

    event: str  # geo.process_died, geo.stalled
    detail: dict[str, int | float]


class LoopSummary(NamedTuple):
    """The GEO loop's run, for the `daemon.stopped` log line."""

    cycles: int
    exceeded: int
    compute_over: int
    regridded: int
    events_dropped: int
    lateness_us: dict[float, float]
    compute_us: dict[float, float]
    compute_max_us: float
    rss_mb: float | None
    compute_cpu_over: int = 0
    compute_cpu_max_us: float = 0.0
    compute_mean_us: float = 0.0  # the loop's compute summed over the run, per cycle

    def as_log(self) -> dict[str, object]:
        return {
            "cycles": self.cycles,
            "exceeded": self.exceeded,
            "exceed_rate": round(self.exceeded / self.cycles, 6) if self.cycles else 0.0,
            "regridded": self.regridded,
            "lateness_us": self.lateness_us,
            "compute_us": self.compute_us,
            "compute_max_us": round(self.compute_max_us, 1),
            "compute_mean_us": round(self.compute_mean_us, 2),
            "compute_over_25pct": self.compute_over,
            "compute_cpu_max_us": round(self.compute_cpu_max_us, 1),
            "compute_cpu_over_25pct": self.compute_cpu_over,
            "events_dropped": self.events_dropped,
            "geo_rss_mb": self.rss_mb,
        }


def rss_mb(pid: int) -> float | None:
    """Resident set size of a process in MiB (Linux /proc), None where unavailable."""
    try:
        with open(f"/proc/{pid}/status", encoding="ascii") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return round(int(line.split()[1]) / 1024, 1)
    except OSError:
        return None
    return None


def _write_all(fd: int, data: bytes) -> None:
    view = memoryview(data)
    while view:
        view = view[os.write(fd, view) :]


class GeoProcess:
    def __init__(
        self, shared: Shared, on_event: Callable[[Event], None], stall_timeout_s: float
    ) -> None:
        self.shared = shared
        self.on_event = on_event
        self.stall_timeout_s = stall_timeout_s
        self.proc: subprocess.Popen[bytes] | None = None
        self.alive = False  # cycling and serving: between start() and a failure or stop()
        self.generation = 0  # of the newest configuration handed over
        self._control_fd = -1
        self._reader = EventReader()
        self._poller: asyncio.Task[None] | None = None
        self._watched = (-1, -1)
        self._rss_mb: float | None = None

    @property
    def pid(self) -> int | None:
        return self.proc.pid if self.proc is not None else None

    # -- start ------------------------------------------------------------------------------------
    async def start(self, cfg: LoopConfig) -> None:
        """Start the process, hand it `cfg`, return once it cycles. Raises GeoStartError (the
        caller still calls stop() to clean up)."""
        loop = asyncio.get_running_loop()
        control_r, self._control_fd = os.pipe()
        shm_fd = self.shared.block.fd
        fds = (control_r, shm_fd)
        try:
            self.proc = subprocess.Popen(
                [sys.executable, "-m", "liftd.runtime", *map(str, fds)],
                pass_fds=fds,
                stdin=subprocess.DEVNULL,
            )
        except OSError as exc:  # no fork (TasksMax, ENOMEM), the venv's python gone or barred
            raise GeoStartError(f"cannot start {sys.executable}: {exc.strerror}") from None
        finally:
            os.close(control_r)
        self.shared.block.unlink()  # the child holds the descriptor: no name left to leak
        self._poller = asyncio.create_task(self._poll_events())
        first = pack_message((self.shared.spec, cfg))
        try:  # above the pipe buffer (64 KiB) this waits until the child reads: off the loop
            await loop.run_in_executor(None, _write_all, self._control_fd, first)
        except OSError as exc:
            raise GeoStartError(f"the GEO process did not take its configuration: {exc}") from None
        end = time.monotonic() + START_TIMEOUT_S
        while self.shared.cycles < READY_CYCLES:
            if self.proc.poll() is not None:
                raise GeoStartError(f"the GEO process exited with {self.proc.returncode}")
            if time.monotonic() > end:
                raise GeoStartError("the GEO process did not start cycling")
            await asyncio.sleep(0.005)
        self.alive = True

    async def _poll_events(self) -> None:
        loop = asyncio.get_running_loop()
        while True:
            try:
                self._drain_events()
            except Exception as exc:  # a consumer's bug must not end the events' delivery
                loop.call_exception_handler(
                    {"message": "GEO event consumer failed", "exception": exc}
                )
            await asyncio.sleep(EVENT_POLL_S)

    def _drain_events(self) -> None:
        """Pass on the events the loop has put into the shared block since the last call."""
        data = self.shared.events.take()
        if data:
            for ev in self._reader.feed(data):
                self.on_event(ev)

    # -- what the daemon serves -------------------------------------------------------------------
    def advancing(self) -> bool:
        """Has the loop cycled since the last call (or is it preparing a program)? The
        condition for systemd's WATCHDOG=1 and the container heartbeat."""
        progress = self.shared.progress
        moved = progress != self._watched or self.shared.loading
        self._watched = progress
        return self.alive and moved

    # -- supervision -------------------------------------------------------------------------------
    async def supervise(self) -> GeoFailure:
        """Return when the process has died, or lives but stopped cycling for the stall timeout
        (then it is killed: a hung loop has no cycle boundary to stop at)."""
        assert self.proc is not None
        last, since = self.shared.progress, time.monotonic()
        while True:
            await asyncio.sleep(min(POLL_S, self.stall_timeout_s / 4))
            code = self.proc.poll()
            if code is not None:
                self.alive = False
                return GeoFailure("geo.process_died", {"exitcode": code})
            progress, now = self.shared.progress, time.monotonic()
            limit = LOAD_TIMEOUT_S if self.shared.loading else self.stall_timeout_s
            if progress != last:  # a cycle, or a program preparation begun or ended
                last, since = progress, now
            elif now - since > limit:
                self.alive = False
                self.proc.kill()
                return GeoFailure(
                    "geo.stalled", {"cycles": progress[0], "seconds": round(now - since, 3)}
                )

    # -- reload ------------------------------------------------------------------------------------
    async def reload(self, cfg: LoopConfig) -> None:
        """Hand a new configuration over; return once the loop has read it (it takes effect at
        the next program boundary). Raises GeoGone. One at a time (the caller serialises)."""
        if not self.alive or self.proc is None:
            raise GeoGone("the GEO process is not running")
        self.generation += 1
        generation = self.generation
        self.shared.announce_reload(generation)  # the loop reads the pipe from now on
        try:  # a program above the pipe buffer blocks until the loop reads: off the event loop
            await asyncio.get_running_loop().run_in_executor(
                None, _write_all, self._control_fd, pack_message((generation, cfg))
            )
        except OSError as exc:
            raise GeoGone(f"the GEO process: {exc}") from None
        end = time.monotonic() + LOAD_TIMEOUT_S
        while self.shared.reload_taken < generation:
            if self.proc.poll() is not None or not self.alive:
                raise GeoGone("the GEO process ended before taking the configuration")
            if time.monotonic() > end:
                raise GeoGone("the GEO process did not take the configuration in time")
            await asyncio.sleep(0.002)

    # -- stop --------------------------------------------------------------------------------------
    async def stop(self) -> bool:
        """Stop at a cycle boundary (kill after STOP_WAIT_S); False if it had to be killed."""
        self.alive = False
        proc = self.proc
        clean = True
        if proc is not None:
            self._rss_mb = rss_mb(proc.pid)
            self.shared.request_stop()
            loop = asyncio.get_running_loop()
            if proc.poll() is None:
                try:
                    await loop.run_in_executor(None, proc.wait, STOP_WAIT_S)
                except subprocess.TimeoutExpired:
                    clean = False
                    proc.kill()
                    await loop.run_in_executor(None, proc.wait)
        if self._poller is not None:
            self._poller.cancel()
            self._poller = None
            self._drain_events()  # what the loop put before it ended
        if self._control_fd >= 0:
            os.close(self._control_fd)
            self._control_fd = -1
        return clean

    def summary(self) -> LoopSummary:
        sh = self.shared
        totals = sh.totals()
        comp, late = list(sh.compute_hist), list(sh.lateness_hist)
        stats = sh.codec.unpack(sh.snapshot.read())[1] if sh.snapshot.sequence else LoopStats()
        return LoopSummary(
            cycles=totals.cycles,
            exceeded=totals.exceeded,
            compute_over=totals.compute_over,
            regridded=totals.regridded,
            events_dropped=totals.events_dropped,
            lateness_us={q: percentile_us(late, q) for q in QUANTILES},
            compute_us={q: percentile_us(comp, q) for q in QUANTILES},
            compute_max_us=stats.compute_max_us,
            rss_mb=self._rss_mb,
            compute_cpu_over=totals.compute_cpu_over,
            compute_cpu_max_us=stats.compute_cpu_max_us,
            compute_mean_us=totals.compute_sum_ns / 1e3 / totals.cycles if totals.cycles else 0.0,
        )
