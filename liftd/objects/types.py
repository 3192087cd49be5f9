"""CNC data types (the ISG type strings of the object tables) ↔ bytes and PLC symbol types."""

from __future__ import annotations

import struct
from dataclasses import dataclass

from liftd.ads.constants import AdsErr, Adst
from liftd.ads.errors import AdsError
from liftd.ads.symbols import DataType


@dataclass(frozen=True, slots=True)
class CncType:
    # type string of the +0x200 attribute (docs/reference/isg-cnc.md §1.4): BOOLEAN, UNS32, …
    isg: str
    plc: str  # IEC type of the symbol entry, mapped to a ctype by pyads: BOOL, UDINT, …
    adst: Adst
    fmt: struct.Struct

    @property
    def size(self) -> int:
        return self.fmt.size

    def pack(self, value: float | int | bool) -> bytes:
        if self.fmt.format[-1] in "fd":
            return self.fmt.pack(float(value))
        return self.fmt.pack(int(value))

    def data_type(self) -> DataType:
        """The ISG type name as an alias of its IEC type, for the data-type upload (0xF00E)."""
        return DataType(self.isg, self.size, self.adst, self.plc, "ISG CNC object type")

    def unpack(self, data: bytes) -> float | int:
        """A written value; the length must be exact (0x705)."""
        if len(data) != self.fmt.size:
            raise AdsError(AdsErr.INVALIDSIZE, f"{self.isg} takes {self.fmt.size} bytes")
        value: float | int = self.fmt.unpack(data)[0]
        return value


BOOLEAN = CncType("BOOLEAN", "BOOL", Adst.BIT, struct.Struct("<B"))
UNS16 = CncType("UNS16", "UINT", Adst.UINT16, struct.Struct("<H"))
UNS32 = CncType("UNS32", "UDINT", Adst.UINT32, struct.Struct("<I"))
SGN32 = CncType("SGN32", "DINT", Adst.INT32, struct.Struct("<i"))
UNS64 = CncType("UNS64", "ULINT", Adst.UINT64, struct.Struct("<Q"))
REAL64 = CncType("REAL64", "LREAL", Adst.REAL64, struct.Struct("<d"))

CNC_TYPES: tuple[DataType, ...] = tuple(
    t.data_type() for t in (BOOLEAN, UNS16, UNS32, SGN32, UNS64, REAL64)
)
