"""The CNC objects liftd serves on the GEO port, declared as data, compiled once per channel.

Addressing (docs/reference/isg-cnc.md §1; docs/reference/design.md §3.5): interpolator objects of
channel <CID> at index group 0x121300 + CID (logical; bit 0x100000) and 0x21300 + channel index
(index based); axis objects at index offset AID × 0x10000 + element, AID the logical axis number
under logical addressing and the 1-based position in the channel otherwise (the
docs/reference/isg-cnc.md §1.3 inference); element attributes at index group + 0x100 (name) … +
0x600 (object address). Data the real CNC offers only over the HLI shared memory gets a symbol and
no invented IG/IO: its symbol entry points at 0xF005 with a fixed handle (STATIC_HANDLE_BIT | n),
valid on every connection.
"""

# `# fmt: skip` where it stays: ruff's one-item-per-line layout of those statements would
# take this file past the house's ~450 lines a file (the others were removed, issue 40)
from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import NamedTuple

from liftd.ads.constants import IndexGroup
from liftd.ads.device import STATIC_HANDLE_BIT, Symbol
from liftd.cnc import units
from liftd.cnc.params import ChannelParams
from liftd.cnc.snapshot import GeoSnapshot, LoopStats, PlcSignal
from liftd.objects.types import BOOLEAN, REAL64, SGN32, UNS16, UNS32, UNS64, CncType

IPO_LOGICAL = 0x121300  # interpolator class, logical addressing (docs/reference/isg-cnc.md §1.2)
IPO_INDEX = 0x021300  # interpolator class, index-based addressing
ATTRIBUTE_FIELD = 0xF00  # 0x300 data, 0x400 name, 0x500 type, 0x600 length, 0x700 unit, …
DATA, NAME, TYPE, LENGTH, UNIT, WRITE_FLAG, ADDRESS = range(0x300, 0xA00, 0x100)
ELEMENT_LIFT_SUPPRESSED = 0x0094  # docs/reference/isg-cnc.md §2.1 [S5]
ELEMENT_LIFT_ACTIVE = 0x0095


class AdsStats(NamedTuple):
    """The ADS server's own counters, served as symbols next to the GEO timing."""

    connections: int = 0
    requests: int = 0
    errors: int = 0  # connections closed for protocol errors + requests answered 0x700
    notifications: int = 0
    log_dropped: int = 0  # log lines dropped because stderr was not read (service/logs.py)


class GeoView(NamedTuple):
    """What the provider reads from: the last published cycle, the loop's timing and the ADS
    server's counters. `snapshot` is the first channel's (channel order), `channels` every
    channel's of a machine of several (empty: only `snapshot`)."""

    snapshot: GeoSnapshot
    stats: LoopStats
    ads: AdsStats = AdsStats()
    channels: tuple[GeoSnapshot, ...] = ()


Getter = Callable[[GeoView], float | int | bool]
SnapOf = Callable[[GeoView], GeoSnapshot]


def _first(v: GeoView) -> GeoSnapshot:
    return v.snapshot


def _snap_of(index: int) -> SnapOf:
    """How channel `index` (machine order) finds its snapshot in a view."""
    if index == 0:
        return _first
    return lambda v: v.channels[index]


@dataclass(frozen=True, slots=True)
class CncObject:
    name: str  # element name (attribute +0x100), e.g. lift_active
    symbol: str  # liftd's symbol name, e.g. GEO.ch1.Z.lift_active
    type: CncType
    unit: str
    get: Getter
    comment: str
    aliases: tuple[str, ...] = ()
    index_offset: int | None = None  # logical-addressing IO; None: HLI-only (symbol only)
    index_offset_index: int | None = None  # index-based IO
    signal: PlcSignal | None = None  # writable: the PLC input it sets
    channel: int = 0  # machine index of its channel (channel order)

    @property
    def writable(self) -> bool:
        return self.signal is not None


def normalise(name: str) -> str:
    """Symbol names are case-insensitive (TwinCAT); HLI paths may carry the ST dereference."""
    return name.replace("^", "").strip().lower()


def _flag(name: str, axis: int, snap: SnapOf) -> Getter:
    """A lift flag of channel axis `axis`: the channel's flag while this axis lifts (any axis of
    the channel may lift, vendor §3; one range at a time per channel)."""

    def get(v: GeoView) -> bool:
        s = snap(v)
        return bool(getattr(s, name)) and s.lift_axis == axis

    return get


