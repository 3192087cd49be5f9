"""The GEO port's CNC objects: real addresses, attributes, symbols and aliases, PLC inputs, and
the error codes of docs/reference/isg-cnc.md §1.5."""

from __future__ import annotations

import struct

import pytest

from liftd.ads.constants import AdsErr, AdsState, IndexGroup
from liftd.ads.errors import AdsError
from liftd.ads.service import STATIC_HANDLE_BIT
from liftd.cnc.snapshot import LiftPhase, LoopStats, PlcSignal, PlcWrite
from liftd.objects.catalog import Catalog, GeoView
from liftd.objects.provider import CncProvider
from tests.support.ads_harness import snapshot
from tests.support.channel import make_channel


class World:
    def __init__(self) -> None:
        self.view: GeoView | None = GeoView(snapshot(), LoopStats(cycles=5, exceeded=2))
        self.writes: list[PlcWrite] = []
        self.catalog = Catalog(make_channel())  # X (1), Y (2), Z (3); Z lifts
        self.p = CncProvider(self.catalog, lambda: self.view, self.writes.append)

    def code(self, fn, *args) -> int:  # type: ignore[no-untyped-def]
        with pytest.raises(AdsError) as err:
            fn(*args)
        return err.value.code


@pytest.fixture
def w() -> World:
    return World()


def test_lift_objects_at_their_vendor_addresses(w: World) -> None:
    assert w.p.read(0x121301, 0x00030095, 1) == b"\x00"
    w.view = w.view._replace(
        snapshot=w.view.snapshot._replace(
            lift_active=True,  # type: ignore[union-attr]
            lift_suppressed=True,
        )
    )
    assert w.p.read(0x121301, 0x00030095, 1) == b"\x01"  # lift_active, AID 3 (Z), logical
    assert w.p.read(0x121301, 0x00030094, 1) == b"\x01"  # lift_suppressed
    assert w.p.read(0x021301, 0x00030095, 1) == b"\x01"  # index based: channel index 1, 3rd axis
    assert w.p.read(0x121301, 0x00010095, 1) == b"\x00"  # X does not lift
    assert w.p.read(0x121301, 0x00030095, 1024) == b"\x01"  # longer buffer: object length


def test_the_flags_belong_to_the_axis_that_lifts(w: World) -> None:
    """Any axis of the channel may lift (vendor §3): the flags, the phase and liftd's lift
    counter are the lifting axis's; the other axes read 0."""
    snap = w.view.snapshot._replace(
        lift_active=True,
        lift_axis=0,  # type: ignore[union-attr]
        lift_phase=LiftPhase.UP,
        lift_counts=(3, 0, 2),
    )
    w.view = w.view._replace(snapshot=snap)  # type: ignore[union-attr]
    assert w.p.read(0x121301, 0x00010095, 1) == b"\x01"  # X lifts
    assert w.p.read(0x121301, 0x00030095, 1) == b"\x00"  # Z does not, now
    for name, value in (
        ("X.lift_phase", b"\x01\x00"),
        ("Z.lift_phase", b"\x00\x00"),
        ("X.lift_count", struct.pack("<I", 3)),
        ("Z.lift_count", struct.pack("<I", 2)),
    ):
        sym = w.p.find_symbol(f"GEO.ch1.{name}")
        assert w.p.read(sym.index_group, sym.index_offset, 8) == value


def test_path_velocity_objects(w: World) -> None:
    # snapshot: v_path 0.25 m/s, block max 0.4 m/s, block end 0.1 m/s
    assert w.p.read(0x121301, 0xF, 4) == struct.pack("<I", 400_000)  # UNS32 µm/s
    assert w.p.read(0x121301, 0x10, 4) == struct.pack("<I", 100_000)
    assert w.p.read(0x121301, 0x15, 8) == struct.pack("<d", 250_000.0)  # REAL64 µm/s


def test_attributes_by_index_group(w: World) -> None:
    io = 0x00030095
    assert w.p.read(0x121401, io, 1024) == b"lift_active\0"  # +0x100 name
    assert w.p.read(0x121501, io, 1024) == b"BOOLEAN\0"  # +0x200 type
    assert w.p.read(0x121601, io, 4) == struct.pack("<I", 1)  # +0x300 length
    assert w.p.read(0x121701, io, 1024) == b"-\0"  # +0x400 unit
    assert w.p.read(0x121801, io, 1) == b"\x00"  # +0x500 write flag: read only
    assert w.p.read(0x121901, io, 8) == struct.pack("<II", 0x121301, io)  # +0x600 address
    assert w.p.read(0x121701, 0x15, 1024) == "µm/s\0".encode("cp1252")  # CP1252 strings
    # object address of lift_active of axis 1 of channel 1 (ReadWrite: channel, axis)
    assert w.p.read_write(0x121901, io, 8, struct.pack("<II", 1, 1)) == struct.pack(
        "<II", 0x121301, 0x00010095
    )


