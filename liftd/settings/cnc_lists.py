"""Read a channel's ISG lists (start-up → default channel list → channel list → axis lists)
and map them to core parameters in SI units, applying the lift activation rules.

Interpretation order: internal defaults, then `default_sda_mds`, then `sda_mds[i]`; missing
entries keep the earlier value (P-STUP-00034, docs/reference/isg-cnc.md §3.3). File names in the
start-up list are relative to the start-up list's directory (docs/reference/isg-cnc.md §3.2).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from liftd.cnc import units
from liftd.cnc.params import AxisParams, LiftMethod, MSync, SlopeType
from liftd.settings.channel_rules import lift_method_of, look_ahead_of, m_synch_of
from liftd.settings.isg_list import Problem, Severity, read_list
from liftd.settings.isg_schema import (
    AXIS_KEYS,
    CHANNEL_KEYS,
    STARTUP_KEYS,
    TOOL_KEYS,
    ZERO_OFFSET_KEYS,
    TypedList,
    Value,
    type_list,
)
from liftd.settings.list_reader import ListReader, as_int, flags_of, int_of, real_of

DEFAULT_MAX_RADIUS_DIFF = 50  # P-CHAN-00171 default, 0.1 µm


@dataclass(frozen=True, slots=True)
class ChannelLists:
    """What the lists say about one channel, in SI units."""

    channel_id: int
    axes: tuple[AxisParams, ...]
    lift_method: LiftMethod
    lift_min_dist: float
    slope: SlopeType
    look_ahead_blocks: int
    max_radius_diff: float
    m_synch: tuple[tuple[int, MSync], ...]
    path_prep_flags: frozenset[str]
    ipo_flags: frozenset[str]
    files: tuple[str, ...]
    tool_radii: tuple[tuple[int, float], ...] = ()  # D number -> m
    zero_offsets: tuple[tuple[int, tuple[float, ...]], ...] = ()  # group 0..6 -> m per axis
    zero_offset_default: int = 0
    g53_offsets: bool = False
    # where each path axis's log_achs_nr is written (file, line), for messages about the axis
    axis_refs: tuple[tuple[str, int | None], ...] = ()
    corr_v_trans_jerk: bool = False  # P-CHAN-00009
    mode_trans_jerk: int = 0  # P-CHAN-00117


def _resolve(base: Path, value: Value) -> Path:
    assert isinstance(value.value, str)
    path = Path(value.value)
    return path if path.is_absolute() else base / path


def read_channel_lists(
    startup: Path,
    channel: int,
    tool_list: Path | None = None,
    zero_offset_list: Path | None = None,
) -> tuple[ChannelLists | None, list[Problem]]:
    """Read the lists of logical channel `channel` (1-based; list index channel - 1); the
    tool and zero-offset lists come from `werkz_data[i]` / `nullp_data[i]` of the start-up
    list unless given.

    Returns the channel's parameters, or None when any error was found; the problem list
    always carries every error and warning with file, line, key and value.
    """
    rd = ListReader()
    stup = rd.read(startup, STARTUP_KEYS, None)
    if stup is None:
        return None, rd.problems
    base = startup.parent
    idx = channel - 1
    channel_values: TypedList = {}
    default_ref = stup.get("default_sda_mds")
    if default_ref is not None:
        default_values = rd.read(_resolve(base, default_ref), CHANNEL_KEYS, default_ref)
        channel_values.update(default_values or {})
    chan_ref = stup.get(f"sda_mds[{idx}]")
    if chan_ref is None:
        rd.error(None, f"no channel list sda_mds[{idx}] for channel {channel}", str(startup))
        return None, rd.problems
    chan_own = rd.read(_resolve(base, chan_ref), CHANNEL_KEYS, chan_ref)
    if chan_own is None:
        return None, rd.problems
    channel_values.update(chan_own)

    axes = _read_axes(rd, stup, base, channel_values, startup)
    pp_ref = flags_of(channel_values, "configuration.path_preparation.function") or flags_of(
        stup, f"configuration.channel[{idx}].path_preparation.function"
    )
    ipo_ref = flags_of(channel_values, "configuration.interpolator.function") or flags_of(
        stup, f"configuration.channel[{idx}].interpolator.function"
    )
    pp = pp_ref.value if pp_ref is not None else frozenset({"FCT_DEFAULT"})
    ipo = ipo_ref.value if ipo_ref is not None else frozenset({"FCT_IPO_DEFAULT"})
    assert isinstance(pp, frozenset) and isinstance(ipo, frozenset)
    method = lift_method_of(
        rd, pp, ipo, pp_ref, ipo_ref, channel_values.get("enable_time_based_lift")
    )
    look_ahead = look_ahead_of(rd, ipo, ipo_ref, channel_values, stup, idx)
    m_synch = m_synch_of(rd, channel_values)
    slope = SlopeType(int_of(channel_values, "prog_start.slope.profile", 0))
    tools = _tools(rd, _list_path(base, stup, f"werkz_data[{idx}]", tool_list))
    zero = _zero_offsets(rd, _list_path(base, stup, f"nullp_data[{idx}]", zero_offset_list), axes)
    if any(p.severity is Severity.ERROR for p in rd.problems) or axes is None:
        return None, rd.problems
    lists = ChannelLists(
        channel_id=channel,
        axes=axes,
        lift_method=method,
        lift_min_dist=units.isg_pos_to_m(int_of(channel_values, "lift_min_dist", 0)),
        slope=slope,
        look_ahead_blocks=look_ahead,
        max_radius_diff=units.isg_pos_to_m(
            int_of(channel_values, "max_radius_diff_circle", DEFAULT_MAX_RADIUS_DIFF)
        ),
        m_synch=m_synch,
        path_prep_flags=pp,
        ipo_flags=ipo,
        files=tuple(rd.files),
        tool_radii=tools,
        zero_offsets=zero[0],
        zero_offset_default=zero[1],
        g53_offsets=zero[2],
        axis_refs=tuple(_axis_ref(channel_values, j) for j in range(len(axes))),
        corr_v_trans_jerk=int_of(channel_values, "corr_v_trans_jerk", 0) != 0,
        mode_trans_jerk=int_of(channel_values, "mode_trans_jerk", 0),
    )
    return lists, rd.problems


def _axis_ref(chan: TypedList, j: int) -> tuple[str, int | None]:
    value = chan[f"gruppe[0].achse[{j}].log_achs_nr"]
    return value.entry.file, value.entry.line


def startup_channels(
    startup: Path, configured: int
) -> tuple[tuple[int, ...] | None, list[Problem]]:
    """The logical channels the start-up list describes: 1 … `kanal_anzahl` (P-STUP-00001),
    each with its channel list `sda_mds[i]` (P-STUP-00009, i = channel − 1). A start-up list
    without `kanal_anzahl` describes only the channel liftd.toml names (`configured`), as
    before liftd ran several channels. Returns the ids, or None with the errors: a channel
    without its list, a list for a channel beyond `kanal_anzahl`. (Reading and typing the list
    itself is reported by `read_channel_lists`, once.)"""
    try:
        parsed = read_list(startup)
    except OSError:
        return None, []  # read_channel_lists says why
    stup, _ = type_list(parsed, STARTUP_KEYS)
    count = stup.get("kanal_anzahl")
    if count is None or not isinstance(count.value, int):
        return (configured,), []
    n = count.value
    rd = ListReader()
    for i in range(n):
        if f"sda_mds[{i}]" not in stup:
            rd.error(count, f"{n} channels but no channel list sda_mds[{i}] for channel {i + 1}")
    for key, value in stup.items():
        if key.startswith("sda_mds[") and int(key[len("sda_mds[") : -1]) >= n:
            index = int(key[len("sda_mds[") : -1])
            rd.error(
                value,
                f"a channel list for channel {index + 1}, but kanal_anzahl is {n} "
                f"(channels 1 … {n}, sda_mds[0] … sda_mds[{n - 1}])",
            )
    return (None, rd.problems) if rd.problems else (tuple(range(1, n + 1)), [])


def _list_path(
    base: Path, stup: TypedList, key: str, explicit: Path | None
) -> tuple[Path, Value | None] | None:
    if explicit is not None:
        return explicit, None
    ref = stup.get(key)
    return (_resolve(base, ref), ref) if ref is not None else None


def _tools(
    rd: ListReader, where: tuple[Path, Value | None] | None
) -> tuple[tuple[int, float], ...]:
    """Tool radii per tool number from the tool list (wz[i].radius, P-TOOL-00004; the D word
    selects tool i). Invalid tools (wz[i].gueltig 0) have no radius."""
    if where is None:
        return ()
    values = rd.read(where[0], TOOL_KEYS, where[1])
    if values is None:
        return ()
    radii: dict[int, float] = {}
    for key, value in values.items():
        if not key.endswith(".radius") or key.count("[") != 1:
            continue
        number = int(key[3 : key.index("]")])
        valid = values.get(f"wz[{number}].gueltig")
        if valid is not None and not valid.value:
            continue
        inch = values.get(f"wz[{number}].mass_einheit")
        raw = as_int(value)
        radii[number] = (
            units.isg_inch_to_m(raw) if inch is not None and inch.value else units.isg_pos_to_m(raw)
        )
    return tuple(sorted(radii.items()))


def _zero_offsets(
    rd: ListReader, where: tuple[Path, Value | None] | None, axes: tuple[AxisParams, ...] | None
) -> tuple[tuple[tuple[int, tuple[float, ...]], ...], int, bool]:
    """Zero-offset groups 0..6 (G53, G54..G59) per channel axis j (np_grp[i].achse[j].versch,
    P-ZERO-00003; inaktiv hides an axis' offset, P-ZERO-00004)."""
    if where is None or axes is None:
        return (), 0, False
    values = rd.read(where[0], ZERO_OFFSET_KEYS, where[1])
    if values is None:
        return (), 0, False
    groups: dict[int, list[float]] = {}
    for key, value in values.items():
        if not key.endswith(".versch"):
            continue
        grp = int(key[len("np_grp[") : key.index("]")])
        axis = int(key[key.index("achse[") + 6 : key.rindex("]")])
        if axis >= len(axes):
            rd.error(value, f"axis index {axis}: the channel has {len(axes)} axes")
            continue
        if grp > 6:
            continue  # G159 groups are not emulated
        inactive = values.get(key.replace(".versch", ".inaktiv"))
        if inactive is not None and inactive.value:
            continue
        groups.setdefault(grp, [0.0] * len(axes))[axis] = units.isg_pos_to_m(as_int(value))
    default = values.get("default_index")
    default_index = as_int(default) if default is not None else 0
    if default is not None and default_index > 6:
        rd.error(default, "liftd emulates the zero offsets G53 … G59 (index 0 … 6)")
        default_index = 0
    g53 = values.get("g53_verfuegbar")
    return (
        tuple((g, tuple(v)) for g, v in sorted(groups.items())),
        default_index,
        bool(g53.value) if g53 is not None else False,
    )


def _read_axes(
    rd: ListReader, stup: TypedList, base: Path, chan: TypedList, startup: Path
) -> tuple[AxisParams, ...] | None:
    names: list[Value] = []
    numbers: list[Value] = []
    j = 0
    while f"gruppe[0].achse[{j}].bezeichnung" in chan:
        name = chan[f"gruppe[0].achse[{j}].bezeichnung"]
        nr = chan.get(f"gruppe[0].achse[{j}].log_achs_nr")
        if nr is None:
            rd.error(name, f"axis {name.value} has no gruppe[0].achse[{j}].log_achs_nr")
            return None
        names.append(name)
        numbers.append(nr)
        j += 1
    if not names:
        rd.error(None, "the channel list defines no path axes (gruppe[0].achse[j])", str(startup))
        return None
    count = chan.get("gruppe[0].achs_anzahl")
    if count is not None and count.value != len(names):
        rd.error(count, f"says {count.value} axes but {len(names)} are defined")
    seen_names: set[str] = set()
    for name in names:
        text = str(name.value)
        if len(text) != 1 or not text.isalpha() or text.upper() in "DFGHIJKLMNPRST":
            rd.error(
                name,
                "liftd needs single-letter axis names other than the addresses "
                "D F G H I J K L M N P R S T",
            )
        if text in seen_names:
            rd.error(name, "axis name used twice")
        seen_names.add(text)

    axis_lists: dict[int, TypedList] = {}
    defaults: TypedList = {}
    default_ref = stup.get("default_achs_mds")
    if default_ref is not None:
        defaults = rd.read(_resolve(base, default_ref), AXIS_KEYS, default_ref) or {}
    zahl = stup.get("zahl_mds")
    k = 0
    while f"achs_mds[{k}]" in stup and (zahl is None or k < as_int(zahl)):
        ref = stup[f"achs_mds[{k}]"]
        own = rd.read(_resolve(base, ref), AXIS_KEYS, ref)
        k += 1
        if own is None:
            continue
        merged = {**defaults, **own}
        nr_value = merged.get("kopf.achs_nr")
        log_nr = as_int(nr_value) if nr_value is not None else 1
        if log_nr in axis_lists:
            rd.error(nr_value or ref, f"logical axis number {log_nr} used by two axis lists")
        axis_lists[log_nr] = merged
    if zahl is not None and k < as_int(zahl):
        rd.error(zahl, f"zahl_mds is {zahl.value} but only {k} achs_mds[i] entries exist")

    axes: list[AxisParams] = []
    for name, nr_v in zip(names, numbers, strict=True):
        values = axis_lists.get(as_int(nr_v))
        if values is None:
            rd.error(nr_v, f"no axis list with kopf.achs_nr {nr_v.value}")
            continue
        axis = _axis(rd, str(name.value), as_int(nr_v), values)
        if axis is not None:
            axes.append(axis)
    return tuple(axes) if len(axes) == len(names) else None


def _axis(rd: ListReader, name: str, nr: int, v: TypedList) -> AxisParams | None:
    typ = v.get("kenngr.achs_typ")
    if typ is not None and typ.value != 1:
        rd.error(typ, f"axis {name}: liftd emulates translatory axes only (ACHSTYP_TRANSLATOR 0x1)")
        return None
    vb_max = int_of(v, "getriebe[0].dynamik.vb_max", 200000)
    a_max = int_of(v, "getriebe[0].dynamik.a_max", 1000)
    tr_min = int_of(v, "getriebe[0].dynamik.tr_min", 10000)
    swe_neg = int_of(v, "kenngr.swe_neg", -100000000)
    swe_pos = int_of(v, "kenngr.swe_pos", 100000000)
    if swe_neg >= swe_pos:
        rd.error(
            v.get("kenngr.swe_neg") or v.get("kenngr.swe_pos"),
            f"axis {name}: swe_neg ({swe_neg}) must be below swe_pos ({swe_pos})",
        )
        return None
    a = units.isg_acc_to_m_s2(a_max)
    return AxisParams(
        name=name,
        log_axis_nr=nr,
        v_max=units.isg_vel_to_m_s(vb_max),
        a_max=a,
        j_max=units.jerk_from_ramp(a, units.isg_time_to_s(tr_min)),
        sw_limit_neg=units.isg_pos_to_m(swe_neg),
        sw_limit_pos=units.isg_pos_to_m(swe_pos),
        dyn_a_warn=units.isg_permille_to_fraction(int_of(v, "kenngr.dyn_monitoring_a_warn", 500)),
        dyn_a_err=units.isg_permille_to_fraction(int_of(v, "kenngr.dyn_monitoring_a_err", 1000)),
        # block transitions (path/limits.py): defaults as the pages give them
        a_trans_weight=units.isg_permille_to_fraction(
            int_of(v, "getriebe[0].dynamik.a_trans_weight", 0)
        ),
        r_trans_weight=units.isg_permille_to_fraction(
            int_of(v, "getriebe[0].dynamik.r_trans_weight", 1000)
        ),
        j_trans_c0=real_of(v, "getriebe[0].dynamik.j_trans_c0", 0.0),
        j_trans_c1=real_of(v, "getriebe[0].dynamik.j_trans_c1", 0.0),
    )