def _phase(axis: int, snap: SnapOf) -> Getter:
    def get(v: GeoView) -> int:
        s = snap(v)
        return int(s.lift_phase) if s.lift_axis == axis else 0

    return get


def _count(axis: int, snap: SnapOf) -> Getter:
    def get(v: GeoView) -> int:
        s = snap(v)
        return s.lift_counts[axis] if s.lift_counts else 0

    return get


def _axis(i: int, snap: SnapOf) -> Getter:
    return lambda v: units.m_to_isg_pos(snap(v).positions[i])


def _of(snap: SnapOf, field: Callable[[GeoSnapshot], float | int | bool]) -> Getter:
    return lambda v: field(snap(v))


def _objects(ch: ChannelParams, index: int = 0) -> list[CncObject]:
    """Channel `index`'s objects (machine order); the loop's and the server's (GEO.cycle,
    GEO.timing.*, GEO.ads.*) with the first channel's."""
    snap = _snap_of(index)
    cid = ch.channel_id
    geo = f"GEO.ch{cid}"
    um_s = units.m_s_to_isg_vel
    out: list[CncObject] = []
    for pos, ax in enumerate(ch.axes, start=1):
        for element, name, flag in (
            (ELEMENT_LIFT_ACTIVE, "lift_active", "lift_active"),
            (ELEMENT_LIFT_SUPPRESSED, "lift_suppressed", "lift_suppressed"),
        ):
            getter = _flag(flag, pos - 1, snap)
            out.append(
                CncObject(
                    name,
                    f"{geo}.{ax.name}.{name}",
                    BOOLEAN,
                    "-",
                    getter,
                    f"{name} of axis {ax.name} (vendor §2.6)",
                    (f"gpAx[{ax.log_axis_nr}].ipo_state.{name}",),
                    ax.log_axis_nr * 0x10000 + element,
                    pos * 0x10000 + element,
                )
            )
        phase, count = _phase(pos - 1, snap), _count(pos - 1, snap)
        out += [
            CncObject(
                "lift_phase",
                f"{geo}.{ax.name}.lift_phase",
                UNS16,
                "-",
                phase,
                f"lift phase of {ax.name}: 0 none, 1 up, 2 down, 3 done, 4 direct, "
                "5 hold at POS_LIMIT, 6 coupled",
            ),
            CncObject(
                "lift_count",
                f"{geo}.{ax.name}.lift_count",
                UNS32,
                "-",
                count,
                f"lift ranges started on {ax.name} since the program started (liftd "
                "extension: counts lifts whose flags overlap in one GEO cycle)",
            ),
        ]
        out.append(
            CncObject(
                "command_position",
                f"{geo}.{ax.name}.command_position",
                SGN32,
                "0.1 µm",
                _axis(pos - 1, snap),
                f"command position of {ax.name} (HLI act_position_r)",
            )
        )
    out += [
        CncObject(
            "max_path_velocity",
            f"{geo}.max_path_velocity",
            UNS32,
            "µm/s",
            lambda v: round(um_s(snap(v).v_block_max)),
            "maximum velocity on path in the active block",
            (),
            0xF,
            0xF,
        ),
        CncObject(
            "max_path_velocity_block_end",
            f"{geo}.max_path_velocity_block_end",
            UNS32,
            "µm/s",
            lambda v: round(um_s(snap(v).v_block_end)),
            "maximum velocity on path at block end",
            (),
            0x10,
            0x10,
        ),
        CncObject(
            "path_velocity",
            f"{geo}.path_velocity",
            REAL64,
            "µm/s",
            lambda v: um_s(snap(v).v_path),
            "current velocity on path",
            (),
            0x15,
            0x15,
        ),
        CncObject(
            "override",
            f"{geo}.override",
            UNS16,
            "0.1 %",
            lambda v: units.fraction_to_isg_permille(snap(v).override),
            "path override in effect (after the lift's limits)",
        ),
        CncObject(
            "override_requested",
            f"{geo}.override_requested",
            UNS16,
            "0.1 %",
            lambda v: units.fraction_to_isg_permille(snap(v).override_requested),
            "path override requested by the PLC",
        ),
        CncObject(
            "override_max",
            f"{geo}.override_max",
            UNS16,
            "0.1 %",
            lambda v: units.fraction_to_isg_permille(snap(v).override_max),
            "highest override Advanced Lifting accepts now",
        ),
        CncObject(
            "feed_hold",
            f"{geo}.feed_hold",
            BOOLEAN,
            "-",
            lambda v: snap(v).feed_hold,
            "feed hold in effect",
        ),
        CncObject(
            "state",
            f"{geo}.state",
            UNS32,
            "-",
            lambda v: int(snap(v).state),
            "channel state (KERNELV: 3 READY, 4 ACTIVE, 5 HOLD, 6 ERROR)",
        ),
        CncObject(
            "line",
            f"{geo}.line",
            UNS32,
            "-",
            lambda v: snap(v).line,
            "NC source line being executed",
        ),
        CncObject(
            "block",
            f"{geo}.block",
            UNS32,
            "-",
            lambda v: snap(v).segment,
            "motion block being executed (0-based)",
        ),
        CncObject(
            "error_id",
            f"{geo}.error_id",
            UNS32,
            "-",
            lambda v: snap(v).error_id,
            "ISG error id of the channel error, 0 for none",
        ),
        CncObject(
            "error_line",
            f"{geo}.error_line",
            UNS32,
            "-",
            lambda v: snap(v).error_line,
            "NC line of the channel error",
        ),
        CncObject(
            "m_pending",
            f"{geo}.m_pending",
            SGN32,
            "-",
            lambda v: snap(v).m_pending,
            "M function waiting for its acknowledge, -1 for none",
        ),
    ]
    if index == 0:
        out += [
            # the loop's count, not the channel task's: a reload replaces the task (whose own
            # count restarts at 0), and a health check or PLC watchdog needs one that only rises
            CncObject("cycle", "GEO.cycle", UNS64, "-", lambda v: v.stats.cycles,
                      "GEO cycles since start"),
            CncObject("exceeded", "GEO.timing.exceeded", UNS32, "-", lambda v: v.stats.exceeded,
                      "cycles that finished after their deadline"),
            CncObject("compute_last_us", "GEO.timing.compute_last_us", REAL64, "µs",
                      lambda v: v.stats.compute_last_us, "compute time of the last cycle"),
            CncObject("compute_max_us", "GEO.timing.compute_max_us", REAL64, "µs",
                      lambda v: v.stats.compute_max_us, "largest compute time since start"),
            CncObject("compute_over_25pct", "GEO.timing.compute_over_25pct", UNS32, "-",
                      lambda v: v.stats.compute_over,
                      "cycles whose compute took > 25 % of the cycle"),
            CncObject("compute_cpu_max_us", "GEO.timing.compute_cpu_max_us", REAL64, "µs",
                      lambda v: v.stats.compute_cpu_max_us,
                      "largest compute on the loop thread's CPU clock"),
            CncObject("compute_cpu_over_25pct", "GEO.timing.compute_cpu_over_25pct", UNS32, "-",
                      lambda v: v.stats.compute_cpu_over,
                      "cycles whose compute took > 25 % of the cycle on the thread's CPU clock"),
            CncObject("lateness_last_us", "GEO.timing.lateness_last_us", REAL64, "µs",
                      lambda v: v.stats.lateness_last_us, "wake-up lateness of the last cycle"),
            CncObject("lateness_max_us", "GEO.timing.lateness_max_us", REAL64, "µs",
                      lambda v: v.stats.lateness_max_us, "largest wake-up lateness since start"),
            CncObject("connections", "GEO.ads.connections", UNS32, "-",
                      lambda v: v.ads.connections, "open ADS connections"),
            CncObject("requests", "GEO.ads.requests", UNS64, "-", lambda v: v.ads.requests,
                      "ADS requests answered since start"),
            CncObject("errors", "GEO.ads.errors", UNS32, "-", lambda v: v.ads.errors,
                      "connections closed for protocol errors and requests answered 0x700"),
            CncObject("notifications", "GEO.ads.notifications", UNS64, "-",
                      lambda v: v.ads.notifications, "device notification frames sent"),
            CncObject("log_dropped", "GEO.ads.log_dropped", UNS64, "-",
                      lambda v: v.ads.log_dropped,
                      "daemon log lines dropped because nobody read the log output"),
        ]  # fmt: skip
    plc = f"PLC.ch{cid}"
    out += [
        CncObject("override", f"{plc}.override", UNS16, "0.1 %",
                  lambda v: units.fraction_to_isg_permille(snap(v).override_requested),
                  "write: path override 0..2000 (0.1 %)", signal=PlcSignal.OVERRIDE),
        CncObject("feed_hold", f"{plc}.feed_hold", BOOLEAN, "-",
                  lambda v: snap(v).feed_hold, "write: feed hold", signal=PlcSignal.FEED_HOLD),
        CncObject("start", f"{plc}.start", BOOLEAN, "-", lambda v: False,
                  "write TRUE: start / continue the program", signal=PlcSignal.START),
        CncObject("stop", f"{plc}.stop", BOOLEAN, "-", lambda v: False,
                  "write TRUE: stop at standstill (HOLD)", signal=PlcSignal.STOP),
        CncObject("reset", f"{plc}.reset", BOOLEAN, "-", lambda v: False,
                  "write TRUE: reset the channel", signal=PlcSignal.RESET),
        CncObject("m_ack", f"{plc}.m_ack", BOOLEAN, "-", lambda v: False,
                  "write TRUE: acknowledge the pending M function", signal=PlcSignal.M_ACK),
    ]  # fmt: skip
    return [dataclasses.replace(obj, channel=index) for obj in out]


