"""Fixed binary layouts crossing the process boundary: a cycle's snapshot (+ loop timing), a
PLC input, an event; and the framing of the control pipe's messages (a length, then a pickle).
Pure; struct and pickle only (packing a snapshot costs ~1 µs)."""

from __future__ import annotations

import enum
import functools
import os
import pickle
import struct
from collections.abc import Callable, Sequence
from typing import Any, Final, cast

from liftd.cnc import events
from liftd.cnc.snapshot import (
    Event,
    GeoSnapshot,
    LoopStats,
    PlcSignal,
    PlcWrite,
    record_layout,
)

INPUT = struct.Struct("<IdI")  # signal, value, machine index of the channel
EVENT_HEAD = struct.Struct("<HHIdd")  # name id (+ channel id << 8), text bytes, line, t, value
EVENT_NAME_MASK = 0xFF
MAX_EVENT_TEXT = 1000  # a record's text (the event stream holds 64 KiB)

EVENT_NAMES = events.RECORDED  # an event record names its event by index here
EVENT_IDS = {name: i for i, name in enumerate(EVENT_NAMES)}


STATS = "qqddddqdq"  # LoopStats


def _runs(codes: list[tuple[str, bool]]) -> list[tuple[int, int, bool]]:
    """(first, end, per axis) of each run of packed fields, from each field's (format, per
    axis): consecutive scalars form one run, a per-axis field is a run of its own."""
    runs: list[tuple[int, int, bool]] = []
    for i, (code, per_axis) in enumerate(codes):
        if not code:
            continue
        if not per_axis and runs and not runs[-1][2] and runs[-1][1] == i:
            runs[-1] = (runs[-1][0], i + 1, False)
        else:
            runs.append((i, i + 1, per_axis))
    return runs


# GeoSnapshot's record layout (`snapshot.record_layout`) as runs of consecutive fields: (first,
# end, per axis): a run of scalars packs as a slice of the tuple, a per-axis field as its tuple
# (an empty one as zeros); a field without a format is left out, and a record reads it as ().
_LAYOUT = record_layout()
_RUNS: Final = tuple(_runs([(rec.code, rec.per_axis) for _, rec, _ in _LAYOUT]))
# the fields made of an enum again when a record is read: their index and the enum's members
_ENUMS: Final[dict[int, dict[int, Any]]] = {
    i: {int(m): m for m in tp}
    for i, (_, _, tp) in enumerate(_LAYOUT)
    if isinstance(tp, type) and issubclass(tp, enum.IntEnum)
}


def _fields(s: GeoSnapshot, n_axes: int) -> tuple[Any, ...]:
    """The snapshot's packed fields: slices of the tuple and its per-axis tuples, not 25
    attribute reads and a starred display: packing was 12.6 % of the GEO process's CPU samples
    (perf of `liftd run` on the demo, 2026-12-01)."""
    out: tuple[Any, ...] = ()
    fields: tuple[Any, ...] = s
    for first, end, per_axis in _RUNS:
        if per_axis:
            out += fields[first] or (0,) * n_axes
        else:
            out += fields[first:end]
    return out


class SnapshotCodec:
    """GeoSnapshot (without its events) + LoopStats ↔ bytes, for a channel of `n_axes`."""

    def __init__(self, n_axes: int) -> None:
        self.n = n_axes
        body = "".join(f"{n_axes}{rec.code}" if rec.per_axis else rec.code for _, rec, _ in _LAYOUT)
        self.fmt = struct.Struct(f"<{body}{STATS}")
        self.size = self.fmt.size
        # how many values a snapshot is in the record
        self.values = sum(n_axes if rec.per_axis else 1 for _, rec, _ in _LAYOUT if rec.code)

    def pack(self, s: GeoSnapshot, st: LoopStats) -> bytes:
        return self.fmt.pack(*(_fields(s, self.n) + st))

    def unpack(self, raw: bytes) -> tuple[GeoSnapshot, LoopStats]:
        v = self.fmt.unpack(raw)
        return self.snapshot_of(v), LoopStats(*v[self.values :])

    def snapshot_of(self, v: tuple[Any, ...]) -> GeoSnapshot:
        """The snapshot from the unpacked fields (its `values` first)."""
        n = self.n
        fields: list[Any] = []
        at = 0
        for i, (_, rec, _) in enumerate(_LAYOUT):
            if not rec.code:
                fields.append(())
            elif rec.per_axis:
                fields.append(tuple(v[at : at + n]))
                at += n
            else:
                members = _ENUMS.get(i)
                fields.append(v[at] if members is None else members[v[at]])
                at += 1
        return GeoSnapshot(*fields)


