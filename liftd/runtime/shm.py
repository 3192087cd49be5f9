"""Lock-free hand-over between the GEO loop process and the daemon, in shared memory.

* `Seqlock`: one writer (the loop) publishes a fixed-size record every cycle; readers copy it
  and retry while the sequence is odd or changed, at most `MAX_RETRIES` times, then keep the
  last good copy — the writer never waits (docs/reference/rt-python.md §2.6: 0 torn reads in
  millions, a plain copy tears 0.08–5 %).
* `Ring`: single-producer single-consumer queue of fixed-size records (PLC inputs daemon →
  loop, trace records loop → daemon). The producer writes the record, then advances `head`;
  the consumer reads, then advances `tail`; a full ring rejects the record (counted).
* `ByteRing`: the same over a stream of bytes: records of any length, whole or not at all
  (the GEO loop's events → the daemon, which reassembles them as it did from a pipe).

Both rely on stores becoming visible in program order, which x86-64 (TSO) guarantees for the
interpreter's byte copies; an ARM target needs a helper with barriers (docs/reference/rt-python.md
§5).

The u64 indices (sequence, head, tail) are read and written through the block's one `cast("Q")`
view: a single aligned 8-byte load or store each (memoryview's pack/unpack is a `memcpy` of the
item). Never through `struct.pack_into`: CPython zeroes the target bytes before it packs
(Modules/_struct.c, `s_pack_internal`: `memset(buf, '\0', soself->s_size)`), so the other
process could read a head or tail of 0 — a ring that looked full (a trace record dropped
in the ring's second lap) or empty (a PLC input a cycle late).
"""

from __future__ import annotations

import contextlib
import mmap
import os

MAX_RETRIES = 100
SHM_DIR = "/dev/shm"  # where POSIX shm_open(3) keeps its names on Linux


