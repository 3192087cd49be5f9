"""ADS services over an `ObjectProvider`: one dispatch table per command and per reserved index
group, sum commands, symbol handles and notifications per connection. Pure (no IO, no clock:
`now_ns` is passed in); the one place where an exception becomes an ADS result code, so every
request gets an answer (reference/ads.md §0.4, style-anchors rule 3).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from functools import partial
from typing import NamedTuple

from liftd.ads import sums, symbols, wire
from liftd.ads.constants import SUM_GROUPS, AdsErr, Command, IndexGroup
from liftd.ads.device import (
    ENCODING,
    STATIC_HANDLE_BIT,
    DeviceInfo,
    ObjectProvider,
    ServiceLimits,
    Session,
    Symbol,
    error_payload,
)
from liftd.ads.errors import AdsError
from liftd.ads.notifications import AmsAddr, NotificationTable
from liftd.ads.symbols import DataType
from liftd.ads.wire import AddNotificationRequest, AmsHeader, ReadWriteRequest

__all__ = [  # the seam's declarations live in device.py; importable from here as before
    "ENCODING", "STATIC_HANDLE_BIT", "AdsService", "DeviceInfo", "ObjectProvider", "Reply",
    "ServiceLimits", "Session", "Symbol", "error_payload",
]  # fmt: skip


class Context(NamedTuple):
    """What a ReadWrite handler may need beyond the request: the request's header (addresses
    for notifications), write access, and the time."""

    header: AmsHeader
    may_write: bool
    now_ns: int


RwHandler = Callable[["Session", ReadWriteRequest, Context], bytes]


class Reply(NamedTuple):
    payload: bytes
    failure: BaseException | None = None  # an unexpected exception answered with 0x700


class AdsService:
    def __init__(
        self, provider: ObjectProvider, limits: ServiceLimits, device: DeviceInfo | None = None
    ) -> None:
        self.provider = provider
        self.limits = limits
        self.device = device or DeviceInfo()
        self._upload: tuple[int, bytes, bytes, dict[str, DataType]] | None = None
        self.commands: Mapping[int, Callable[[Session, AmsHeader, bytes, bool, int], bytes]] = {
            Command.READ_DEVICE_INFO: self._device_info,
            Command.READ: self._cmd_read,
            Command.WRITE: self._cmd_write,
            Command.READ_STATE: self._cmd_state,
            Command.WRITE_CONTROL: self._cmd_write_control,
            Command.ADD_NOTIFICATION: self._cmd_add_notification,
            Command.DEL_NOTIFICATION: self._cmd_del_notification,
            Command.READ_WRITE: self._cmd_read_write,
        }
        self.read_groups: Mapping[int, Callable[[Session, int, int], bytes]] = {
            IndexGroup.SYM_VALBYHND: self._read_by_handle,
            IndexGroup.SYM_VERSION: self._sym_version,
            IndexGroup.SYM_UPLOAD: self._sym_upload,
            IndexGroup.SYM_UPLOADINFO: self._sym_upload_info,
            IndexGroup.SYM_UPLOADINFO2: self._sym_upload_info2,
            IndexGroup.SYM_DT_UPLOAD: self._dt_upload,
            IndexGroup.DEVICE_DATA: self._device_data,
        }
        self.write_groups: Mapping[int, Callable[[Session, int, bytes], None]] = {
            IndexGroup.SYM_VALBYHND: self._write_by_handle,
            IndexGroup.SYM_RELEASEHND: self._release_handle,
        }
        self.read_write_groups: Mapping[int, RwHandler] = {
            IndexGroup.SYM_HNDBYNAME: self._handle_by_name,
            IndexGroup.SYM_VALBYNAME: self._value_by_name,
            IndexGroup.SYM_INFOBYNAMEEX: self._info_by_name,
            IndexGroup.SYM_INFOBYNAME: self._location_by_name,
            IndexGroup.SYM_DT_INFOBYNAMEEX: self._data_type_by_name,
            IndexGroup.SUMUP_READ: self._sum_read,
            IndexGroup.SUMUP_WRITE: self._sum_write,
            IndexGroup.SUMUP_READWRITE: self._sum_read_write,
            IndexGroup.SUMUP_READEX: self._sum_read_ex,
            IndexGroup.SUMUP_READEX2: self._sum_read_ex2,
            IndexGroup.SUMUP_ADDDEVNOTE: self._sum_add_notifications,
            IndexGroup.SUMUP_DELDEVNOTE: self._sum_delete_notifications,
        }

    def new_session(self) -> Session:
        lim = self.limits
        return Session(
            NotificationTable(
                lim.max_notifications,
                lim.min_notification_cycle_ns,
                lim.max_notification_length,
                lim.max_notification_payload,
            )
        )

    # -- the boundary -------------------------------------------------------------------------
    def handle(
        self, session: Session, header: AmsHeader, payload: bytes, may_write: bool, now_ns: int
    ) -> Reply:
        """Answer one request (the caller has checked the address and that the command is
        1..9 but 8). Never raises."""
        try:
            out = self.commands[header.command](session, header, payload, may_write, now_ns)
            if len(out) > self.limits.max_reply_payload:  # checked before building where
                raise AdsError(AdsErr.NOMEMORY, f"a reply of {len(out)} bytes")  # it can grow
            return Reply(out)
        except AdsError as exc:
            return Reply(error_payload(header.command, exc.code))
        except Exception as exc:  # a bug: answer 0x700 (the client must not time out) and report
            return Reply(error_payload(header.command, AdsErr.DEVICE_ERROR), exc)

    def rejected(self, command: int, code: int) -> bytes:
        """The payload answering `command` with `code` (e.g. 0x723 for an unknown source)."""
        return error_payload(command, code)

    # -- commands ---------------------------------------------------------------------------------
    def _device_info(self, s: Session, h: AmsHeader, p: bytes, w: bool, now: int) -> bytes:
        d = self.device
        return wire.device_info_response(0, d.major, d.minor, d.build, d.name.encode(ENCODING))

    def _cmd_state(self, s: Session, h: AmsHeader, p: bytes, w: bool, now: int) -> bytes:
        ads_state, device_state = self.provider.ads_state()
        return wire.state_response(0, ads_state, device_state)

    def _cmd_read(self, s: Session, h: AmsHeader, p: bytes, w: bool, now: int) -> bytes:
        req = wire.decode_read(p)
        data = self.read(s, req.index_group, req.index_offset, req.length)
        if len(data) > req.length:  # never more than asked for (pyads#186: "Frame too long")
            raise AdsError(AdsErr.INVALIDSIZE, f"{len(data)} bytes do not fit {req.length}")
        return wire.read_response(0, data)

    def _cmd_write(self, s: Session, h: AmsHeader, p: bytes, may_write: bool, now: int) -> bytes:
        req = wire.decode_write(p)
        self.write(s, req.index_group, req.index_offset, req.data, may_write)
        return wire.result_only(0)

    def _cmd_read_write(
        self, s: Session, h: AmsHeader, p: bytes, may_write: bool, now: int
    ) -> bytes:
        req = wire.decode_read_write(p)
        data = self.read_write(s, req, Context(h, may_write, now))
        if len(data) > req.read_length:
            raise AdsError(AdsErr.INVALIDSIZE, f"{len(data)} bytes do not fit {req.read_length}")
        return wire.read_response(0, data)

    def _cmd_write_control(
        self, s: Session, h: AmsHeader, p: bytes, may_write: bool, now: int
    ) -> bytes:
        req = wire.decode_write_control(p)
        if not may_write:
            raise AdsError(AdsErr.INVALIDACCESS, "WriteControl needs write access")
        self.provider.write_control(req.ads_state, req.device_state, req.data)
        return wire.result_only(0)

    def _cmd_add_notification(self, s: Session, h: AmsHeader, p: bytes, w: bool, now: int) -> bytes:
        handle = self._add_notification(s, h, wire.decode_add_notification(p), now)
        return wire.add_notification_response(0, handle)

    def _add_notification(
        self, s: Session, h: AmsHeader, req: AddNotificationRequest, now: int
    ) -> int:
        if req.index_group in SUM_GROUPS:
            raise AdsError(AdsErr.SRVNOTSUPP, "notification on a sum command")
        size = None  # what a sample will carry, when the object says (notifications.py)
        try:  # the object must exist; a device not ready yet is fine
            size = len(self.read(s, req.index_group, req.index_offset, req.length))
        except AdsError as exc:
            if exc.code != AdsErr.NOTREADY:
                raise
        client = AmsAddr(h.source_net_id, h.source_port)
        server = AmsAddr(h.target_net_id, h.target_port)
        return s.notifications.add(req, client, server, now, size)

    def _cmd_del_notification(self, s: Session, h: AmsHeader, p: bytes, w: bool, now: int) -> bytes:
        s.notifications.delete(wire.decode_del_notification(p))
        return wire.result_only(0)

    # -- routing by index group (also used by sum commands and notifications) ----------------------
    def read(self, s: Session, ig: int, io: int, length: int) -> bytes:
        handler = self.read_groups.get(ig)
        if handler is not None:
            return handler(s, io, length)
        if ig in self.read_write_groups or ig in self.write_groups:
            raise AdsError(AdsErr.SRVNOTSUPP, f"index group 0x{ig:X} is not read with Read")
        return self.provider.read(ig, io, length)

    def write(self, s: Session, ig: int, io: int, data: bytes, may_write: bool) -> None:
        handler = self.write_groups.get(ig)
        if handler is not None and ig == IndexGroup.SYM_RELEASEHND:
            handler(s, io, data)  # releasing a handle changes nothing on the device
            return
        if not may_write:
            raise AdsError(AdsErr.INVALIDACCESS, "this source has no write access")
        if handler is not None:
            handler(s, io, data)
            return
        if ig in self.read_groups or ig in self.read_write_groups:
            raise AdsError(AdsErr.SRVNOTSUPP, f"index group 0x{ig:X} is not written with Write")
        self.provider.write(ig, io, data)

    def read_write(self, s: Session, req: ReadWriteRequest, ctx: Context) -> bytes:
        handler = self.read_write_groups.get(req.index_group)
        if handler is not None:
            return handler(s, req, ctx)
        return self.provider.read_write(
            req.index_group, req.index_offset, req.read_length, req.data
        )

    # -- symbols -----------------------------------------------------------------------------------
    def _symbol_of_handle(self, s: Session, handle: int) -> Symbol | None:
        """A connection's handle, or None for a static symbol address (provider's business)."""
        if handle & STATIC_HANDLE_BIT:
            return None
        sym = s.handles.get(handle)
        if sym is None:
            raise AdsError(AdsErr.SYMBOLNOTFOUND, f"symbol handle {handle}")
        return sym

    def _read_by_handle(self, s: Session, io: int, length: int) -> bytes:
        sym = self._symbol_of_handle(s, io)
        if sym is None:
            return self.provider.read(IndexGroup.SYM_VALBYHND, io, length)
        return self.read(s, sym.index_group, sym.index_offset, length)

    def _write_by_handle(self, s: Session, io: int, data: bytes) -> None:
        sym = self._symbol_of_handle(s, io)
        if sym is None:
            self.provider.write(IndexGroup.SYM_VALBYHND, io, data)
        elif not sym.writable:
            raise AdsError(AdsErr.INVALIDACCESS, f"{sym.name} is read-only")
        else:
            self.provider.write(sym.index_group, sym.index_offset, data)

    def _release_handle(self, s: Session, io: int, data: bytes) -> None:
        if len(data) != 4:
            raise AdsError(AdsErr.INVALIDSIZE, "release handle: 4 bytes expected")
        handle = int.from_bytes(data, "little")
        if s.handles.pop(handle, None) is None:
            raise AdsError(AdsErr.SYMBOLNOTFOUND, f"symbol handle {handle}")

    def _find(self, raw: bytes) -> Symbol:
        return self.provider.find_symbol(raw.split(b"\0", 1)[0].decode(ENCODING, "replace"))

    def _handle_by_name(self, s: Session, req: ReadWriteRequest, ctx: Context) -> bytes:
        if req.read_length < 4:
            raise AdsError(AdsErr.INVALIDSIZE, "a handle needs 4 bytes")
        sym = self._find(req.data)
        if len(s.handles) >= self.limits.max_handles:
            raise AdsError(AdsErr.NOMOREHDLS, f"{self.limits.max_handles} handles per connection")
        handle = s.next_handle
        while handle in s.handles or handle == 0 or handle & STATIC_HANDLE_BIT:
            handle = (handle + 1) % STATIC_HANDLE_BIT
        s.next_handle = (handle + 1) % STATIC_HANDLE_BIT
        s.handles[handle] = sym
        # TwinCAT 3 answers a read length that can hold it with handle, size and type
        # (ads-client createVariableHandle asks 0xFFFFFFFF); pyads asks 4, gets 4
        extended = symbols.extended_handle(handle, sym.size, sym.type_name.encode(ENCODING))
        return extended if req.read_length >= len(extended) else handle.to_bytes(4, "little")

    def _value_by_name(self, s: Session, req: ReadWriteRequest, ctx: Context) -> bytes:
        sym = self._find(req.data)
        return self.read(s, sym.index_group, sym.index_offset, req.read_length)

    def _info_by_name(self, s: Session, req: ReadWriteRequest, ctx: Context) -> bytes:
        return self._whole(self._find(req.data).entry(), req.read_length, "symbol entry")

    def _tables(self) -> tuple[int, bytes, bytes, dict[str, DataType]]:
        """(version, symbol upload, data-type upload, types by lower-case name), rebuilt when
        the provider's symbol version changes."""
        version = self.provider.symbol_version
        if self._upload is None or self._upload[0] != version:
            entries = b"".join(sym.entry() for sym in self.provider.symbols())
            types = {t.name.lower(): t for t in (*symbols.BASE_TYPES, *self.provider.data_types())}
            type_entries = b"".join(t.entry(ENCODING) for t in types.values())
            self._upload = (version, entries, type_entries, types)
        return self._upload

    @staticmethod
    def _whole(data: bytes, length: int, what: str) -> bytes:
        if length < len(data):
            raise AdsError(AdsErr.INVALIDSIZE, f"the {what} needs {len(data)} bytes")
        return data

    def _sym_upload(self, s: Session, io: int, length: int) -> bytes:
        return self._whole(self._tables()[1], length, "symbol upload")

    def _dt_upload(self, s: Session, io: int, length: int) -> bytes:
        return self._whole(self._tables()[2], length, "data-type upload")

    def _sym_upload_info(self, s: Session, io: int, length: int) -> bytes:
        return self._sym_upload_info2(s, io, min(length, 8))

    def _sym_upload_info2(self, s: Session, io: int, length: int) -> bytes:
        _, entries, type_entries, types = self._tables()
        info = symbols.upload_info(len(self.provider.symbols()), len(entries), len(types),
                                   len(type_entries))  # fmt: skip
        return info[:length]

    def _data_type_by_name(self, s: Session, req: ReadWriteRequest, ctx: Context) -> bytes:
        name = req.data.split(b"\0", 1)[0].decode(ENCODING, "replace").strip().lower()
        dt = self._tables()[3].get(name)
        if dt is None:  # ads-client falls back to its own base types on exactly 0x710
            raise AdsError(AdsErr.SYMBOLNOTFOUND, f"data type {name!r}")
        return self._whole(dt.entry(ENCODING), req.read_length, "data-type entry")

    def _location_by_name(self, s: Session, req: ReadWriteRequest, ctx: Context) -> bytes:
        """0xF007: IG, IO and size of a symbol, 12 bytes (birkenfeld/ads-rs `src/symbol.rs`
        get_location / get_size read exactly these, the name sent without a NUL)."""
        sym = self._find(req.data)
        return self._whole(wire.U32X3.pack(sym.index_group, sym.index_offset, sym.size),
                           req.read_length, "symbol location")  # fmt: skip

    def _device_data(self, s: Session, io: int, length: int) -> bytes:
        """0xF100: IO 0 → ADS state u16 + device state u16, IO 2 → device state (ads.md §3;
        ads-client subscribes to (0xF100, 0, 4) to follow the runtime state)."""
        state = wire.U16X2.pack(*self.provider.ads_state())
        if io not in (0, 2):
            raise AdsError(AdsErr.INVALIDOFFSET, f"device data offset {io}")
        return self._whole(state[io:], length, "device state")[:length]

    def _sym_version(self, s: Session, io: int, length: int) -> bytes:
        return bytes([self.provider.symbol_version & 0xFF])[:length]

    # -- sum commands (liftd/ads/sums.py has the layouts) -------------------------------------
    @property
    def _reply_cap(self) -> int:
        """The data a ReadWrite reply may carry (its payload less result and length)."""
        return self.limits.max_reply_payload - 8

    def _sum_read(self, s: Session, req: ReadWriteRequest, ctx: Context) -> bytes:
        limit = self.limits.max_sum_subcommands
        return sums.sum_read(req, limit, partial(self.read, s), self._reply_cap)

    def _sum_read_ex(self, s: Session, req: ReadWriteRequest, ctx: Context) -> bytes:
        limit = self.limits.max_sum_subcommands
        return sums.sum_read_ex(req, limit, partial(self.read, s), True, self._reply_cap)

    def _sum_read_ex2(self, s: Session, req: ReadWriteRequest, ctx: Context) -> bytes:
        limit = self.limits.max_sum_subcommands
        return sums.sum_read_ex(req, limit, partial(self.read, s), False, self._reply_cap)

    def _sum_write(self, s: Session, req: ReadWriteRequest, ctx: Context) -> bytes:
        def write(ig: int, io: int, data: bytes) -> None:
            self.write(s, ig, io, data, ctx.may_write)

        return sums.sum_write(req, self.limits.max_sum_subcommands, write)

    def _sum_read_write(self, s: Session, req: ReadWriteRequest, ctx: Context) -> bytes:
        def read_write(sub: ReadWriteRequest) -> bytes:
            return self.read_write(s, sub, ctx)

        limit = self.limits.max_sum_subcommands
        return sums.sum_read_write(req, limit, read_write, self._reply_cap)

    def _sum_add_notifications(self, s: Session, req: ReadWriteRequest, ctx: Context) -> bytes:
        def add(sub: AddNotificationRequest) -> int:
            return self._add_notification(s, ctx.header, sub, ctx.now_ns)

        return sums.sum_add_notifications(req, self.limits.max_sum_subcommands, add)

    def _sum_delete_notifications(self, s: Session, req: ReadWriteRequest, ctx: Context) -> bytes:
        limit = self.limits.max_sum_subcommands
        return sums.sum_delete_notifications(req, limit, s.notifications.delete)
