"""The one shared-memory block between the daemon and the GEO loop process, and its layout:
words (u64: two control words daemon → loop, counters loop → daemon), the snapshot seqlock
(every channel's snapshot of one cycle in one record, `MachineCodec`),
the PLC input ring, the loop's event stream, the optional trace ring and the compute and
lateness histograms.

Words are read and written by index through `words` (the loop: one store per counter per
cycle, no lookup) and read by name through the properties (the daemon).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

from liftd.runtime.cycle import BUCKETS
from liftd.runtime.records import INPUT, MachineCodec
from liftd.runtime.shm import Block, ByteRing, Ring, Seqlock

# word indices; daemon → loop:
STOP = 0  # 1: stop at the next cycle boundary
RELOAD = 1  # generation of the newest configuration the daemon is sending on the control pipe
# loop → daemon:
RELOAD_TAKEN = 2  # generation of the newest configuration the loop has read
LOADING = 3  # +1 when the loop starts and +1 when it ends decoding and planning a program:
# odd while it works on one (the supervisor waits), and any change is progress
CYCLES = 4
EXCEEDED = 5  # cycles that finished after the start of the next one
COMPUTE_OVER = 6  # cycles whose compute took more than COMPUTE_SHARE of the period
REGRIDDED = 7
COMPUTE_SUM_NS = 8
LATENESS_SUM_NS = 9
COMPUTE_CPU_OVER = 10  # cycles whose compute took more than COMPUTE_SHARE on the thread's CPU clock
WORDS = 11  # (the events dropped are the event stream's own count)
COMPUTE_SHARE = 0.25  # a cycle computing longer than this share of its period is counted
INPUT_CAPACITY = 256
EVENTS_CAPACITY = 1 << 16  # bytes of events the daemon has not read yet (a pipe's buffer)
CACHE_LINE = 64


def _line(offset: int) -> int:
    """Each region starts on a cache line: a u64 index (seqlock sequence, ring head and tail)
    never straddles two lines, where an 8-byte store is not atomic for the other process."""
    return -(-offset // CACHE_LINE) * CACHE_LINE


class LoopTotals(NamedTuple):
    """The loop's counters at one moment (read by the daemon: summary, metrics)."""

    cycles: int
    exceeded: int
    compute_over: int
    regridded: int
    events_dropped: int
    compute_sum_ns: int
    lateness_sum_ns: int
    compute_cpu_over: int = 0  # the same count on the loop thread's CPU clock


@dataclass(frozen=True, slots=True)
class SharedSpec:
    """What the loop process needs to map the block (besides its descriptor)."""

    axes: tuple[int, ...]  # axes per channel, in channel order
    trace_capacity: int


class Shared:
    def __init__(
        self,
        axes: int | Sequence[int],
        trace_capacity: int = 0,
        name: str | None = None,
        fd: int | None = None,
    ) -> None:
        """`axes`: the axes of each channel in channel order (an int: one channel)."""
        self.axes = (axes,) if isinstance(axes, int) else tuple(axes)
        self.codec = MachineCodec(self.axes)
        self.trace_capacity = trace_capacity
        snap_at = _line(8 * WORDS)
        in_at = _line(snap_at + Seqlock.space(self.codec.size))
        events_at = _line(in_at + Ring.space(INPUT.size, INPUT_CAPACITY))
        trace_at = _line(events_at + ByteRing.space(EVENTS_CAPACITY))
        hist_at = _line(
            trace_at + (Ring.space(self.codec.size, trace_capacity) if trace_capacity else 0)
        )
        at = hist_at + 2 * 8 * BUCKETS
        self.block = Block(at, name, fd=fd)
        buf = self.block.buf
        self.words = buf[: 8 * WORDS].cast("Q")
        self.snapshot = Seqlock(self.block, snap_at, self.codec.size)
        self.inputs = Ring(self.block, in_at, INPUT.size, INPUT_CAPACITY)
        self.events = ByteRing(self.block, events_at, EVENTS_CAPACITY)
        self.trace = (
            Ring(self.block, trace_at, self.codec.size, trace_capacity) if trace_capacity else None
        )
        self._hist = buf[hist_at : hist_at + 2 * 8 * BUCKETS].cast("q")
        self.compute_hist = self._hist[:BUCKETS]
        self.lateness_hist = self._hist[BUCKETS:]

    @property
    def spec(self) -> SharedSpec:
        return SharedSpec(self.axes, self.trace_capacity)

    @classmethod
    def attach(cls, spec: SharedSpec, fd: int) -> Shared:
        """The loop process's view of the block whose descriptor it inherited."""
        return cls(spec.axes, spec.trace_capacity, fd=fd)

    # -- the daemon's side ------------------------------------------------------------------------
    def request_stop(self) -> None:
        self.words[STOP] = 1

    def announce_reload(self, generation: int) -> None:
        self.words[RELOAD] = generation

    @property
    def reload_taken(self) -> int:
        return int(self.words[RELOAD_TAKEN])

    @property
    def cycles(self) -> int:
        return int(self.words[CYCLES])

    @property
    def loading(self) -> bool:
        return bool(self.words[LOADING] & 1)

    @property
    def progress(self) -> tuple[int, int]:
        """Changes whenever the loop cycles or starts or ends preparing a program."""
        return int(self.words[CYCLES]), int(self.words[LOADING])

    def totals(self) -> LoopTotals:
        w = self.words
        return LoopTotals(
            w[CYCLES],
            w[EXCEEDED],
            w[COMPUTE_OVER],
            w[REGRIDDED],
            self.events.dropped,
            w[COMPUTE_SUM_NS],
            w[LATENESS_SUM_NS],
            w[COMPUTE_CPU_OVER],
        )

    def close(self) -> None:
        """Release the views, unmap the block (and unlink it if this side created it)."""
        for view in (self.compute_hist, self.lateness_hist, self._hist, self.words):
            view.release()
        self.snapshot.buf = self.inputs.buf = self.events.buf = memoryview(b"")
        if self.trace is not None:
            self.trace.buf = memoryview(b"")
        self.block.close()
