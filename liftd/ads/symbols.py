"""TwinCAT 3 symbol-server records: data-type entries, the upload info and the extended handle
reply. Pure codec: bytes only, no provider, no clock.

Layouts (little-endian), each checked against two independent client parsers:

* AdsDatatypeEntry (0xF00E upload, 0xF011 by name): u32 entryLength (counting itself),
  version = 1, hashValue, typeHashValue, size, offset, ADST data type, flags; u16 nameLength,
  typeLength, commentLength, arrayDim, subItems; name, type and comment each NUL-terminated.
  Sources: jisotalo/ads-client 2.1.0 `src/ads-client.ts` parseAdsResponseDataType; birkenfeld/
  ads-rs `src/symbol.rs` decode_type_info (rejects version ≠ 1, reads the two hashes as
  u16 + u16 + u32, requires offset 0 for a top-level type).
* Upload info 2/3 (0xF00F): ads-client reads 8 / 24 / 64 bytes as version 1 / 2 / 3 (symbol
  count and bytes, data-type count and bytes, max and used dynamic symbols, invalid dynamic
  symbols, encoding code page, flags, 28 reserved); ads-rs `get_symbol_info` asks 64 and needs
  exactly 64 (`read_exact`).
* Extended handle (0xF003 with a read length that can hold it): u32 handle, u32 size, u32 type
  decoration, u16 type-name length, type name NUL (ads-client `createVariableHandle`, which asks
  0xFFFFFFFF, and `createVariableHandleMulti`, which asks 0xFFFF per sub-command).
"""

from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass

from liftd.ads.constants import Adst

DATA_TYPE_HEAD = struct.Struct("<IIIIIIIIHHHHH")  # entryLength … subItems (42 B)
UPLOAD_INFO = struct.Struct("<IIIIIIIII28s")  # 64 B (ads-client readPlcUploadInfo, version 3)
EXTENDED_HANDLE = struct.Struct("<IIIH")
DATATYPE_FLAG = 0x0000_0001  # ADSDATATYPEFLAG_DATATYPE (ads-client ADS_DATA_TYPE_FLAGS)
UPLOAD_INCLUDES_BASE_TYPES = 0x2  # ADS_UPLOAD_INFO_FLAGS.IncludesBaseTypes (ads-client)
CODE_PAGE_CP1252 = 1252  # ads-client decodes symbol strings as UTF-8 only for 65001


@dataclass(frozen=True, slots=True)
class DataType:
    """A type a client can resolve by name: a base type (`base` empty) or an alias of one."""

    name: str
    size: int
    adst: Adst
    base: str = ""  # the type this one is an alias of ("" for a base type)
    comment: str = ""

    def entry(self, encoding: str) -> bytes:
        name, base, comment = (
            s.encode(encoding, "replace") for s in (self.name, self.base, self.comment)
        )
        strings = name + b"\0" + base + b"\0" + comment + b"\0"
        head = DATA_TYPE_HEAD.pack(
            DATA_TYPE_HEAD.size + len(strings),
            1,
            type_hash(self.name),
            type_hash(self.base),
            self.size,
            0,
            int(self.adst),
            DATATYPE_FLAG,
            len(name),
            len(base),
            len(comment),
            0,
            0,
        )
        return head + strings


def type_hash(name: str) -> int:
    """A stable 32-bit hash of a type name (TwinCAT's own hash is undocumented; clients only
    compare it for equality), 0 for no type."""
    return zlib.crc32(name.lower().encode()) if name else 0


# IEC 61131-3 elementary types as TwinCAT 3 serves them (ADST ids: AdsLib AdsDef.h ADST_*;
# BOOL is ADST_BIT, as TwinCAT reports it and pyads/ads-client map it).
BASE_TYPES: tuple[DataType, ...] = tuple(
    DataType(name, size, adst)
    for name, size, adst in (
        ("BOOL", 1, Adst.BIT),
        ("BYTE", 1, Adst.UINT8),
        ("SINT", 1, Adst.INT8),
        ("USINT", 1, Adst.UINT8),
        ("WORD", 2, Adst.UINT16),
        ("INT", 2, Adst.INT16),
        ("UINT", 2, Adst.UINT16),
        ("DWORD", 4, Adst.UINT32),
        ("DINT", 4, Adst.INT32),
        ("UDINT", 4, Adst.UINT32),
        ("LWORD", 8, Adst.UINT64),
        ("LINT", 8, Adst.INT64),
        ("ULINT", 8, Adst.UINT64),
        ("REAL", 4, Adst.REAL32),
        ("LREAL", 8, Adst.REAL64),
        ("TIME", 4, Adst.UINT32),
        ("LTIME", 8, Adst.UINT64),
        ("STRING(80)", 81, Adst.STRING),
    )
)


def upload_info(symbols: int, symbol_bytes: int, types: int, type_bytes: int) -> bytes:
    """The 64-byte upload info (version 3); a client that asks fewer bytes gets the head."""
    return UPLOAD_INFO.pack(
        symbols,
        symbol_bytes,
        types,
        type_bytes,
        0,
        0,
        0,
        CODE_PAGE_CP1252,
        UPLOAD_INCLUDES_BASE_TYPES,
        bytes(28),
    )


def extended_handle(handle: int, size: int, type_name: bytes) -> bytes:
    return EXTENDED_HANDLE.pack(handle, size, 0, len(type_name)) + type_name + b"\0"