class Catalog:
    """Every object of the machine's channels, looked up by address or by symbol name.

    Channel i (machine order, ascending channel id) is at index group 0x121300 + its channel
    id (logical) and 0x21300 + i + 1 (index based: the n-th configured channel); a catalogue
    of one channel takes its index from `channel_index`."""

    def __init__(self, ch: ChannelParams | Sequence[ChannelParams], channel_index: int = 1) -> None:
        channels = (ch,) if isinstance(ch, ChannelParams) else tuple(ch)
        channels = tuple(sorted(channels, key=lambda c: c.channel_id))
        self.channels = channels
        self.channel = channels[0]
        self.objects = tuple(obj for i, c in enumerate(channels) for obj in _objects(c, i))
        self.ig_logicals = tuple(IPO_LOGICAL + c.channel_id for c in channels)
        self.ig_indexes = tuple(
            IPO_INDEX + (channel_index if len(channels) == 1 else i + 1)
            for i in range(len(channels))
        )
        self.ig_logical, self.ig_index = self.ig_logicals[0], self.ig_indexes[0]
        self.by_group: dict[int, dict[int, CncObject]] = {
            ig: {} for ig in (*self.ig_logicals, *self.ig_indexes)
        }
        self.static: dict[int, CncObject] = {}
        self.symbols: list[Symbol] = []
        self.by_name: dict[str, Symbol] = {}
        self.object_of: dict[str, CncObject] = {}
        for n, obj in enumerate(self.objects):
            if obj.index_offset is not None and obj.index_offset_index is not None:
                logical = self.ig_logicals[obj.channel]
                self.by_group[logical][obj.index_offset] = obj
                self.by_group[self.ig_indexes[obj.channel]][obj.index_offset_index] = obj
                ig, io = logical, obj.index_offset
            else:
                ig, io = int(IndexGroup.SYM_VALBYHND), STATIC_HANDLE_BIT | n
                self.static[io] = obj
            sym = Symbol(obj.symbol, ig, io, obj.type.size, obj.type.adst, obj.type.plc,
                         f"{obj.comment} [{obj.unit}]", obj.writable)  # fmt: skip
            self.symbols.append(sym)
            for name in (obj.symbol, *obj.aliases):
                key = normalise(name)
                if key in self.by_name:
                    raise ValueError(f"symbol {name} declared twice")
                self.by_name[key] = sym if name == obj.symbol else _alias(sym, name)
                self.object_of[key] = obj

    def index_of(self, channel_id: int) -> int | None:
        """Machine index of logical channel `channel_id`, None if the machine has none."""
        for i, c in enumerate(self.channels):
            if c.channel_id == channel_id:
                return i
        return None

    def rows(self) -> list[tuple[str, str, str, str, str, str, str]]:
        """(symbol, IG, IO, type, unit, access, comment) for `liftd objects`."""
        out = []
        for obj, sym in zip(self.objects, self.symbols, strict=True):
            ig = f"0x{sym.index_group:X}"
            io = f"0x{sym.index_offset:08X}"
            if obj.index_offset is None:
                ig, io = "symbol", "-"
            access = "read/write" if obj.writable else "read"
            out.append((obj.symbol, ig, io, obj.type.isg, obj.unit, access, obj.comment))
            out += [
                (f"  = {a}", ig, io, obj.type.isg, obj.unit, access, "alias") for a in obj.aliases
            ]
        return out


def _alias(sym: Symbol, name: str) -> Symbol:
    return Symbol(name, sym.index_group, sym.index_offset, sym.size, sym.data_type,
                  sym.type_name, sym.comment, sym.writable)  # fmt: skip
