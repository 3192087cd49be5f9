"""Sans-IO AMS/ADS codec: bytes in, typed values out, and back. Pure: no sockets, no clock.

Layouts (little-endian, docs/reference/ads.md §1): AMS/TCP header (reserved u16, length u32), AMS
header (target NetId 6 B + port u16, source NetId + port, command u16, state flags u16, data
length u32, error u32, invoke id u32), then the ADS payload of the command. Every decoder checks
the sizes its layout implies and raises AdsError(INVALIDSIZE, 0x705) otherwise; every message
re-encodes to exactly the bytes it was decoded from.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence
from typing import NamedTuple

from liftd.ads.constants import AdsErr, Command
from liftd.ads.errors import AdsError

TCP_HEADER = struct.Struct("<HI")
AMS_HEADER = struct.Struct("<6sH6sHHHIII")
TCP_SIZE = TCP_HEADER.size  # 6
AMS_SIZE = AMS_HEADER.size  # 32
HEADER_SIZE = TCP_SIZE + AMS_SIZE

U32 = struct.Struct("<I")
U32X2 = struct.Struct("<II")
U32X3 = struct.Struct("<III")
U32X4 = struct.Struct("<IIII")
U16X2 = struct.Struct("<HH")
STATE_RESPONSE = struct.Struct("<IHH")
DEVICE_INFO = struct.Struct("<IBBH16s")
WRITE_CONTROL = struct.Struct("<HHI")
ADD_NOTE = struct.Struct("<IIIIII16s")
STAMP = struct.Struct("<QI")
SYMBOL_HEAD = struct.Struct("<IIIIIIHHH")  # SAdsSymbolEntry without its strings (30 B)

FILETIME_UNIX_OFFSET_S = 11_644_473_600  # seconds from 1601-01-01 to 1970-01-01


def net_id_bytes(text: str) -> bytes:
    """'127.0.0.1.1.1' → 6 bytes (each part 0..255; raises ValueError otherwise)."""
    parts = text.split(".")
    if len(parts) != 6:
        raise ValueError(f"AMS NetId {text!r}: six numbers joined by dots")
    return bytes(int(p) for p in parts)


def net_id_text(raw: bytes) -> str:
    return ".".join(str(b) for b in raw)


def filetime(unix_ns: int) -> int:
    """Unix time in ns → FILETIME (100 ns since 1601-01-01, UTC; docs/reference/ads.md §0.6)."""
    return unix_ns // 100 + FILETIME_UNIX_OFFSET_S * 10_000_000


class AmsHeader(NamedTuple):
    target_net_id: bytes
    target_port: int
    source_net_id: bytes
    source_port: int
    command: int
    flags: int
    length: int
    error: int
    invoke_id: int


class Frame(NamedTuple):
    """One AMS/TCP frame: reserved field, AMS header and payload (not yet interpreted)."""

    reserved: int
    header: AmsHeader
    payload: bytes


def decode_frame(raw: bytes) -> Frame:
    """Split a whole frame (as the framer returns it). A header whose data length disagrees
    with the AMS/TCP length raises AdsError(INVALIDSIZE); the caller answers AMS error 0xE."""
    reserved, length = TCP_HEADER.unpack_from(raw)
    if len(raw) != TCP_SIZE + length or length < AMS_SIZE:
        raise AdsError(AdsErr.INVALIDSIZE, f"AMS/TCP length {length}, frame {len(raw)} bytes")
    header = AmsHeader._make(AMS_HEADER.unpack_from(raw, TCP_SIZE))
    payload = raw[HEADER_SIZE:]
    if header.length != len(payload):
        raise AdsError(AdsErr.INVALIDSIZE, f"AMS data length {header.length} ≠ {len(payload)}")
    return Frame(reserved, header, payload)


def encode_frame(header: AmsHeader, payload: bytes, reserved: int = 0) -> bytes:
    """AMS/TCP + AMS header + payload; `header.length` is ignored and set from the payload."""
    return b"".join(
        (
            TCP_HEADER.pack(reserved, AMS_SIZE + len(payload)),
            AMS_HEADER.pack(*header[:6], len(payload), header.error, header.invoke_id),
            payload,
        )
    )


def reply_header(request: AmsHeader, flags: int, error: int = 0) -> AmsHeader:
    """Header of the response to `request`: addresses swapped, same command and invoke id."""
    return AmsHeader(
        request.source_net_id,
        request.source_port,
        request.target_net_id,
        request.target_port,
        request.command,
        flags,
        0,
        error,
        request.invoke_id,
    )


# -- requests (client → server) -----------------------------------------------------------------
class ReadRequest(NamedTuple):
    index_group: int
    index_offset: int
    length: int


class WriteRequest(NamedTuple):
    index_group: int
    index_offset: int
    data: bytes


class ReadWriteRequest(NamedTuple):
    index_group: int
    index_offset: int
    read_length: int
    data: bytes


class AddNotificationRequest(NamedTuple):
    index_group: int
    index_offset: int
    length: int
    mode: int
    max_delay_100ns: int  # 100 ns units on the wire, not ms (docs/reference/ads.md §0.6)
    cycle_time_100ns: int
    reserved: bytes = bytes(16)


class WriteControlRequest(NamedTuple):
    ads_state: int
    device_state: int
    data: bytes


def _exact(payload: bytes, size: int, what: str) -> None:
    if len(payload) != size:
        raise AdsError(AdsErr.INVALIDSIZE, f"{what}: {len(payload)} bytes, expected {size}")


def decode_read(payload: bytes) -> ReadRequest:
    _exact(payload, 12, "Read")
    return ReadRequest._make(U32X3.unpack(payload))


def decode_write(payload: bytes) -> WriteRequest:
    if len(payload) < 12:
        raise AdsError(AdsErr.INVALIDSIZE, "Write shorter than 12 bytes")
    ig, io, length = U32X3.unpack_from(payload)
    _exact(payload, 12 + length, "Write")
    return WriteRequest(ig, io, payload[12:])


def decode_read_write(payload: bytes) -> ReadWriteRequest:
    if len(payload) < 16:
        raise AdsError(AdsErr.INVALIDSIZE, "ReadWrite shorter than 16 bytes")
    ig, io, read_length, write_length = U32X4.unpack_from(payload)
    _exact(payload, 16 + write_length, "ReadWrite")
    return ReadWriteRequest(ig, io, read_length, payload[16:])


def decode_add_notification(payload: bytes) -> AddNotificationRequest:
    _exact(payload, ADD_NOTE.size, "AddDeviceNotification")
    return AddNotificationRequest._make(ADD_NOTE.unpack(payload))


def decode_del_notification(payload: bytes) -> int:
    _exact(payload, 4, "DeleteDeviceNotification")
    return int(U32.unpack(payload)[0])


def decode_write_control(payload: bytes) -> WriteControlRequest:
    if len(payload) < 8:
        raise AdsError(AdsErr.INVALIDSIZE, "WriteControl shorter than 8 bytes")
    ads_state, device_state, length = WRITE_CONTROL.unpack_from(payload)
    _exact(payload, 8 + length, "WriteControl")
    return WriteControlRequest(ads_state, device_state, payload[8:])


def encode_read_request(r: ReadRequest) -> bytes:
    return U32X3.pack(*r)


def encode_write_request(r: WriteRequest) -> bytes:
    return U32X3.pack(r.index_group, r.index_offset, len(r.data)) + r.data


def encode_read_write_request(r: ReadWriteRequest) -> bytes:
    return U32X4.pack(r.index_group, r.index_offset, r.read_length, len(r.data)) + r.data


def encode_add_notification_request(r: AddNotificationRequest) -> bytes:
    return ADD_NOTE.pack(*r)


def encode_write_control_request(r: WriteControlRequest) -> bytes:
    return WRITE_CONTROL.pack(r.ads_state, r.device_state, len(r.data)) + r.data


# -- responses (server → client) -----------------------------------------------------------------
def result_only(result: int) -> bytes:
    return U32.pack(result)


def read_response(result: int, data: bytes = b"") -> bytes:
    """Read and ReadWrite responses: result, length, data."""
    return U32X2.pack(result, len(data)) + data


def state_response(result: int, ads_state: int, device_state: int) -> bytes:
    return STATE_RESPONSE.pack(result, ads_state, device_state)


def device_info_response(result: int, major: int, minor: int, build: int, name: bytes) -> bytes:
    """The full 24 bytes: the name NUL-padded to 16 (pyads' test server sends 19,
    docs/reference/ads.md §1.5)."""
    return DEVICE_INFO.pack(result, major, minor, build, name[:16].ljust(16, b"\0"))


def add_notification_response(result: int, handle: int) -> bytes:
    return U32X2.pack(result, handle)


def decode_read_response(payload: bytes) -> tuple[int, bytes]:
    """Read / ReadWrite response → (result, data)."""
    if len(payload) < 8:
        raise AdsError(AdsErr.INVALIDSIZE, "Read response shorter than 8 bytes")
    result, length = U32X2.unpack_from(payload)
    _exact(payload, 8 + length, "Read response")
    return result, payload[8:]


def decode_result(payload: bytes) -> int:
    _exact(payload, 4, "result")
    return int(U32.unpack(payload)[0])


def decode_state_response(payload: bytes) -> tuple[int, int, int]:
    _exact(payload, STATE_RESPONSE.size, "ReadState response")
    result, ads_state, device_state = STATE_RESPONSE.unpack(payload)
    return result, ads_state, device_state


def decode_device_info_response(payload: bytes) -> tuple[int, int, int, int, bytes]:
    _exact(payload, DEVICE_INFO.size, "ReadDeviceInfo response")
    result, major, minor, build, name = DEVICE_INFO.unpack(payload)
    return result, major, minor, build, name


def decode_add_notification_response(payload: bytes) -> tuple[int, int]:
    _exact(payload, 8, "AddDeviceNotification response")
    result, handle = U32X2.unpack(payload)
    return result, handle


class Sample(NamedTuple):
    handle: int
    data: bytes


class Stamp(NamedTuple):
    filetime: int
    samples: tuple[Sample, ...]


def encode_notification(stamps: Sequence[Stamp]) -> bytes:
    """DeviceNotification payload: u32 length (bytes after this field), u32 stamps, then per
    stamp FILETIME u64, u32 samples, per sample handle u32, size u32, data (docs/reference/ads.md
    §1.6)."""
    parts: list[bytes] = [b"", U32.pack(len(stamps))]
    for stamp in stamps:
        parts.append(STAMP.pack(stamp.filetime, len(stamp.samples)))
        for sample in stamp.samples:
            parts.append(U32X2.pack(sample.handle, len(sample.data)))
            parts.append(sample.data)
    body = b"".join(parts)
    return U32.pack(len(body)) + body


def decode_notification(payload: bytes) -> tuple[Stamp, ...]:
    if len(payload) < 8:
        raise AdsError(AdsErr.INVALIDSIZE, "DeviceNotification shorter than 8 bytes")
    length, count = U32X2.unpack_from(payload)
    if length != len(payload) - 4:
        raise AdsError(AdsErr.INVALIDSIZE, "DeviceNotification length field")
    pos = 8
    stamps = []
    for _ in range(count):
        if pos + STAMP.size > len(payload):
            raise AdsError(AdsErr.INVALIDSIZE, "DeviceNotification stamp truncated")
        ft, n = STAMP.unpack_from(payload, pos)
        pos += STAMP.size
        samples = []
        for _ in range(n):
            if pos + 8 > len(payload):
                raise AdsError(AdsErr.INVALIDSIZE, "DeviceNotification sample truncated")
            handle, size = U32X2.unpack_from(payload, pos)
            pos += 8
            if pos + size > len(payload):
                raise AdsError(AdsErr.INVALIDSIZE, "DeviceNotification sample data truncated")
            samples.append(Sample(handle, payload[pos : pos + size]))
            pos += size
        stamps.append(Stamp(ft, tuple(samples)))
    if pos != len(payload):
        raise AdsError(AdsErr.INVALIDSIZE, "DeviceNotification has trailing bytes")
    return tuple(stamps)


class SymbolEntry(NamedTuple):
    """SAdsSymbolEntry (reply of 0xF009 and the records of the 0xF00B upload)."""

    index_group: int
    index_offset: int
    size: int
    data_type: int
    flags: int
    name: bytes
    type_name: bytes
    comment: bytes


def encode_symbol_entry(e: SymbolEntry) -> bytes:
    """Head, then name, type and comment each NUL-terminated; entryLength counts it all (pyads
    checks that the reply is exactly entryLength bytes, docs/reference/ads.md §3)."""
    strings = e.name + b"\0" + e.type_name + b"\0" + e.comment + b"\0"
    total = SYMBOL_HEAD.size + len(strings)
    head = SYMBOL_HEAD.pack(
        total,
        e.index_group,
        e.index_offset,
        e.size,
        e.data_type,
        e.flags,
        len(e.name),
        len(e.type_name),
        len(e.comment),
    )
    return head + strings


def decode_symbol_entry(raw: bytes, pos: int = 0) -> tuple[SymbolEntry, int]:
    """One entry at `pos`; returns it and the position after it."""
    if pos + SYMBOL_HEAD.size > len(raw):
        raise AdsError(AdsErr.INVALIDSIZE, "symbol entry truncated")
    total, ig, io, size, adst, flags, n_name, n_type, n_comment = SYMBOL_HEAD.unpack_from(raw, pos)
    end = pos + total
    strings_at = pos + SYMBOL_HEAD.size
    if end > len(raw) or strings_at + n_name + n_type + n_comment + 3 > end:
        raise AdsError(AdsErr.INVALIDSIZE, "symbol entry length")
    name = raw[strings_at : strings_at + n_name]
    t0 = strings_at + n_name + 1
    type_name = raw[t0 : t0 + n_type]
    c0 = t0 + n_type + 1
    comment = raw[c0 : c0 + n_comment]
    return SymbolEntry(ig, io, size, adst, flags, name, type_name, comment), end


REQUEST_DECODERS = {
    Command.READ: decode_read,
    Command.WRITE: decode_write,
    Command.READ_WRITE: decode_read_write,
    Command.ADD_NOTIFICATION: decode_add_notification,
    Command.DEL_NOTIFICATION: decode_del_notification,
    Command.WRITE_CONTROL: decode_write_control,
}
