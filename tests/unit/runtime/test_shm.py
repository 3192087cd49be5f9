"""Shared-memory hand-over: the seqlock never returns a torn record and never makes the writer
wait; the SPSC ring is FIFO, bounded and counts what it rejects. One test crosses a real process
boundary (bounded in count)."""

from __future__ import annotations

import multiprocessing as mp
import struct
import time
from collections.abc import Iterator
from typing import Any

import pytest

from liftd.runtime.shm import MAX_RETRIES, Block, ByteRing, Ring, Seqlock

SIZE = 64


@pytest.fixture
def block() -> Iterator[Block]:
    b = Block(4096)
    yield b
    b.close()


def record(n: int) -> bytes:
    return bytes([n % 251]) * SIZE  # a torn copy mixes two different byte values


def test_seqlock_reader_gets_what_was_published(block: Block) -> None:
    lock = Seqlock(block, 0, SIZE)
    assert lock.read() == bytes(SIZE) and lock.sequence == 0  # nothing published yet
    for n in (1, 2, 3):
        lock.write(record(n))
        assert lock.read() == record(n)
    assert lock.sequence == 6 and lock.retries == 0


def test_seqlock_reader_gives_up_with_the_last_good_copy_while_a_write_is_in_flight(
    block: Block,
) -> None:
    writer, reader = Seqlock(block, 0, SIZE), Seqlock(block, 0, SIZE)
    writer.write(record(7))
    assert reader.read() == record(7)
    block.words[0] = writer.sequence + 1  # odd: the writer is mid-copy …
    block.buf[8 : 8 + SIZE // 2] = record(8)[: SIZE // 2]  # … half of the new record is in
    assert reader.read() == record(7)  # bounded retries, then the last consistent copy
    assert reader.retries == MAX_RETRIES and reader.given_up == 1


def _writer(name: str, n: int) -> None:
    b = Block(0, name)
    lock = Seqlock(b, 0, SIZE)
    for i in range(1, n + 1):
        lock.write(record(i))
    b.close()


def test_seqlock_across_processes_never_tears(block: Block) -> None:
    reader = Seqlock(block, 0, SIZE)
    proc = mp.get_context("spawn").Process(target=_writer, args=(block.name, 300_000))
    proc.start()
    reads = 0
    while proc.is_alive() or reads == 0:
        data = reader.read()
        assert data == bytes([data[0]]) * SIZE  # every byte from the same write
        reads += 1
    proc.join(30)
    assert proc.exitcode == 0
    assert reader.read() == record(300_000)


def test_ring_is_fifo_bounded_and_wraps(block: Block) -> None:
    ring = Ring(block, 0, 12, capacity=4)
    assert ring.get() is None and len(ring) == 0
    for i in range(4):
        assert ring.put(struct.pack("<3I", i, i, i))
    assert not ring.put(struct.pack("<3I", 9, 9, 9))  # full: rejected, not overwritten
    assert ring.dropped == 1 and len(ring) == 4
    assert ring.get() == struct.pack("<3I", 0, 0, 0)
    for i in range(4, 50):  # many times round the ring
        assert ring.put(struct.pack("<3I", i, i, i))
        assert len(ring) == 4
        assert ring.get() == struct.pack("<3I", i - 3, i - 3, i - 3)
    assert [ring.get() for _ in range(3)][-1] == struct.pack("<3I", 49, 49, 49)
    assert ring.get() is None and ring.dropped == 1


def test_byte_ring_keeps_records_whole_across_the_end_and_rejects_what_does_not_fit(
    block: Block,
) -> None:
    """The loop's event stream: records of any length, each whole or not at all, in order,
    however they straddle the end of the buffer; the daemon reassembles them (EventReader)."""
    ring = ByteRing(block, 0, capacity=100)
    assert ring.take() == b""
    sent = bytearray()
    for i in range(60):  # ~14 times round the buffer, at a different offset each time
        rec = bytes([i]) * (7 + i % 13)
        assert ring.put(rec)
        sent += rec
        if i % 3 == 2:
            got = ring.take()
            assert sent.startswith(got) and got
            del sent[: len(got)]
    assert ring.take() == bytes(sent)
    assert ring.put(bytes(60)) and not ring.put(bytes(41))  # 40 free: rejected, counted
    assert ring.dropped == 1 and ring.put(bytes(40)) and not ring.put(b"x")
    assert ring.take() == bytes(100) and ring.dropped == 2


def _index_watcher(name: str, seconds: float, out: Any) -> None:
    """Reads the ring's head and tail as fast as it can; both only ever grow."""
    b = Block(0, name)
    ring = Ring(b, 0, SIZE, 8)
    backwards = reads = head = tail = 0
    t_end = time.monotonic() + seconds
    while time.monotonic() < t_end:
        for _ in range(1000):
            h, t = ring.head, ring.tail
            backwards += (h < head) + (t < tail)
            head, tail, reads = h, t, reads + 2
    out.put((backwards, reads))
    ring.words = ring.buf = memoryview(b"")
    b.close()


def test_ring_indices_read_by_the_other_process_never_go_backwards(block: Block) -> None:
    """The other process reads each index either before or after a store, never in between:
    struct.pack_into zeroes the bytes before it packs, which another process read as a head or
    tail of 0 (about a thousand times a second here) — past the ring's first lap a tail of 0
    is a full ring, and the GEO loop dropped a trace record."""
    ctx = mp.get_context("spawn")
    ring = Ring(block, 0, SIZE, 8)
    out = ctx.Queue()
    proc = ctx.Process(target=_index_watcher, args=(block.name, 0.5, out))
    proc.start()
    rec, stores = record(1), 0
    while out.empty() and proc.is_alive():  # producer and consumer in one process: a put and
        # a get are two stores
        for _ in range(1000):
            assert ring.put(rec) and ring.get() == rec
        stores += 2000
    backwards, reads = out.get(timeout=30)
    proc.join(30)
    assert proc.exitcode == 0 and reads > 100_000 and stores > 100_000  # they did overlap
    assert backwards == 0
