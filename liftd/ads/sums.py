"""Sum commands (ReadWrite to 0xF080…0xF086, IO = number of sub-commands n): split the
container, run each sub-command through the callables the service passes, join the answers.
Pure. A malformed container raises AdsError(0x705); a failing sub-command only sets its own
result (reference/ads.md §3).

Layouts (write data → read data), sources in brackets:

* 0xF080 read: n × {IG, IO, len} → n × result, then n blocks of exactly the requested length,
  even on error (pyads and ads-client step by the requested size; AdsLib AdsDef.h).
* 0xF081 write: n × {IG, IO, len}, data → n × result.
* 0xF082 read/write: n × {IG, IO, rlen, wlen}, data → n × {result, len}, data as returned.
* 0xF083 read-ex: n × {IG, IO, len} → n × {result, len}, then blocks padded to the requested
  lengths (birkenfeld/ads-rs `src/client.rs` read_multi: it reads the blocks into buffers of the
  requested sizes and says so); 0xF084 read-ex2: the same, blocks at the returned lengths.
* 0xF085 add notifications: n × {IG, IO, AdsNotificationAttrib} → n × {result, handle}; the
  attribute is cbLength, mode, max delay, cycle time and, as ads-rs sends it
  (`client.rs` AddNotif, 40 B per entry), 16 reserved bytes; the 24-byte form without them
  (TcAdsDef.h AdsNotificationAttrib, tcads-rs) is accepted too.
* 0xF086 delete notifications: n × handle → n × result.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from typing import ParamSpec, TypeVar

from liftd.ads import wire
from liftd.ads.constants import SUM_GROUPS, AdsErr
from liftd.ads.errors import AdsError
from liftd.ads.wire import AddNotificationRequest, ReadWriteRequest

HEAD = struct.Struct("<III")  # IG, IO, length
RW_HEAD = struct.Struct("<IIII")  # IG, IO, read length, write length
NOTE_SHORT = struct.Struct("<IIIIII")  # IG, IO, cbLength, mode, max delay, cycle time

P = ParamSpec("P")
T = TypeVar("T")
Read = Callable[[int, int, int], bytes]
Write = Callable[[int, int, bytes], None]
ReadWrite = Callable[[ReadWriteRequest], bytes]
AddNote = Callable[[AddNotificationRequest], int]
DelNote = Callable[[int], None]


def count(req: ReadWriteRequest, entry_bytes: int, limit: int) -> int:
    """n from the index offset, checked against the cap and the headers present."""
    n = req.index_offset
    if n == 0 or n > limit:
        raise AdsError(AdsErr.INVALIDSIZE, f"{n} sub-commands (1..{limit} accepted)")
    if len(req.data) < entry_bytes * n:
        raise AdsError(AdsErr.INVALIDSIZE, "sum command headers truncated")
    return n


def _run(ig: int, fn: Callable[P, T], *args: P.args, **kw: P.kwargs) -> tuple[int, T | None]:
    """One sub-command: (0, its answer) or (its error code, None)."""
    try:
        if ig in SUM_GROUPS:
            raise AdsError(AdsErr.SRVNOTSUPP, "nested sum command")
        return 0, fn(*args, **kw)
    except AdsError as exc:
        return exc.code, None


def _reads(req: ReadWriteRequest, limit: int, read: Read) -> list[tuple[int, int, bytes]]:
    """Run n reads: (result, requested length, data)."""
    n = count(req, HEAD.size, limit)
    if len(req.data) != HEAD.size * n:
        raise AdsError(AdsErr.INVALIDSIZE, "sum read: 12 bytes per sub-command")
    out = []
    for ig, io, length in HEAD.iter_unpack(req.data):
        code, data = _run(ig, read, ig, io, length)
        out.append((code, length, (data or b"")[:length]))
    return out


def _check_room(req: ReadWriteRequest, need: int) -> None:
    if req.read_length < need:
        raise AdsError(AdsErr.INVALIDSIZE, f"sum command: read length below {need}")


def sum_read(req: ReadWriteRequest, limit: int, read: Read) -> bytes:
    """0xF080"""
    n = count(req, HEAD.size, limit)
    _check_room(req, 4 * n + sum(h[2] for h in HEAD.iter_unpack(req.data[: HEAD.size * n])))
    subs = _reads(req, limit, read)
    results = struct.pack(f"<{n}I", *(code for code, _, _ in subs))
    return results + b"".join(data.ljust(length, b"\0") for _, length, data in subs)


def sum_read_ex(req: ReadWriteRequest, limit: int, read: Read, padded: bool) -> bytes:
    """0xF083 (padded) and 0xF084 (compact)."""
    n = count(req, HEAD.size, limit)
    _check_room(req, 8 * n + sum(h[2] for h in HEAD.iter_unpack(req.data[: HEAD.size * n])))
    subs = _reads(req, limit, read)
    heads = b"".join(wire.U32X2.pack(code, len(data)) for code, _, data in subs)
    if padded:
        return heads + b"".join(data.ljust(length, b"\0") for _, length, data in subs)
    return heads + b"".join(data for _, _, data in subs)


def sum_write(req: ReadWriteRequest, limit: int, write: Write) -> bytes:
    """0xF081"""
    n = count(req, HEAD.size, limit)
    subs = list(HEAD.iter_unpack(req.data[: HEAD.size * n]))
    if len(req.data) != HEAD.size * n + sum(sub[2] for sub in subs):
        raise AdsError(AdsErr.INVALIDSIZE, "sum write: headers + data")
    results, pos = [], HEAD.size * n
    for ig, io, length in subs:
        data = req.data[pos : pos + length]
        pos += length
        results.append(_run(ig, write, ig, io, data)[0])
    return struct.pack(f"<{n}I", *results)


def sum_read_write(req: ReadWriteRequest, limit: int, read_write: ReadWrite) -> bytes:
    """0xF082"""
    n = count(req, RW_HEAD.size, limit)
    subs = list(RW_HEAD.iter_unpack(req.data[: RW_HEAD.size * n]))
    if len(req.data) != RW_HEAD.size * n + sum(sub[3] for sub in subs):
        raise AdsError(AdsErr.INVALIDSIZE, "sum read/write: headers + write data")
    heads, blocks, pos = [], [], RW_HEAD.size * n
    for ig, io, rlen, wlen in subs:
        sub = ReadWriteRequest(ig, io, rlen, req.data[pos : pos + wlen])
        pos += wlen
        code, got = _run(ig, read_write, sub)
        out = (got or b"")[:rlen]
        heads.append(wire.U32X2.pack(code, len(out)))
        blocks.append(out)
    return b"".join(heads) + b"".join(blocks)


def sum_add_notifications(req: ReadWriteRequest, limit: int, add: AddNote) -> bytes:
    """0xF085: 40-byte entries (ads-rs) or 24-byte ones (AdsNotificationAttrib without the
    reserved bytes); the write length decides."""
    n = count(req, NOTE_SHORT.size, limit)
    if len(req.data) == wire.ADD_NOTE.size * n:
        entries = [AddNotificationRequest._make(e) for e in wire.ADD_NOTE.iter_unpack(req.data)]
    elif len(req.data) == NOTE_SHORT.size * n:
        entries = [AddNotificationRequest(*e) for e in NOTE_SHORT.iter_unpack(req.data)]
    else:
        raise AdsError(AdsErr.INVALIDSIZE, "sum add notification: 40 or 24 bytes per entry")
    _check_room(req, 8 * n)
    out = []
    for entry in entries:
        code, handle = _run(entry.index_group, add, entry)
        out.append(wire.U32X2.pack(code, handle or 0))
    return b"".join(out)


def sum_delete_notifications(req: ReadWriteRequest, limit: int, delete: DelNote) -> bytes:
    """0xF086"""
    n = count(req, 4, limit)
    if len(req.data) != 4 * n:
        raise AdsError(AdsErr.INVALIDSIZE, "sum delete notification: 4 bytes per handle")
    _check_room(req, 4 * n)
    handles = struct.unpack(f"<{n}I", req.data)
    return struct.pack(f"<{n}I", *(_run(0, delete, h)[0] for h in handles))
