"""ADS services over a small fake device: every command, the reserved index groups, sum
commands with exactly the layouts clients expect, symbol handles and their error codes."""

from __future__ import annotations

import struct
from collections.abc import Sequence

import pytest

from liftd.ads import wire
from liftd.ads.constants import AdsErr, AdsState, Adst, Command, IndexGroup
from liftd.ads.errors import AdsError
from liftd.ads.service import AdsService, ServiceLimits, Session, Symbol
from liftd.ads.symbols import DataType

NET = bytes([127, 0, 0, 1, 1, 1])
CLIENT = bytes([10, 0, 0, 7, 1, 1])


class Device:
    """IG 0x10: IO 0 = u32 counter (read only), IO 4 = u16 setpoint (read/write)."""

    symbol_version = 3

    def __init__(self) -> None:
        self.counter = 7
        self.setpoint = 100
        self.syms = [
            Symbol("Dev.counter", 0x10, 0, 4, Adst.UINT32, "UDINT", "a counter"),
            Symbol("Dev.setpoint", 0x10, 4, 2, Adst.UINT16, "UINT", "", writable=True),
        ]

    def read(self, ig: int, io: int, length: int) -> bytes:
        if ig != 0x10:
            raise AdsError(AdsErr.INVALIDGRP)
        if io == 0:
            data = struct.pack("<I", self.counter)
        elif io == 4:
            data = struct.pack("<H", self.setpoint)
        else:
            raise AdsError(AdsErr.INVALIDOFFSET)
        if length < len(data):
            raise AdsError(AdsErr.INVALIDSIZE)
        return data

    def write(self, ig: int, io: int, data: bytes) -> None:
        self.read(ig, io, 8)
        if io != 4:
            raise AdsError(AdsErr.INVALIDACCESS)
        if len(data) != 2:
            raise AdsError(AdsErr.INVALIDSIZE)
        self.setpoint = struct.unpack("<H", data)[0]

    def read_write(self, ig: int, io: int, read_length: int, data: bytes) -> bytes:
        raise AdsError(AdsErr.SRVNOTSUPP)

    def find_symbol(self, name: str) -> Symbol:
        for s in self.syms:
            if s.name.lower() == name.lower():
                return s
        raise AdsError(AdsErr.SYMBOLNOTFOUND)

    def symbols(self) -> Sequence[Symbol]:
        return self.syms

    def data_types(self) -> Sequence[DataType]:
        return (DataType("T_Count", 4, Adst.UINT32, "UDINT", "an alias"),)

    def ads_state(self) -> tuple[int, int]:
        return int(AdsState.RUN), 0

    def write_control(self, ads_state: int, device_state: int, data: bytes) -> None:
        if ads_state != AdsState.RUN:
            raise AdsError(AdsErr.SRVNOTSUPP)


@pytest.fixture
def svc() -> AdsService:
    return AdsService(Device(), ServiceLimits(max_sum_subcommands=600, max_handles=3))


def call(
    svc: AdsService, s: Session, command: int, payload: bytes = b"", may_write: bool = True
) -> bytes:
    header = wire.AmsHeader(NET, 551, CLIENT, 30000, command, 4, len(payload), 0, 1)
    reply = svc.handle(s, header, payload, may_write, 0)
    assert reply.failure is None
    return reply.payload


def read(svc: AdsService, s: Session, ig: int, io: int, n: int) -> tuple[int, bytes]:
    return wire.decode_read_response(
        call(svc, s, Command.READ, wire.encode_read_request(wire.ReadRequest(ig, io, n)))
    )


def rw(
    svc: AdsService, s: Session, ig: int, io: int, n: int, data: bytes, w: bool = True
) -> tuple[int, bytes]:
    req = wire.encode_read_write_request(wire.ReadWriteRequest(ig, io, n, data))
    return wire.decode_read_response(call(svc, s, Command.READ_WRITE, req, w))


def write(svc: AdsService, s: Session, ig: int, io: int, data: bytes, w: bool = True) -> int:
    req = wire.encode_write_request(wire.WriteRequest(ig, io, data))
    return wire.decode_result(call(svc, s, Command.WRITE, req, w))