class Block:
    """A POSIX shared-memory block mapped into this process, without multiprocessing's resource
    tracker (a third process of 12 MiB that also warns about "leaked" blocks).

    `Block(size)` creates one under a fresh name and owns it: `unlink()` removes the name (the
    daemon does so as soon as the GEO process holds the descriptor, so nothing is left in
    /dev/shm whatever happens to either process after that) and `close()` unlinks too.
    `Block(0, name)` attaches by name, `Block(0, fd=fd)` to an inherited descriptor.
    """

    def __init__(self, size: int, name: str | None = None, *, fd: int | None = None) -> None:
        self.owner = name is None and fd is None
        self.name = name or ""
        flags = os.O_RDWR | os.O_CLOEXEC | os.O_NOFOLLOW
        if fd is None and name is None:
            self.name = f"liftd-{os.getpid()}-{os.urandom(6).hex()}"
            fd = os.open(self.path, flags | os.O_CREAT | os.O_EXCL, 0o600)
            try:
                os.ftruncate(fd, -(-max(size, 8) // 8) * 8)  # whole u64 words: `words` below
            except OSError:
                os.close(fd)
                os.unlink(self.path)
                raise
        elif fd is None:
            fd = os.open(self.path, flags)
        self.fd = fd
        self._linked = self.owner
        self._map = mmap.mmap(fd, os.fstat(fd).st_size)
        self.buf: memoryview = memoryview(self._map)
        self.words: memoryview = self.buf.cast("Q")  # the u64 at byte offset 8 i is words[i]

    @property
    def path(self) -> str:
        return f"{SHM_DIR}/{self.name}"

    def unlink(self) -> None:
        """Remove the name (owner only, once); the memory lives on while it is mapped."""
        if self._linked:
            self._linked = False
            with contextlib.suppress(FileNotFoundError):
                os.unlink(self.path)

    def close(self) -> None:
        """Unmap, close the descriptor and (owner) remove the name. The caller has released
        every view it took of `buf`."""
        self.unlink()
        self.words.release()
        self.buf.release()
        self.buf = memoryview(b"")
        with contextlib.suppress(BufferError):  # a view still held elsewhere: unmapped at exit
            self._map.close()
        if self.fd >= 0:
            os.close(self.fd)
            self.fd = -1


class Seqlock:
    """Layout: seq u64, then the record."""

    def __init__(self, block: Block, offset: int, size: int) -> None:
        self.buf = block.buf
        self.words = block.words
        self.seq_at = offset
        self.seq_i = _word(offset)
        self.data_at = offset + 8
        self.size = size
        self._seq = 0
        self.last = bytes(size)
        self.retries = 0
        self.given_up = 0

    @staticmethod
    def space(size: int) -> int:
        return 8 + size

    def write(self, record: bytes) -> None:
        """Writer side (one process only)."""
        words, i = self.words, self.seq_i
        self._seq += 1
        words[i] = self._seq  # odd: writing
        self.buf[self.data_at : self.data_at + self.size] = record
        self._seq += 1
        words[i] = self._seq  # even: consistent

    def read(self) -> bytes:
        """Reader side: a consistent copy, or the last one if the writer kept it busy."""
        buf, words, i = self.buf, self.words, self.seq_i
        for _ in range(MAX_RETRIES):
            s1 = words[i]
            if s1 & 1:
                self.retries += 1
                continue
            data = bytes(buf[self.data_at : self.data_at + self.size])
            if words[i] == s1:
                if s1:
                    self.last = data
                return self.last
            self.retries += 1
        self.given_up += 1
        return self.last

    @property
    def sequence(self) -> int:
        return int(self.words[self.seq_i])


class Ring:
    """Layout: head u64, tail u64, dropped u64, then `capacity` records of `size` bytes."""

    def __init__(self, block: Block, offset: int, size: int, capacity: int) -> None:
        self.buf = block.buf
        self.words = block.words
        self.at = offset
        self.head_i = _word(offset)
        self.tail_i = self.head_i + 1
        self.dropped_i = self.head_i + 2
        self.size = size
        self.capacity = capacity
        self.data_at = offset + 24

    @staticmethod
    def space(size: int, capacity: int) -> int:
        return 24 + size * capacity

    def put(self, record: bytes) -> bool:
        """Producer side; False (and counted) when the ring is full."""
        words = self.words
        head = words[self.head_i]
        if head - words[self.tail_i] >= self.capacity:
            words[self.dropped_i] += 1
            return False
        pos = self.data_at + (head % self.capacity) * self.size
        self.buf[pos : pos + self.size] = record
        words[self.head_i] = head + 1  # publish after the record
        return True

    def get(self) -> bytes | None:
        """Consumer side; None when empty."""
        words = self.words
        tail = words[self.tail_i]
        if tail >= words[self.head_i]:
            return None
        pos = self.data_at + (tail % self.capacity) * self.size
        record = bytes(self.buf[pos : pos + self.size])
        words[self.tail_i] = tail + 1  # free the slot after reading it
        return record

    def __len__(self) -> int:
        tail = self.words[self.tail_i]  # first: the head read after it is never behind it
        return int(self.words[self.head_i] - tail)

    @property
    def head(self) -> int:
        """Records ever put."""
        return int(self.words[self.head_i])

    @property
    def tail(self) -> int:
        """Records ever taken."""
        return int(self.words[self.tail_i])

    @property
    def dropped(self) -> int:
        return int(self.words[self.dropped_i])


class ByteRing:
    """Layout: head u64 (bytes ever put), tail u64 (bytes ever taken), dropped u64, then
    `capacity` bytes; a record may wrap around the end. No system call on either side: the
    loop's events no longer wake the daemon from inside a cycle (a pipe write did: 24–76 µs of
    an event cycle's compute in `bench_rt`, 2026-12-02); the daemon polls."""

    def __init__(self, block: Block, offset: int, capacity: int) -> None:
        self.buf = block.buf
        self.words = block.words
        self.head_i = _word(offset)
        self.tail_i = self.head_i + 1
        self.dropped_i = self.head_i + 2
        self.capacity = capacity
        self.data_at = offset + 24

    @staticmethod
    def space(capacity: int) -> int:
        return 24 + capacity

    def put(self, record: bytes) -> bool:
        """Producer side: the whole record, or False (and counted) when it does not fit."""
        words, cap, n = self.words, self.capacity, len(record)
        head = words[self.head_i]
        if n > cap - (head - words[self.tail_i]):
            words[self.dropped_i] += 1
            return False
        pos = head % cap
        first = min(n, cap - pos)
        at = self.data_at
        if first == n:
            self.buf[at + pos : at + pos + n] = record
        else:  # across the end
            view = memoryview(record)
            self.buf[at + pos : at + pos + first] = view[:first]
            self.buf[at : at + n - first] = view[first:]
        words[self.head_i] = head + n  # publish after the bytes
        return True

    def take(self) -> bytes:
        """Consumer side: every byte put and not yet taken (b"" when none)."""
        words, cap, at = self.words, self.capacity, self.data_at
        tail, head = words[self.tail_i], words[self.head_i]
        n = head - tail
        if not n:
            return b""
        pos = tail % cap
        first = min(n, cap - pos)
        data = bytes(self.buf[at + pos : at + pos + first])
        if first < n:
            data += bytes(self.buf[at : at + n - first])
        words[self.tail_i] = head  # free the bytes after reading them
        return data

    @property
    def dropped(self) -> int:
        return int(self.words[self.dropped_i])


def _word(offset: int) -> int:
    if offset % 8:
        raise ValueError(f"a u64 index at byte {offset} is not 8-byte aligned")
    return offset // 8