class MachineCodec:
    """The snapshots of every channel of a machine (channel order) + LoopStats ↔ bytes: the
    channels' fields one after the other, the loop's timing once at the end. With one
    channel the bytes are exactly `SnapshotCodec`'s."""

    def __init__(self, axes: Sequence[int]) -> None:
        self.axes = tuple(axes)
        self.channels = [SnapshotCodec(n) for n in self.axes]
        bodies = "".join(c.fmt.format[1 : -len(STATS)] for c in self.channels)  # no "<", stats
        self.fmt = struct.Struct(f"<{bodies}{STATS}")
        self.size = self.fmt.size
        self._fields = [c.values for c in self.channels]

    def pack(self, snaps: Sequence[GeoSnapshot], st: LoopStats) -> bytes:
        axes = self.axes
        if len(snaps) != len(axes):
            raise ValueError(f"{len(snaps)} snapshots for {len(axes)} channels")
        values: tuple[Any, ...] = ()
        for i in range(len(axes)):
            values += _fields(snaps[i], axes[i])
        return self.fmt.pack(*(values + st))

    def unpack(self, raw: bytes) -> tuple[tuple[GeoSnapshot, ...], LoopStats]:
        v = self.fmt.unpack(raw)
        snaps, at = [], 0
        for codec, size in zip(self.channels, self._fields, strict=True):
            snaps.append(codec.snapshot_of(v[at : at + size]))
            at += size
        return tuple(snaps), LoopStats(*v[at:])


def pack_input(w: PlcWrite) -> bytes:
    return INPUT.pack(int(w.signal), w.value, w.channel)


new_write = cast(
    Callable[[tuple[PlcSignal, float, int]], PlcWrite], functools.partial(tuple.__new__, PlcWrite)
)
# the members by value: `PlcSignal(n)` runs the enum machinery (Python code in enum.py; 19 µs
# of a PLC write's cycle when the caches are cold, as they are after the loop's sleep)
_SIGNALS: dict[int, PlcSignal] = {int(s): s for s in PlcSignal}
# what a geo.plc_input event calls each signal (`.name` is enum.py's Python property, 6 µs cold)
INPUT_NAMES: dict[PlcSignal, str] = {s: s.name.lower() for s in PlcSignal}


def unpack_input(raw: bytes) -> PlcWrite:
    signal, value, channel = INPUT.unpack(raw)
    sig = _SIGNALS.get(signal)
    if sig is None:
        raise ValueError(f"{signal} is not a valid PlcSignal")
    return new_write((sig, value, channel))


def pack_event(ev: Event, channel: int = 0) -> bytes:
    """An event record; `channel` (or the event's own) is the logical channel id it comes
    from in a machine of several channels, 0 for none."""
    eid = EVENT_IDS.get(ev.name, 0)
    text = ev.text if eid else f"{ev.name}\0{ev.text}"
    raw = text.encode("utf-8", "replace")[:MAX_EVENT_TEXT]
    head = eid | ((channel or ev.channel) << 8)
    return EVENT_HEAD.pack(head, len(raw), ev.line & 0xFFFFFFFF, ev.t, ev.value) + raw


class EventReader:
    """Reassembles event records from reads of the event stream (a read may end inside a record)."""

    def __init__(self) -> None:
        self._buf = bytearray()

    def feed(self, data: bytes) -> list[Event]:
        self._buf += data
        out: list[Event] = []
        pos = 0
        while len(self._buf) - pos >= EVENT_HEAD.size:
            head, n, line, t, value = EVENT_HEAD.unpack_from(self._buf, pos)
            eid, channel = head & EVENT_NAME_MASK, head >> 8
            end = pos + EVENT_HEAD.size + n
            if end > len(self._buf):
                break
            text = bytes(self._buf[pos + EVENT_HEAD.size : end]).decode("utf-8", "replace")
            name = EVENT_NAMES[eid] if eid < len(EVENT_NAMES) else "?"
            if not eid:
                name, _, text = text.partition("\0")
            out.append(Event(name, t, line, value, text, channel))
            pos = end
        del self._buf[:pos]
        return out


MESSAGE_HEAD = struct.Struct("<Q")  # length of the pickle that follows


def pack_message(obj: Any) -> bytes:
    """One control-pipe message (daemon → GEO process): its configuration, a reload."""
    data = pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL)
    return MESSAGE_HEAD.pack(len(data)) + data


def read_message(fd: int) -> Any:
    """Read one whole message from a blocking descriptor; EOFError if the pipe is closed."""
    (size,) = MESSAGE_HEAD.unpack(_read_exactly(fd, MESSAGE_HEAD.size))
    return pickle.loads(_read_exactly(fd, size))


def _read_exactly(fd: int, size: int) -> bytes:
    parts, left = [], size
    while left:
        chunk = os.read(fd, min(left, 1 << 20))
        if not chunk:
            raise EOFError("the control pipe was closed")
        parts.append(chunk)
        left -= len(chunk)
    return b"".join(parts)
