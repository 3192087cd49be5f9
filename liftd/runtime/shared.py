"""The one shared-memory block between the daemon and the GEO loop process, and its layout:
control words (daemon → loop), counters and timing histograms (loop → daemon), the snapshot
seqlock, the PLC input ring and the optional trace ring."""

from __future__ import annotations

import struct
from dataclasses import dataclass

from liftd.runtime.cycle import BUCKETS
from liftd.runtime.records import INPUT, SnapshotCodec
from liftd.runtime.shm import Block, Ring, Seqlock

CONTROL_WORDS = ("stop", "reload", "ready")
COUNTER_WORDS = ("exceeded", "regridded", "events_dropped", "cycles", "reloads", "loading")
INPUT_CAPACITY = 256
U64 = struct.Struct("<Q")


@dataclass(frozen=True, slots=True)
class SharedSpec:
    """What the loop process needs to attach (picklable for the spawn start method)."""

    name: str
    n_axes: int
    trace_capacity: int


class Shared:
    def __init__(self, n_axes: int, trace_capacity: int = 0, name: str | None = None) -> None:
        self.codec = SnapshotCodec(n_axes)
        self.n_axes = n_axes
        self.trace_capacity = trace_capacity
        words = len(CONTROL_WORDS) + len(COUNTER_WORDS)
        at = 8 * words
        self._snap_at = at
        at += Seqlock.space(self.codec.size)
        self._in_at = at
        at += Ring.space(INPUT.size, INPUT_CAPACITY)
        self._trace_at = at
        at += Ring.space(self.codec.size, trace_capacity) if trace_capacity else 0
        self._hist_at = at
        at += 2 * 8 * BUCKETS
        self.block = Block(at, name)
        buf = self.block.buf
        self.snapshot = Seqlock(self.block, self._snap_at, self.codec.size)
        self.inputs = Ring(self.block, self._in_at, INPUT.size, INPUT_CAPACITY)
        self.trace = (
            Ring(self.block, self._trace_at, self.codec.size, trace_capacity)
            if trace_capacity
            else None
        )
        self._hist = buf[self._hist_at : self._hist_at + 2 * 8 * BUCKETS].cast("q")
        self.compute_hist = self._hist[:BUCKETS]
        self.lateness_hist = self._hist[BUCKETS:]

    @property
    def spec(self) -> SharedSpec:
        return SharedSpec(self.block.name, self.n_axes, self.trace_capacity)

    @classmethod
    def attach(cls, spec: SharedSpec) -> Shared:
        return cls(spec.n_axes, spec.trace_capacity, spec.name)

    def _word(self, names: tuple[str, ...], base: int, name: str) -> int:
        return base + 8 * names.index(name)

    def get(self, name: str) -> int:
        if name in CONTROL_WORDS:
            at = self._word(CONTROL_WORDS, 0, name)
        else:
            at = self._word(COUNTER_WORDS, 8 * len(CONTROL_WORDS), name)
        return int(U64.unpack_from(self.block.buf, at)[0])

    def set(self, name: str, value: int) -> None:
        if name in CONTROL_WORDS:
            at = self._word(CONTROL_WORDS, 0, name)
        else:
            at = self._word(COUNTER_WORDS, 8 * len(CONTROL_WORDS), name)
        U64.pack_into(self.block.buf, at, value)

    def close(self) -> None:
        """Release the views, close the block (and unlink it if this side created it)."""
        for view in (self.compute_hist, self.lateness_hist, self._hist):
            view.release()
        self.snapshot.buf = self.inputs.buf = memoryview(b"")
        if self.trace is not None:
            self.trace.buf = memoryview(b"")
        self.block.close()
