"""The objects of a machine of several channels (issue 18 item 1): channel N at index group
0x12130‖N (logical, AID = logical axis number) and 0x21300 + n (index based, the n-th channel,
AID = position in the channel), docs/reference/isg-cnc.md §1.2/§1.3; its own PLC inputs; the loop's objects
once. The machine drives the view on a virtual clock."""

from __future__ import annotations

import struct

import pytest

from liftd.ads.constants import AdsErr
from liftd.ads.errors import AdsError
from liftd.cnc.machine import ChannelProgram, Machine
from liftd.cnc.plc import Schedule, SimPlc
from liftd.cnc.snapshot import GeoSnapshot, LoopStats, PlcSignal, PlcWrite
from liftd.objects.catalog import Catalog, GeoView
from liftd.objects.provider import CncProvider
from liftd.runtime.records import MachineCodec, SnapshotCodec, pack_input, unpack_input
from tests.support.ads_harness import snapshot
from tests.support.channel import make_channel, make_second_channel

CUT = "N10 G01 X300 Y0 F6000\nN20 M30\n"
LIFT = "N10 W[LIFT_START POS=1 POS_LIMIT=40]\nN20 G01 U400 V40 F24000\nN30 W[LIFT_END]\nN40 M30\n"


def value(p: CncProvider, name: str) -> bytes:
    sym = p.find_symbol(name)
    return p.read(sym.index_group, sym.index_offset, sym.size)


class Machine2:
    def __init__(self) -> None:
        self.catalog = Catalog([make_second_channel(), make_channel()])  # sorted by id
        self.view: GeoView | None = None
        self.writes: list[PlcWrite] = []
        self.p = CncProvider(self.catalog, lambda: self.view, self.writes.append)

    def show(self, snaps: list[GeoSnapshot]) -> None:
        self.view = GeoView(snaps[0], LoopStats(cycles=snaps[0].cycle), channels=tuple(snaps))

    def flag(self, ig: int, io: int) -> bool:
        return self.p.read(ig, io, 1) == b"\x01"

    def code(self, fn, *args) -> int:  # type: ignore[no-untyped-def]
        with pytest.raises(AdsError) as err:
            fn(*args)
        return err.value.code


def test_each_channels_flags_at_its_own_index_group() -> None:
    """Channel 2 lifts W while channel 1 cuts: ch2's W flag at 0x121302 / 0x60095 (logical
    axis 6) and 0x21302 / 0x30095 (3rd axis of the 2nd channel), ch1's Z stays 0."""
    w = Machine2()
    machine = Machine(
        [ChannelProgram(make_channel(), CUT), ChannelProgram(make_second_channel(), LIFT)]
    )
    plcs = [SimPlc(0.02), SimPlc(0.02)]
    last: list[GeoSnapshot | None] = [None, None]
    lifted = 0
    for k in range(1, 400):
        t = k * 1e-3
        snaps = machine.step(
            [p.inputs(s, t, Schedule()) for p, s in zip(plcs, last, strict=True)], t
        )
        last = list(snaps)
        w.show(snaps)
        ch2_lifts = snaps[1].lift_active
        lifted += ch2_lifts
        assert w.flag(0x121302, 0x00060095) == ch2_lifts
        assert w.flag(0x021302, 0x00030095) == ch2_lifts
        assert value(w.p, "GEO.ch2.W.lift_active") == bytes([ch2_lifts])
        assert not w.flag(0x121301, 0x00030095)  # Z of channel 1 never
        assert not w.flag(0x021301, 0x00030095)
        assert value(w.p, "GEO.ch1.state") == struct.pack("<I", int(snaps[0].state))
    assert lifted > 50


def test_addressing_rules_of_two_channels() -> None:
    w = Machine2()
    one = snapshot(lift_active=True, lift_axis=2, line=11)
    two = snapshot(lift_active=False, lift_suppressed=True, lift_axis=2, line=22)
    w.show([one, two])
    assert w.flag(0x121301, 0x00030095) and not w.flag(0x121302, 0x00060095)
    assert w.flag(0x121302, 0x00060094) and not w.flag(0x121301, 0x00030094)
    # channel 2 has no logical axis 3, channel 1 no axis 6; no channel 3
    assert w.code(w.p.read, 0x121302, 0x00030095, 1) == AdsErr.INVALIDOFFSET
    assert w.code(w.p.read, 0x121301, 0x00060095, 1) == AdsErr.INVALIDOFFSET
    assert w.code(w.p.read, 0x121303, 0x00010095, 1) == AdsErr.INVALIDGRP
    assert w.code(w.p.read, 0x021303, 0x00010095, 1) == AdsErr.INVALIDGRP
    # attributes by adding to the channel's index group (+0x100 name, +0x600 address)
    assert w.p.read(0x121402, 0x00060095, 64).rstrip(b"\0") == b"lift_active"
    assert w.p.read(0x121902, 0x00060095, 8) == struct.pack("<II", 0x121302, 0x00060095)
    assert w.p.read(0x021902, 0x00030095, 8) == struct.pack("<II", 0x021302, 0x00030095)
    # object address by (channel, axis): ReadWrite on +0x600
    out = w.p.read_write(0x121901, 0x00030095, 8, struct.pack("<II", 2, 6))
    assert out == struct.pack("<II", 0x121302, 0x00060095)
    # an axis the channel lacks, a channel the machine lacks: (0, 0), no instance (TF5200)
    assert w.p.read_write(0x121901, 0x00030095, 8, struct.pack("<II", 2, 3)) == bytes(8)
    assert w.p.read_write(0x121901, 0x00030095, 8, struct.pack("<II", 3, 1)) == bytes(8)
    # channel objects (path velocity 0x15) per channel, the loop's once
    assert value(w.p, "GEO.ch2.line") == struct.pack("<I", 22)
    assert value(w.p, "GEO.ch1.line") == struct.pack("<I", 11)
    assert w.p.find_symbol("GEO.cycle") is not None
    assert sum(s.name == "GEO.cycle" for s in w.catalog.symbols) == 1
    # HLI aliases by logical axis number
    assert w.p.find_symbol("gpAx[6].ipo_state.lift_active").index_group == 0x121302


def test_plc_inputs_name_their_channel() -> None:
    w = Machine2()
    w.show([snapshot(), snapshot()])
    sym = w.p.find_symbol("PLC.ch2.override")
    w.p.write(sym.index_group, sym.index_offset, struct.pack("<H", 500))
    sym = w.p.find_symbol("PLC.ch1.start")
    w.p.write(sym.index_group, sym.index_offset, b"\x01")
    assert w.writes == [PlcWrite(PlcSignal.OVERRIDE, 0.5, 1), PlcWrite(PlcSignal.START, 1.0, 0)]
    for write in w.writes:  # through the input ring's record
        assert unpack_input(pack_input(write)) == write


def test_one_record_carries_every_channel() -> None:
    one, two = snapshot(line=5), snapshot(line=9, positions=(1.0, 2.0, 3.0))
    codec = MachineCodec([3, 3])
    snaps, stats = codec.unpack(codec.pack([one, two], LoopStats(cycles=7)))
    assert [s._replace(events=()) for s in snaps] == [one, two] and stats.cycles == 7
    single = MachineCodec([3])  # one channel: the single-channel record, byte for byte
    assert single.pack([one], LoopStats(3)) == SnapshotCodec(3).pack(one, LoopStats(3))