def test_error_codes(w: World) -> None:
    assert w.code(w.p.read, 0x121302, 0x30095, 1) == AdsErr.INVALIDGRP  # channel 2
    assert w.code(w.p.read, 0x122301, 0x30095, 1) == AdsErr.INVALIDGRP  # decoder class
    assert w.code(w.p.read, 0x121301, 0x40095, 1) == AdsErr.INVALIDOFFSET  # AID 4
    assert w.code(w.p.read, 0x121301, 0x30096, 1) == AdsErr.INVALIDOFFSET  # element
    assert w.code(w.p.read, 0x121301, 0x15, 4) == AdsErr.INVALIDSIZE  # REAL64 into 4 bytes
    assert len(w.p.read(0x121301, 0x30095, 4)) == 1  # a longer read: the BOOL's one byte
    assert w.code(w.p.write, 0x121301, 0x30095, b"\x01") == AdsErr.INVALIDACCESS
    assert w.code(w.p.read_write, 0x121301, 0x30095, 8, bytes(8)) == AdsErr.SRVNOTSUPP
    w.view = None  # the GEO task is not running
    assert w.code(w.p.read, 0x121301, 0x30095, 1) == AdsErr.NOTREADY
    assert w.p.read(0x121401, 0x30095, 64) == b"lift_active\0"  # attributes still answer
    assert w.p.ads_state() == (AdsState.STOP, 0)
    w.p.down_state = AdsState.ERROR
    assert w.p.ads_state() == (AdsState.ERROR, 0)


def test_symbols_and_aliases_resolve_to_the_same_object(w: World) -> None:
    sym = w.p.find_symbol("GEO.ch1.Z.lift_active")
    assert (sym.index_group, sym.index_offset, sym.type_name, sym.size) == (
        0x121301,
        0x30095,
        "BOOL",
        1,
    )
    for alias in (
        "gpAx[3].ipo_state.lift_active",
        "gpAx[3]^.ipo_state.lift_active",
        "geo.CH1.z.LIFT_ACTIVE",
    ):
        got = w.p.find_symbol(alias)
        assert (got.index_group, got.index_offset) == (0x121301, 0x30095)
    assert w.code(w.p.find_symbol, "GEO.ch1.Q.lift_active") == AdsErr.SYMBOLNOTFOUND
    pos = w.p.find_symbol("GEO.ch1.X.command_position")  # HLI-only: a fixed 0xF005 address
    assert pos.index_group == IndexGroup.SYM_VALBYHND and pos.index_offset & STATIC_HANDLE_BIT
    assert w.p.read(pos.index_group, pos.index_offset, 4) == struct.pack("<i", 1_000_000)  # 0.1 µm
    cyc = w.p.find_symbol("GEO.timing.exceeded")
    assert w.p.read(cyc.index_group, cyc.index_offset, 4) == struct.pack("<I", 2)
    assert len({s.name for s in w.p.symbols()}) == len(w.p.symbols())


def test_plc_inputs(w: World) -> None:
    def put(name: str, data: bytes) -> None:
        sym = w.p.find_symbol(name)
        w.p.write(sym.index_group, sym.index_offset, data)

    put("PLC.ch1.override", struct.pack("<H", 1500))
    put("PLC.ch1.feed_hold", b"\x01")
    put("PLC.ch1.start", b"\x01")
    put("PLC.ch1.start", b"\x00")  # FALSE: no command
    put("PLC.ch1.m_ack", b"\x01")
    assert w.writes == [
        PlcWrite(PlcSignal.OVERRIDE, 1.5),
        PlcWrite(PlcSignal.FEED_HOLD, 1.0),
        PlcWrite(PlcSignal.START, 1.0),
        PlcWrite(PlcSignal.M_ACK, 1.0),
    ]
    sym = w.p.find_symbol("PLC.ch1.override")
    assert w.code(w.p.write, sym.index_group, sym.index_offset, struct.pack("<H", 2001)) == 0x706
    assert w.code(w.p.write, sym.index_group, sym.index_offset, b"\x01") == 0x705
    ro = w.p.find_symbol("GEO.ch1.override")
    assert w.code(w.p.write, ro.index_group, ro.index_offset, struct.pack("<H", 5)) == 0x704
    # the PLC reads its levels back as it wrote them (HLI memory), at once, while the loop has
    # not taken them yet (the view still has 100 %, no hold); a refused write changes nothing
    assert w.p.read(sym.index_group, sym.index_offset, 2) == struct.pack("<H", 1500)
    hold = w.p.find_symbol("PLC.ch1.feed_hold")
    assert w.p.read(hold.index_group, hold.index_offset, 1) == b"\x01"
    taken = w.p.find_symbol("GEO.ch1.override_requested")
    assert w.p.read(taken.index_group, taken.index_offset, 2) == struct.pack("<H", 1000)
    put("PLC.ch1.override", struct.pack("<H", 700))
    assert w.p.read(sym.index_group, sym.index_offset, 2) == struct.pack("<H", 700)


def test_a_plcs_level_reads_the_loops_value_until_written(w: World) -> None:
    """Before any write (a fresh daemon), the level is what the loop has (the view's)."""
    sym = w.p.find_symbol("PLC.ch1.override")
    w.view = GeoView(snapshot()._replace(override_requested=0.5), LoopStats(cycles=5))
    assert w.p.read(sym.index_group, sym.index_offset, 2) == struct.pack("<H", 500)
    w.view = None  # and a stopped GEO task answers 0x707 as for any object
    assert w.code(w.p.read, sym.index_group, sym.index_offset, 2) == AdsErr.NOTREADY


def test_geo_cycle_is_the_loops_count_which_a_reload_does_not_reset(w: World) -> None:
    """A reload replaces the channel's GEO task, whose own count starts again at 0: GEO.cycle
    (what `liftd status` and a PLC watchdog see advance) is the loop's count of cycles."""
    sym = w.p.find_symbol("GEO.cycle")
    assert sym is not None
    w.view = GeoView(w.view.snapshot._replace(cycle=3), LoopStats(cycles=90_000))  # type: ignore[union-attr]
    assert w.p.read(sym.index_group, sym.index_offset, 8) == struct.pack("<Q", 90_000)
