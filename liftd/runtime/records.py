"""Fixed binary layouts crossing the process boundary: a cycle's snapshot (+ loop timing), a
PLC input, an event; and the framing of the control pipe's messages (a length, then a pickle).
Pure; struct and pickle only (packing a snapshot costs ~1 µs)."""

from __future__ import annotations

import functools
import os
import pickle
import struct
from collections.abc import Callable, Sequence
from typing import Any, cast

from liftd.cnc.snapshot import (
    ChannelState,
    Event,
    GeoSnapshot,
    LiftPhase,
    LoopStats,
    PlcSignal,
    PlcWrite,
)

INPUT = struct.Struct("<IdI")  # signal, value, machine index of the channel
EVENT_HEAD = struct.Struct("<HHIdd")  # name id (+ channel id << 8), text bytes, line, t, value
EVENT_NAME_MASK = 0xFF
MAX_EVENT_TEXT = 1000  # a record's text (the event stream holds 64 KiB)

EVENT_NAMES = (
    "",  # 0: the name travels in the text ("name\0text")
    "geo.program_start",
    "geo.program_end",
    "geo.resume",
    "geo.stopped",
    "geo.reset",
    "geo.error",
    "geo.m_output",
    "geo.m_ack",
    "geo.m00",
    "lift.start",
    "lift.end",
    "lift.late",
    "lift.path_waits",
    "lift.override_limited",
    "lift.fallback",
    "lift.guard_clamped",
    "lift.z_acc_warning",
    "lift.z_acc_error",
    "geo.overrun",
    "geo.compute_over",
    "geo.regrid",
    "geo.reloaded",
    "geo.plan_error",
    "geo.plc_input",
    "lift.aborted",
)
EVENT_IDS = {name: i for i, name in enumerate(EVENT_NAMES)}


STATS = "qqddddqdq"  # LoopStats


def _fields(s: GeoSnapshot, n_axes: int) -> tuple[Any, ...]:
    """The snapshot's packed fields: the tuple without its events, positions and lift counts
    flattened. Slices of the tuple, not 25 attribute reads and a starred display: packing
    was 12.6 % of the GEO process's CPU samples (perf of `liftd run` on the demo, 2026-12-01)."""
    return s[:5] + s[5] + s[6:19] + s[20:23] + (s[23] or (0,) * n_axes)


class SnapshotCodec:
    """GeoSnapshot (without its events) + LoopStats ↔ bytes, for a channel of `n_axes`."""

    def __init__(self, n_axes: int) -> None:
        self.n = n_axes
        self.fmt = struct.Struct(f"<qdiii{n_axes}ddddd???iddiiiddi{n_axes}I" + STATS)
        self.size = self.fmt.size

    def pack(self, s: GeoSnapshot, st: LoopStats) -> bytes:
        return self.fmt.pack(*(_fields(s, self.n) + st))

    def unpack(self, raw: bytes) -> tuple[GeoSnapshot, LoopStats]:
        v = self.fmt.unpack(raw)
        return self.snapshot_of(v), LoopStats(*v[21 + 2 * self.n :])

    def snapshot_of(self, v: tuple[Any, ...]) -> GeoSnapshot:
        """The snapshot from the unpacked fields (its 21 + 2·n_axes values first)."""
        n = self.n
        pos = tuple(v[5 : 5 + n])
        r = v[5 + n :]
        snap = GeoSnapshot(
            v[0],
            v[1],
            ChannelState(v[2]),
            v[3],
            v[4],
            pos,
            r[0],
            r[1],
            r[2],
            r[3],
            r[4],
            r[5],
            r[6],
            LiftPhase(r[7]),
            r[8],
            r[9],
            r[10],
            r[11],
            r[12],
            (),
            r[13],
            r[14],
            r[15],
            tuple(r[16 : 16 + n]),
        )
        return snap


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
        self._fields = [21 + 2 * n for n in self.axes]

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
