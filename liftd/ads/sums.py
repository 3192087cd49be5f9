"""Sum commands (ReadWrite to 0xF080…0xF086, IO = number of sub-commands n): split the
container, run each sub-command through the callables the service passes, join the answers.
Pure. A malformed container raises AdsError(0x705); a failing sub-command only sets its own
result (reference/ads.md §3).

Layouts (write data → read data), sources in brackets:

* 0xF080 read: n × {IG, IO, len} → n × result, then n blocks of exactly the requested length,
  even on error (pyads and ads-client step by the requested size; AdsLib AdsDef.h; ads-client
  2.2.0 `src/ads-client.ts` readRawMulti: `pos += commands[i].size`). A length beyond the
  object's size gets the object's bytes and zeros up to it, as a client stepping by the length
  expects.
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

The size of every reply is known from the request before anything is read or built (the
lengths asked for, or the objects' sizes, which are small); a reply that would exceed
`reply_cap` (the frame cap less the headers) is refused with 0x70A, "insufficient memory",
without allocating it. Beckhoff's ISumCommand notes say a sum response must pass the AMS router,
whose memory is bounded (2048 kB by default in TwinCAT 2), so the caller has to limit it
(infosys.beckhoff.com/content/1033/tc3_adsnetref/7313686667.html); which code a TwinCAT
router answers then was not found in any source: 0x70A is liftd's choice (README).
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


def _reads(
    req: ReadWriteRequest, limit: int, read: Read, reply_cap: int
) -> list[tuple[int, int, bytes]]:
    """Run n reads: (result, requested length, data); 0x70A as soon as the data read and 8
    bytes per sub-command exceed `reply_cap`."""
    n = count(req, HEAD.size, limit)
    if len(req.data) != HEAD.size * n:
        raise AdsError(AdsErr.INVALIDSIZE, "sum read: 12 bytes per sub-command")
    out, size = [], 8 * n
    for ig, io, length in HEAD.iter_unpack(req.data):
        code, data = _run(ig, read, ig, io, length)
        got = (data or b"")[:length]
        size += len(got)
        _check_cap(size, reply_cap)
        out.append((code, length, got))
    return out


def _check_cap(need: int, reply_cap: int) -> None:
    if need > reply_cap:
        raise AdsError(AdsErr.NOMEMORY, f"sum reply of {need} bytes above the cap {reply_cap}")


def _check_room(req: ReadWriteRequest, need: int, reply_cap: int | None = None) -> None:
    """The reply of `need` bytes fits what the client reads and what the server may send."""
    if reply_cap is not None:
        _check_cap(need, reply_cap)
    if req.read_length < need:
        raise AdsError(AdsErr.INVALIDSIZE, f"sum command: read length below {need}")


def sum_read(req: ReadWriteRequest, limit: int, read: Read, reply_cap: int) -> bytes:
    """0xF080"""
    n = count(req, HEAD.size, limit)
    asked = sum(h[2] for h in HEAD.iter_unpack(req.data[: HEAD.size * n]))
    _check_room(req, 4 * n + asked, reply_cap)
    subs = _reads(req, limit, read, reply_cap)
    results = struct.pack(f"<{n}I", *(code for code, _, _ in subs))
    return results + b"".join(data.ljust(length, b"\0") for _, length, data in subs)


def sum_read_ex(
    req: ReadWriteRequest, limit: int, read: Read, padded: bool, reply_cap: int
) -> bytes:
    """0xF083 (padded) and 0xF084 (compact: its reply is the data read, checked once read)."""
    n = count(req, HEAD.size, limit)
    asked = sum(h[2] for h in HEAD.iter_unpack(req.data[: HEAD.size * n]))
    _check_room(req, 8 * n + asked, reply_cap if padded else None)
    subs = _reads(req, limit, read, reply_cap)
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


def sum_read_write(
    req: ReadWriteRequest, limit: int, read_write: ReadWrite, reply_cap: int
) -> bytes:
    """0xF082 (the reply: the data each sub-command returned, checked as it grows)."""
    n = count(req, RW_HEAD.size, limit)
    subs = list(RW_HEAD.iter_unpack(req.data[: RW_HEAD.size * n]))
    if len(req.data) != RW_HEAD.size * n + sum(sub[3] for sub in subs):
        raise AdsError(AdsErr.INVALIDSIZE, "sum read/write: headers + write data")
    heads, blocks, pos, size = [], [], RW_HEAD.size * n, 8 * n
    for ig, io, rlen, wlen in subs:
        sub = ReadWriteRequest(ig, io, rlen, req.data[pos : pos + wlen])
        pos += wlen
        code, got = _run(ig, read_write, sub)
        out = (got or b"")[:rlen]
        size += len(out)
        _check_cap(size, reply_cap)
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
