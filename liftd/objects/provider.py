"""The GEO port's `ObjectProvider`: CNC objects and symbols read from the latest published
cycle; PLC inputs handed to the GEO loop. Pure: the snapshot source and the input sink are
injected (the runtime's shared memory and queue, or a test's).

Error codes (isg-cnc.md §1.5, the inference liftd follows): unknown class or channel → 0x702,
unknown element or axis → 0x703, buffer shorter than the object → 0x705, write to a read-only
object → 0x704, value out of range → 0x706, GEO task not running → 0x707 (ReadState then says
STOP or ERROR), input queue full → 0x708 (from the sink).
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Sequence

from liftd.ads.constants import AdsErr, AdsState, IndexGroup
from liftd.ads.device import ENCODING, STATIC_HANDLE_BIT, Symbol
from liftd.ads.errors import AdsError
from liftd.ads.symbols import DataType
from liftd.cnc import units
from liftd.cnc.plc import MAX_OVERRIDE
from liftd.cnc.snapshot import PlcSignal, PlcWrite
from liftd.objects.catalog import (
    ADDRESS,
    ATTRIBUTE_FIELD,
    DATA,
    LENGTH,
    NAME,
    TYPE,
    UNIT,
    WRITE_FLAG,
    Catalog,
    CncObject,
    GeoView,
    normalise,
)
from liftd.objects.types import CNC_TYPES

Source = Callable[[], GeoView | None]  # None: the GEO task is not running
Sink = Callable[[PlcWrite], None]  # raises AdsError(BUSY) when the input queue is full
# the override a PLC may write, in the ISG unit (0.1 %): the core's MAX_OVERRIDE (200 %)
MAX_OVERRIDE_PERMILLE = units.fraction_to_isg_permille(MAX_OVERRIDE)
NO_INSTANCE = struct.pack("<II", 0, 0)  # the object address of a channel or axis not there


class CncProvider:
    def __init__(self, catalog: Catalog, source: Source, sink: Sink) -> None:
        self.catalog = catalog
        self.source = source
        self.sink = sink
        self.symbol_version = 1
        self.down_state = AdsState.STOP  # reported while the GEO task is not running
        # the levels the PLC wrote (override in 0.1 %, feed hold), read back as written, as
        # from the CNC's HLI memory: the loop takes a write a cycle or two later, and a PLC
        # that checks its write by reading it back must not see the old value meanwhile
        self.levels: dict[tuple[int, PlcSignal], int] = {}

    # -- addressing --------------------------------------------------------------------------------
    def _locate(self, ig: int, io: int) -> tuple[CncObject, int]:
        attribute = ig & ATTRIBUTE_FIELD
        table = self.catalog.by_group.get((ig & ~ATTRIBUTE_FIELD) | DATA)
        if table is None or not DATA <= attribute <= ADDRESS:
            raise AdsError(AdsErr.INVALIDGRP, f"index group 0x{ig:X}")
        obj = table.get(io)
        if obj is None:
            raise AdsError(AdsErr.INVALIDOFFSET, f"index offset 0x{io:X} in 0x{ig:X}")
        return obj, attribute

    def _static(self, io: int) -> CncObject:
        obj = self.catalog.static.get(io)
        if obj is None:
            raise AdsError(AdsErr.SYMBOLNOTFOUND, f"symbol handle 0x{io:X}")
        return obj

    def _view(self) -> GeoView:
        view = self.source()
        if view is None:
            raise AdsError(AdsErr.NOTREADY, "the GEO task is not running")
        return view

    def _value(self, obj: CncObject, length: int) -> bytes:
        if length < obj.type.size:
            raise AdsError(AdsErr.INVALIDSIZE, f"{obj.symbol} has {obj.type.size} bytes")
        view = self._view()
        if obj.signal is not None:
            written = self.levels.get((obj.channel, obj.signal))
            if written is not None:
                return obj.type.pack(written)
        return obj.type.pack(obj.get(view))

    # -- ObjectProvider ---------------------------------------------------------------------------
    def read(self, index_group: int, index_offset: int, length: int) -> bytes:
        if index_group == IndexGroup.SYM_VALBYHND:
            return self._value(self._static(index_offset), length)
        obj, attribute = self._locate(index_group, index_offset)
        if attribute == DATA:
            return self._value(obj, length)
        if attribute == ADDRESS:
            return self._address(index_group, obj, length)
        if attribute in (LENGTH, WRITE_FLAG):
            value = struct.pack("<I", obj.type.size) if attribute == LENGTH else bytes([0])
            if length < len(value):
                raise AdsError(AdsErr.INVALIDSIZE, "attribute buffer too short")
            return value
        text = {NAME: obj.name, TYPE: obj.type.isg, UNIT: obj.unit}[attribute]
        return (text.encode(ENCODING, "replace") + b"\0")[:length]

    def _address(self, ig: int, obj: CncObject, length: int) -> bytes:
        if length < 8:
            raise AdsError(AdsErr.INVALIDSIZE, "an object address is IG + IO, 8 bytes")
        data_ig = (ig & ~ATTRIBUTE_FIELD) | DATA
        logical = data_ig == self.catalog.ig_logicals[obj.channel]
        io = obj.index_offset if logical else obj.index_offset_index
        return struct.pack("<II", data_ig, io or 0)

    def write(self, index_group: int, index_offset: int, data: bytes) -> None:
        if index_group == IndexGroup.SYM_VALBYHND:
            obj = self._static(index_offset)
        else:
            obj, _ = self._locate(index_group, index_offset)
        if obj.signal is None:
            raise AdsError(AdsErr.INVALIDACCESS, f"{obj.symbol} is read-only")
        self._submit(obj.signal, obj.type.unpack(data), obj.channel)

    def write_symbol(self, name: str, raw: bool | int) -> None:
        """A write by symbol name (the live view's control), down the same path as an ADS write
        of that symbol: the same checks and errors, the same input for the GEO loop. A BOOL takes
        true/false, a number an integer in its ADS unit (0x706 otherwise)."""
        obj = self.catalog.object_of.get(normalise(name))
        if obj is None:
            raise AdsError(AdsErr.SYMBOLNOTFOUND, f"symbol {name!r}")
        if obj.signal is None:
            raise AdsError(AdsErr.INVALIDACCESS, f"{obj.symbol} is read-only")
        if isinstance(raw, bool) != (obj.type.isg == "BOOLEAN"):
            kind = "true or false" if obj.type.isg == "BOOLEAN" else "an integer"
            raise AdsError(AdsErr.INVALIDDATA, f"{obj.symbol} takes {kind}")
        self._submit(obj.signal, int(raw), obj.channel)

    def _submit(self, signal: PlcSignal, raw: float | int, channel: int) -> None:
        """A PLC write for channel `channel` (machine index) into the GEO loop's inputs."""
        if signal is PlcSignal.OVERRIDE:
            if not 0 <= raw <= MAX_OVERRIDE_PERMILLE:
                raise AdsError(
                    AdsErr.INVALIDDATA, f"override {raw} (0..{MAX_OVERRIDE_PERMILLE} × 0.1 %)"
                )
            self.sink(PlcWrite(signal, units.isg_permille_to_fraction(int(raw)), channel))
            self.levels[(channel, signal)] = int(raw)
            return
        if raw not in (0, 1):
            raise AdsError(AdsErr.INVALIDDATA, f"BOOL value {raw}")
        if signal is PlcSignal.FEED_HOLD:
            self.sink(PlcWrite(signal, float(raw), channel))
            self.levels[(channel, signal)] = int(raw)
        elif raw:  # commands and the acknowledge act on TRUE; FALSE does nothing
            self.sink(PlcWrite(signal, 1.0, channel))

    def read_write(
        self, index_group: int, index_offset: int, read_length: int, data: bytes
    ) -> bytes:
        """Only the object-address attribute (+0x600): in = channel u32 + axis u32 (axis 0 for a
        channel object), out = IG u32 + IO u32 of that element, in the addressing of the group
        asked: logical (axis = logical axis number) or index based (axis = position in the
        channel). TF5200 "Administration, IndexGroup/Offset address" (infosys
        1031/hmiviaads/15685565323: 0x23900 with (1, 0) → 0x23301; 1033/
        tf5200_ads_access_to_cnc/312768779: 0x123900 with (1, 0) → 0x123301)."""
        obj, attribute = self._locate(index_group, index_offset)
        if attribute != ADDRESS:
            raise AdsError(AdsErr.SRVNOTSUPP, "ReadWrite serves only the object address")
        if len(data) != 8 or read_length < 8:
            raise AdsError(AdsErr.INVALIDSIZE, "object address: in 8 bytes, out 8 bytes")
        channel, axis = struct.unpack("<II", data)
        index = self.catalog.index_of(channel)
        if index is None:  # (0, 0): "No instance of the class exists" (same page, 312768779)
            return NO_INSTANCE
        data_ig = (index_group & ~ATTRIBUTE_FIELD) | DATA
        if data_ig in self.catalog.ig_logicals:
            ig, io = self.catalog.ig_logicals[index], obj.index_offset or 0
        else:
            ig, io = self.catalog.ig_indexes[index], obj.index_offset_index or 0
        if io >= 0x10000:  # an axis object: the same element of the asked axis
            io = axis * 0x10000 + (io & 0xFFFF)
            if (io not in self.catalog.by_group[ig]) or axis == 0:
                return NO_INSTANCE
        return struct.pack("<II", ig, io)

    def find_symbol(self, name: str) -> Symbol:
        sym = self.catalog.by_name.get(normalise(name))
        if sym is None:
            raise AdsError(AdsErr.SYMBOLNOTFOUND, f"symbol {name!r}")
        return sym

    def symbols(self) -> Sequence[Symbol]:
        return self.catalog.symbols

    def data_types(self) -> Sequence[DataType]:
        return CNC_TYPES

    def ads_state(self) -> tuple[int, int]:
        return (int(AdsState.RUN) if self.source() is not None else int(self.down_state)), 0

    def write_control(self, ads_state: int, device_state: int, data: bytes) -> None:
        """The GEO task's state follows the daemon, not ADS: asking for the state it is in is
        accepted, anything else is not a service of this port (0x701)."""
        if ads_state != self.ads_state()[0]:
            raise AdsError(AdsErr.SRVNOTSUPP, "WriteControl cannot change the GEO task state")


__all__ = ["STATIC_HANDLE_BIT", "CncProvider", "Sink", "Source"]
