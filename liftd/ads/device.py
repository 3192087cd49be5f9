"""What the device behind an AMS port offers (`ObjectProvider`), the symbols it names, what one
connection owns (`Session`), the service limits, and the error payload of each command. Pure
declarations shared by the service (service.py), the system port (system.py) and providers
(liftd/objects).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol

from liftd.ads import wire
from liftd.ads.constants import Adst, Command, SymbolFlag
from liftd.ads.notifications import NotificationTable
from liftd.ads.symbols import DataType

STATIC_HANDLE_BIT = 0x8000_0000  # 0xF005 offsets with this bit: a symbol's fixed address
ENCODING = "cp1252"  # CNC strings (TF5200 "ADS access to CNC", isg-cnc.md §1.1)


@dataclass(frozen=True, slots=True)
class Symbol:
    """A name a client can resolve (0xF003, 0xF009) and the address its value lives at."""

    name: str
    index_group: int
    index_offset: int
    size: int
    data_type: Adst
    type_name: str  # PLC type string, e.g. BOOL, UDINT, LREAL (pyads maps it to a ctype)
    comment: str = ""
    writable: bool = False

    def entry(self) -> bytes:
        flags = 0 if self.writable else int(SymbolFlag.READONLY)
        return wire.encode_symbol_entry(
            wire.SymbolEntry(
                self.index_group,
                self.index_offset,
                self.size,
                int(self.data_type),
                flags,
                self.name.encode(ENCODING, "replace"),
                self.type_name.encode(ENCODING, "replace"),
                self.comment.encode(ENCODING, "replace"),
            )
        )


class ObjectProvider(Protocol):
    """What the device behind the port offers. Every method raises AdsError with its code."""

    symbol_version: int  # changes when the symbol table changes (0xF008)

    def read(self, index_group: int, index_offset: int, length: int) -> bytes: ...

    def write(self, index_group: int, index_offset: int, data: bytes) -> None: ...

    def read_write(
        self, index_group: int, index_offset: int, read_length: int, data: bytes
    ) -> bytes: ...

    def find_symbol(self, name: str) -> Symbol: ...

    def symbols(self) -> Sequence[Symbol]: ...

    def data_types(self) -> Sequence[DataType]: ...  # the device's own, beside the base types

    def ads_state(self) -> tuple[int, int]: ...

    def write_control(self, ads_state: int, device_state: int, data: bytes) -> None: ...


@dataclass(frozen=True, slots=True)
class ServiceLimits:
    max_sum_subcommands: int = 1000
    max_handles: int = 1024
    max_notifications: int = 512
    min_notification_cycle_ns: int = 1_000_000
    max_notification_length: int = 65536
    max_notification_payload: int = 256 * 1024
    # the AMS data of one reply (a frame's AMS/TCP length less the 32-byte AMS header): a reply
    # that would be larger is answered 0x70A instead (`max_frame_bytes` of the server)
    max_reply_payload: int = (1 << 20) - 32


@dataclass(frozen=True, slots=True)
class DeviceInfo:
    name: str = "liftd GEO"
    major: int = 0
    minor: int = 1
    build: int = 0


@dataclass(slots=True)
class Session:
    """What one connection owns; freed with it."""

    notifications: NotificationTable
    handles: dict[int, Symbol] = field(default_factory=dict)
    next_handle: int = 1


def error_payload(command: int, code: int) -> bytes:
    """The payload answering `command` with the error `code` (its layout per command)."""
    if command in (Command.READ, Command.READ_WRITE):
        return wire.read_response(code)
    if command == Command.ADD_NOTIFICATION:
        return wire.add_notification_response(code, 0)
    if command == Command.READ_STATE:
        return wire.state_response(code, 0, 0)
    if command == Command.READ_DEVICE_INFO:
        return wire.device_info_response(code, 0, 0, 0, b"")
    return wire.result_only(code)