def test_every_command_has_a_handler(svc: AdsService) -> None:
    assert set(svc.commands) == set(Command) - {Command.INVALID, Command.NOTIFICATION}


def test_device_info_state_and_write_control(svc: AdsService) -> None:
    s = svc.new_session()
    assert wire.decode_device_info_response(call(svc, s, Command.READ_DEVICE_INFO)) == (
        0,
        0,
        1,
        0,
        b"liftd GEO".ljust(16, b"\0"),
    )
    assert wire.decode_state_response(call(svc, s, Command.READ_STATE)) == (0, 5, 0)
    ctl = wire.encode_write_control_request(wire.WriteControlRequest(5, 0, b""))
    assert wire.decode_result(call(svc, s, Command.WRITE_CONTROL, ctl)) == 0
    assert wire.decode_result(call(svc, s, Command.WRITE_CONTROL, ctl, False)) == 0x704
    stop = wire.encode_write_control_request(wire.WriteControlRequest(6, 0, b""))
    assert wire.decode_result(call(svc, s, Command.WRITE_CONTROL, stop)) == 0x701


def test_read_write_and_their_errors(svc: AdsService) -> None:
    s = svc.new_session()
    assert read(svc, s, 0x10, 0, 4) == (0, struct.pack("<I", 7))
    assert read(svc, s, 0x10, 0, 1024) == (0, struct.pack("<I", 7))  # longer buffer: fine
    assert read(svc, s, 0x10, 0, 2) == (0x705, b"")
    assert read(svc, s, 0x11, 0, 4) == (0x702, b"")
    assert read(svc, s, 0x10, 8, 4) == (0x703, b"")
    assert write(svc, s, 0x10, 4, b"\x05\x00") == 0
    assert read(svc, s, 0x10, 4, 2) == (0, b"\x05\x00")
    assert write(svc, s, 0x10, 0, b"\0\0\0\0") == 0x704
    assert write(svc, s, 0x10, 4, b"\x06\x00", w=False) == 0x704  # read-only source
    bad = call(svc, s, Command.READ, bytes(11))
    assert wire.decode_read_response(bad) == (0x705, b"")


def test_symbol_handles(svc: AdsService) -> None:
    s = svc.new_session()
    code, raw = rw(svc, s, IndexGroup.SYM_HNDBYNAME, 0, 4, b"dev.COUNTER\0")
    assert code == 0 and len(raw) == 4
    handle = int.from_bytes(raw, "little")
    assert read(svc, s, IndexGroup.SYM_VALBYHND, handle, 4) == (0, struct.pack("<I", 7))
    assert write(svc, s, IndexGroup.SYM_VALBYHND, handle, bytes(4)) == 0x704
    assert write(svc, s, IndexGroup.SYM_RELEASEHND, 0, raw) == 0
    assert read(svc, s, IndexGroup.SYM_VALBYHND, handle, 4)[0] == 0x710  # released
    assert write(svc, s, IndexGroup.SYM_RELEASEHND, 0, raw) == 0x710
    assert rw(svc, s, IndexGroup.SYM_HNDBYNAME, 0, 4, b"nope\0") == (0x710, b"")
    other = svc.new_session()  # handles belong to their connection
    assert read(svc, other, IndexGroup.SYM_VALBYHND, handle, 4)[0] == 0x710
    codes = [rw(svc, s, IndexGroup.SYM_HNDBYNAME, 0, 4, b"Dev.setpoint")[0] for _ in range(4)]
    assert codes == [0, 0, 0, 0x716]  # max_handles = 3


def test_symbol_info_and_upload(svc: AdsService) -> None:
    s = svc.new_session()
    code, raw = rw(svc, s, IndexGroup.SYM_INFOBYNAMEEX, 0, 798, b"Dev.counter\0")
    entry, end = wire.decode_symbol_entry(raw)
    assert code == 0 and end == len(raw)  # exactly entryLength (pyads checks it)
    assert (entry.index_group, entry.index_offset, entry.size, entry.type_name) == (
        0x10,
        0,
        4,
        b"UDINT",
    )
    assert entry.flags == 0x20  # read-only
    assert rw(svc, s, IndexGroup.SYM_INFOBYNAMEEX, 0, 10, b"Dev.counter\0") == (0x705, b"")
    code, info = read(svc, s, IndexGroup.SYM_UPLOADINFO2, 0, 24)
    count, size = struct.unpack_from("<II", info)
    assert (code, count, len(info)) == (0, 2, 24)
    code, upload = read(svc, s, IndexGroup.SYM_UPLOAD, 0, size)
    first, pos = wire.decode_symbol_entry(upload)
    second, pos = wire.decode_symbol_entry(upload, pos)
    assert pos == size and second.name == b"Dev.setpoint" and second.flags == 0
    assert read(svc, s, IndexGroup.SYM_VERSION, 0, 1) == (0, b"\x03")


def sum_read_request(subs: list[tuple[int, int, int]]) -> tuple[int, bytes]:
    return 4 * len(subs) + sum(n for *_, n in subs), b"".join(struct.pack("<III", *x) for x in subs)


def test_sum_read_blocks_are_the_requested_length_even_on_error(svc: AdsService) -> None:
    s = svc.new_session()
    subs = [(0x10, 0, 4), (0x10, 9, 4), (0x10, 4, 2), (0xF080, 0, 1)]
    rlen, data = sum_read_request(subs)
    code, out = rw(svc, s, IndexGroup.SUMUP_READ, len(subs), rlen, data)
    assert code == 0 and len(out) == rlen
    assert struct.unpack_from("<4I", out) == (0, 0x703, 0, 0x701)
    assert out[16:20] == struct.pack("<I", 7) and out[20:24] == bytes(4)
    assert out[24:26] == struct.pack("<H", 100) and out[26:27] == b"\0"


def test_sum_read_of_600_and_the_cap(svc: AdsService) -> None:
    s = svc.new_session()
    rlen, data = sum_read_request([(0x10, 0, 4)] * 600)
    code, out = rw(svc, s, IndexGroup.SUMUP_READ, 600, rlen, data)
    assert code == 0 and out[: 4 * 600] == bytes(4 * 600)
    rlen, data = sum_read_request([(0x10, 0, 4)] * 601)
    assert rw(svc, s, IndexGroup.SUMUP_READ, 601, rlen, data)[0] == 0x705  # over the cap
    assert rw(svc, s, IndexGroup.SUMUP_READ, 2, 16, data[:12])[0] == 0x705  # headers missing
    assert rw(svc, s, IndexGroup.SUMUP_READ, 1, 7, data[:12])[0] == 0x705  # rlen too small


def test_sum_write_and_sum_read_write(svc: AdsService) -> None:
    s = svc.new_session()
    heads = struct.pack("<III", 0x10, 4, 2) + struct.pack("<III", 0x10, 0, 4)
    code, out = rw(svc, s, IndexGroup.SUMUP_WRITE, 2, 8, heads + b"\x09\x00" + bytes(4))
    assert (code, struct.unpack("<II", out)) == (0, (0, 0x704))
    assert read(svc, s, 0x10, 4, 2) == (0, b"\x09\x00")
    code, out = rw(svc, s, IndexGroup.SUMUP_WRITE, 2, 8, heads + b"\x09\x00" + bytes(3))
    assert code == 0x705  # data does not match the headers
    # 0xF082: handle by name for two symbols (ads-client createVariableHandleMulti)
    names = [b"Dev.counter", b"nope"]
    heads = b"".join(struct.pack("<IIII", IndexGroup.SYM_HNDBYNAME, 0, 4, len(n)) for n in names)
    code, out = rw(svc, s, IndexGroup.SUMUP_READWRITE, 2, 100, heads + b"".join(names))
    assert code == 0
    assert struct.unpack_from("<IIII", out) == (0, 4, 0x710, 0)  # (result, length) each
    assert len(out) == 16 + 4  # compact: only the returned data


def test_unexpected_exceptions_still_get_an_answer() -> None:
    class Broken(Device):
        def read(self, ig: int, io: int, length: int) -> bytes:
            raise ZeroDivisionError

    svc = AdsService(Broken(), ServiceLimits())
    s = svc.new_session()
    header = wire.AmsHeader(NET, 551, CLIENT, 30000, 2, 4, 12, 0, 1)
    reply = svc.handle(s, header, wire.encode_read_request(wire.ReadRequest(0x10, 0, 4)), True, 0)
    assert wire.decode_read_response(reply.payload) == (0x700, b"")
    assert isinstance(reply.failure, ZeroDivisionError)


def test_notifications_through_the_service(svc: AdsService) -> None:
    s = svc.new_session()

    def add(ig: int, io: int, n: int, mode: int = 4) -> tuple[int, int]:
        req = wire.AddNotificationRequest(ig, io, n, mode, 0, 10_000)
        return wire.decode_add_notification_response(
            call(svc, s, Command.ADD_NOTIFICATION, wire.encode_add_notification_request(req))
        )

    assert add(0x10, 9, 4) == (0x703, 0)  # the object must exist
    assert add(0x10, 0, 4, mode=10) == (0x713, 0)
    code, handle = add(0x10, 0, 4)
    assert code == 0 and handle > 0
    out = s.notifications.poll(10**9, 0, lambda ig, io, n: svc.read(s, ig, io, n))
    assert [wire.decode_notification(o.payload)[0].samples for o in out] == [
        (wire.Sample(handle, struct.pack("<I", 7)),)
    ]
    assert out[0].client.net_id == CLIENT and out[0].server.port == 551
    delete = handle.to_bytes(4, "little")
    assert wire.decode_result(call(svc, s, Command.DEL_NOTIFICATION, delete)) == 0
    assert wire.decode_result(call(svc, s, Command.DEL_NOTIFICATION, delete)) == 0x714


def data_type_entry(raw: bytes) -> tuple[tuple[int, ...], list[bytes]]:
    """AdsDatatypeEntry as ads-client and ads-rs parse it: the head, then the three strings."""
    head = struct.unpack_from("<IIIIIIIIHHHHH", raw)
    pos, strings = 42, []
    for n in head[8:11]:
        strings.append(raw[pos : pos + n])
        assert raw[pos + n] == 0
        pos += n + 1
    assert head[0] == pos == len(raw)  # entryLength counts the whole entry
    return head, strings


def test_upload_info_is_64_bytes_with_the_data_types(svc: AdsService) -> None:
    s = svc.new_session()
    code, info = read(svc, s, IndexGroup.SYM_UPLOADINFO2, 0, 64)
    assert code == 0 and len(info) == 64  # ads-rs read_exact(64), ads-client version 3
    n_sym, sym_bytes, n_types, type_bytes, _, _, _, code_page, flags = struct.unpack_from(
        "<9I", info
    )
    assert (n_sym, code_page, flags) == (2, 1252, 2)  # base types included
    assert read(svc, s, IndexGroup.SYM_UPLOADINFO, 0, 8) == (0, info[:8])
    code, types = read(svc, s, IndexGroup.SYM_DT_UPLOAD, 0, type_bytes)
    assert code == 0 and len(types) == type_bytes
    names, pos = [], 0
    while pos < len(types):
        size = struct.unpack_from("<I", types, pos)[0]
        head, (name, base, _) = data_type_entry(types[pos : pos + size])
        assert head[1] == 1 and head[5] == 0  # version 1, offset 0 (ads-rs asserts both)
        names.append((name, base))
        pos += size
    assert len(names) == n_types and (b"BOOL", b"") in names and (b"T_Count", b"UDINT") in names
    assert read(svc, s, IndexGroup.SYM_DT_UPLOAD, 0, type_bytes - 1)[0] == 0x705


def test_data_type_and_location_by_name(svc: AdsService) -> None:
    s = svc.new_session()
    code, raw = rw(svc, s, IndexGroup.SYM_DT_INFOBYNAMEEX, 0, 0xFFFFFFFF, b"lreal\0")
    head, strings = data_type_entry(raw)
    assert code == 0 and head[4:8] == (8, 0, Adst.REAL64, 1) and strings[0] == b"LREAL"
    assert rw(svc, s, IndexGroup.SYM_DT_INFOBYNAMEEX, 0, 0xFFFF, b"ST_Nope\0") == (0x710, b"")
    assert rw(svc, s, IndexGroup.SYM_DT_INFOBYNAMEEX, 0, 10, b"BOOL\0")[0] == 0x705
    # 0xF007 as ads-rs get_location / get_size send it: no NUL, 12 bytes back
    assert rw(svc, s, IndexGroup.SYM_INFOBYNAME, 0, 12, b"Dev.setpoint") == (
        0,
        struct.pack("<III", 0x10, 4, 2),
    )
    assert rw(svc, s, IndexGroup.SYM_INFOBYNAME, 0, 11, b"Dev.setpoint")[0] == 0x705
    assert rw(svc, s, IndexGroup.SYM_INFOBYNAME, 0, 12, b"nope")[0] == 0x710


def test_extended_handle_reply(svc: AdsService) -> None:
    s = svc.new_session()
    code, raw = rw(svc, s, IndexGroup.SYM_HNDBYNAME, 0, 0xFFFFFFFF, b"Dev.setpoint\0")
    handle, size, decoration, n = struct.unpack_from("<IIIH", raw)
    assert (code, size, decoration, raw[14 : 14 + n + 1]) == (0, 2, 0, b"UINT\0")
    assert len(raw) == 14 + n + 1
    assert read(svc, s, IndexGroup.SYM_VALBYHND, handle, 2) == (0, struct.pack("<H", 100))


def test_sum_read_ex_padded_and_compact(svc: AdsService) -> None:
    s = svc.new_session()
    subs = [(0x10, 0, 8), (0x10, 9, 4), (0x10, 4, 2)]
    data = b"".join(struct.pack("<III", *x) for x in subs)
    rlen = 8 * 3 + 14
    code, out = rw(svc, s, IndexGroup.SUMUP_READEX, 3, rlen, data)
    assert code == 0 and len(out) == rlen
    assert struct.unpack_from("<6I", out) == (0, 4, 0x703, 0, 0, 2)
    assert out[24:32] == struct.pack("<I", 7) + bytes(4) and out[36:38] == b"\x64\x00"
    code, out = rw(svc, s, IndexGroup.SUMUP_READEX2, 3, rlen, data)
    assert code == 0 and out[24:] == struct.pack("<I", 7) + b"\x64\x00"
    assert rw(svc, s, IndexGroup.SUMUP_READEX, 3, rlen - 1, data)[0] == 0x705
    assert rw(svc, s, IndexGroup.SUMUP_READEX, 4, 100, data)[0] == 0x705


@pytest.mark.parametrize("entry_bytes", [40, 24])
def test_sum_add_and_delete_notifications(svc: AdsService, entry_bytes: int) -> None:
    s = svc.new_session()
    subs = [(0x10, 0, 4, 4), (0x10, 9, 4, 4), (0x10, 4, 2, 99)]
    data = b"".join(
        struct.pack("<IIIIII", ig, io, n, mode, 0, 10_000) + bytes(entry_bytes - 24)
        for ig, io, n, mode in subs
    )
    code, out = rw(svc, s, IndexGroup.SUMUP_ADDDEVNOTE, 3, 24, data)
    results = struct.unpack("<6I", out)
    assert code == 0 and results[0] == 0 and results[1] > 0  # (result, handle) each
    assert results[2:] == (0x703, 0, 0x713, 0)
    assert len(s.notifications) == 1
    handles = struct.pack("<II", results[1], 999)
    code, out = rw(svc, s, IndexGroup.SUMUP_DELDEVNOTE, 2, 8, handles)
    assert (code, struct.unpack("<II", out)) == (0, (0, 0x714))
    assert len(s.notifications) == 0
    assert rw(svc, s, IndexGroup.SUMUP_ADDDEVNOTE, 3, 24, data[:-1])[0] == 0x705


def test_device_data_follows_the_state(svc: AdsService) -> None:
    s = svc.new_session()
    assert read(svc, s, IndexGroup.DEVICE_DATA, 0, 4) == (0, struct.pack("<HH", 5, 0))
    assert read(svc, s, IndexGroup.DEVICE_DATA, 2, 2) == (0, bytes(2))
    assert read(svc, s, IndexGroup.DEVICE_DATA, 1, 4)[0] == 0x703
