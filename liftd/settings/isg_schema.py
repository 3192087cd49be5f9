"""Which ISG list keys liftd knows, their types and ranges, and typing of raw entries.

Key names, types and ranges follow the Beckhoff TF5200 parameter pages cited in
docs/reference/isg-cnc.md §3 (P-STUP-*, P-CHAN-*, P-AXIS-*). Keys that liftd recognises but does not
use are accepted silently (`Kind.KNOWN`); keys nobody knows are warnings, as the CNC does
("unknown entries are ignored with a warning", docs/reference/isg-cnc.md §3.1).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from enum import Enum

from liftd.settings.isg_list import ParsedList, Problem, RawEntry, Severity, parse_number


class Kind(Enum):
    INT = "integer"
    BOOL = "boolean (0/1)"
    STR = "string"
    PATH = "file name"
    FLAGS = "flag set"
    KNOWN = "recognised, not used by liftd"
    REAL = "number"


# P-STUP-00060 / P-CHAN-00600 path-preparation flags (TF5200 lift_axis/223161995.html)
PATH_PREP_FLAGS = frozenset(
    {
        "FCT_DEFAULT",
        "FCT_FFM",
        "FCT_PRESEGMENTATION",
        "FCT_SPLINE",
        "FCT_POLY",
        "FCT_CAX",
        "FCT_CAX_TRACK",
        "FCT_SEGMENTATION",
        "FCT_LIFT_UP",
        "FCT_EMF",
        "FCT_EMF_POLY_OFF",
        "FCT_SYNC",
        "FCT_PRECON",
        "FCT_LIFT_UP_TIME",
        "FCT_PTP",
        "FCT_M_PRE_OUTPUT",
        "FCT_SURFACE",
        "FCT_SEG_CHECK",
        "FCT_NIBBLING",
        "FCT_PUNCHING",
        "FCT_VSM",
    }
)
# P-STUP-00070 / P-CHAN-00650 interpolator flags (TF5200 channel_parameter/828925963.html)
IPO_FLAGS = frozenset(
    {
        "FCT_IPO_DEFAULT",
        "FCT_DEFAULT",
        "FCT_LOOK_AHEAD_LOW",
        "FCT_LOOK_AHEAD_STANDARD",
        "FCT_LOOK_AHEAD_HIGH",
        "FCT_LOOK_AHEAD_CUSTOM",
        "FCT_SYNC",
        "FCT_LOOK_AHEAD_OPT",
        "FCT_LIFT_UP_TIME",
        "FCT_SHIFT_NCBL",
        "FCT_CALC_STATE_AT_T",
        "FCT_CALC_TIME",
        "FCT_CONTOUR_LAH",
        "FCT_DYN_POS_LIMIT",
        "FCT_EXTENSION_EQUIDIST",
    }
)
# P-CHAN-00041 m_synch[i] names (TF5200 channel_parameter/148909195.html)
M_SYNCH_NAMES = {
    "NO_SYNCH": 0x0,
    "MOS": 0x1,
    "MVS_SVS": 0x2,
    "MVS_SNS": 0x4,
    "MNS_SNS": 0x8,
    "MNE_SNS": 0x20,
    "MOS_TS": 0x10,
    "MEP_SVS": 0x40,
    "MET_SVS": 0x80,
    "MVS_SLM": 0x4000,
}

U32 = (0, 0xFFFFFFFF)
S32 = (-(2**31), 2**31 - 1)


@dataclass(frozen=True, slots=True)
class KeySpec:
    pattern: re.Pattern[str]
    kind: Kind
    bounds: tuple[float, float] | None = None
    flags: frozenset[str] | None = None


def _spec(
    pattern: str,
    kind: Kind,
    bounds: tuple[float, float] | None = None,
    flags: frozenset[str] | None = None,
) -> KeySpec:
    regex = re.escape(pattern).replace(r"\[i\]", r"\[\d+\]")
    return KeySpec(re.compile(regex + r"\Z"), kind, bounds, flags)


STARTUP_KEYS = (
    _spec("kanal_anzahl", Kind.INT, (1, 12)),  # P-STUP-00001
    _spec("listen", Kind.KNOWN),  # P-STUP-00008
    _spec("configuration", Kind.KNOWN),
    _spec("default_sda_mds", Kind.PATH),  # P-STUP-00034
    _spec("sda_mds[i]", Kind.PATH),  # P-STUP-00009
    _spec("zahl_mds", Kind.INT, (0, 32)),  # P-STUP-00014
    _spec("achs_mds[i]", Kind.PATH),  # P-STUP-00015
    _spec("default_achs_mds", Kind.PATH),  # P-STUP-00035
    _spec("hand_mds", Kind.KNOWN),
    _spec("werkz_data[i]", Kind.PATH),  # P-STUP-00010: tool list per channel
    _spec("nullp_data[i]", Kind.PATH),  # P-STUP-00011: zero-offset list per channel
    _spec("pzv_data[i]", Kind.KNOWN),
    _spec("zahl_kw", Kind.KNOWN),
    _spec("achs_kw[i]", Kind.KNOWN),
    _spec("configuration.channel[i].path_preparation.function", Kind.FLAGS, None, PATH_PREP_FLAGS),
    _spec("configuration.channel[i].interpolator.function", Kind.FLAGS, None, IPO_FLAGS),
    # P-STUP-00071 / P-CHAN-00653: [0; 200] as the vendor's lift text §4.2.1 and the start-up
    # list page give it (https://infosys.beckhoff.com/content/1033/tccncstartuplist/
    # 15280831883.html); later builds allow more (500, 10000 with STEP slopes), not liftd
    _spec("configuration.channel[i].interpolator.number_blocks_lah", Kind.INT, (0, 200)),
    # P-STUP-00071's older key (docs/reference/isg-cnc.md §3.2 [S42]): the same size, the same range
    _spec("configuration.channel[i].interpolator.parameter", Kind.INT, (0, 200)),
)

CHANNEL_KEYS = (
    _spec("lift_min_dist", Kind.INT, U32),  # P-CHAN-00244, 0.1 µm
    _spec("enable_time_based_lift", Kind.BOOL),  # P-CHAN-00345
    _spec("configuration.path_preparation.function", Kind.FLAGS, None, PATH_PREP_FLAGS),
    _spec("configuration.interpolator.function", Kind.FLAGS, None, IPO_FLAGS),
    _spec("configuration.interpolator.number_blocks_lah", Kind.INT, (0, 200)),  # 00653
    _spec("configuration.interpolator.blocks_per_call", Kind.KNOWN),  # P-CHAN-00654
    _spec("grp_anzahl", Kind.INT, (1, 1)),  # P-CHAN-00023: one axis group only
    _spec("gruppe[0].bezeichnung", Kind.STR),
    _spec("gruppe[0].achs_anzahl", Kind.INT, (0, 32)),
    _spec("gruppe[0].achse[i].bezeichnung", Kind.STR),  # P-CHAN-00006
    _spec("gruppe[0].achse[i].log_achs_nr", Kind.INT, (1, 65535)),  # P-CHAN-00035
    _spec("prog_start.slope.profile", Kind.INT, (0, 3)),  # P-CHAN-00071
    _spec("prog_start.slope.ramp_time", Kind.KNOWN),
    _spec("prog_start.slope.acceleration", Kind.KNOWN),
    _spec("max_radius_diff_circle", Kind.INT, (0, 10000)),  # P-CHAN-00171, 0.1 µm
    _spec("max_proz_radius_diff_circle", Kind.KNOWN),
    _spec("m_synch[i]", Kind.STR),  # P-CHAN-00041
    # block transitions (issue 36, path/limits.py): P-CHAN-00009 corr_v_trans_jerk
    # (tf5200_channel_parameter/149316875.html), P-CHAN-00117 mode_trans_jerk 0/1/2
    # (tf5200_channel_parameter/149319947.html)
    _spec("corr_v_trans_jerk", Kind.BOOL),
    _spec("mode_trans_jerk", Kind.INT, (0, 2)),
    _spec("vector.velocity", Kind.KNOWN),
    _spec("vector.acceleration", Kind.KNOWN),
    _spec("vector.deceleration", Kind.KNOWN),
    _spec("vector.acc_dec_unit", Kind.KNOWN),
    _spec("bezeichnung", Kind.KNOWN),
)

AXIS_KEYS = (
    _spec("kopf.achs_nr", Kind.INT, (1, 65534)),  # P-AXIS-00016
    _spec("kopf.achs_name", Kind.KNOWN),
    _spec("kenngr.achs_typ", Kind.INT, (1, 4)),  # P-AXIS-00018, 0x1 translatory
    _spec("kenngr.achs_mode", Kind.KNOWN),
    _spec("kenngr.antr_typ", Kind.KNOWN),
    _spec("getriebe[i].dynamik.vb_max", Kind.INT, (1, 0xFFFFFFFF)),  # P-AXIS-00212, µm/s
    _spec("getriebe[i].dynamik.a_max", Kind.INT, (1, 100_000_000)),  # P-AXIS-00008, mm/s²
    _spec("getriebe[i].dynamik.tr_min", Kind.INT, U32),  # P-AXIS-00201, µs
    _spec("getriebe[i].dynamik.tr_geom", Kind.KNOWN),
    _spec("getriebe[i].dynamik.a_emergency", Kind.KNOWN),
    # block transitions (issue 36, path/limits.py), 0.1 %: P-AXIS-00013 a_trans_weight, its
    # page gives the range 1 … 1000 and the default 0 (= cycle time / ramp time), so 0 … 1000
    # (tf5200_axis_parameter/117648395.html); P-AXIS-00154 r_trans_weight 0 … 1000, default
    # 1000 (117667595.html); P-AXIS-00339/00340 j_trans_c0/c1, REAL64 m/s³, 0 … MAX(UNS32),
    # default 0 (131314059.html, 131315979.html)
    _spec("getriebe[i].dynamik.a_trans_weight", Kind.INT, (0, 1000)),
    _spec("getriebe[i].dynamik.r_trans_weight", Kind.INT, (0, 1000)),
    _spec("getriebe[i].dynamik.j_trans_c0", Kind.REAL, (0, 0xFFFFFFFF)),
    _spec("getriebe[i].dynamik.j_trans_c1", Kind.REAL, (0, 0xFFFFFFFF)),
    _spec("getriebe[i].slope_profil.tr_beschl_zu", Kind.KNOWN),
    _spec("getriebe[i].slope_profil.tr_brems_zu", Kind.KNOWN),
    _spec("kenngr.swe_neg", Kind.INT, S32),  # P-AXIS-00177, 0.1 µm
    _spec("kenngr.swe_pos", Kind.INT, S32),  # P-AXIS-00178, 0.1 µm
    _spec("kenngr.swe_toleranz", Kind.KNOWN),
    _spec("kenngr.dyn_monitoring_v_warn", Kind.KNOWN),
    _spec("kenngr.dyn_monitoring_v_err", Kind.KNOWN),
    _spec("kenngr.dyn_monitoring_a_warn", Kind.INT, U32),  # P-AXIS-00441, 0.1 %
    _spec("kenngr.dyn_monitoring_a_err", Kind.INT, U32),  # P-AXIS-00442, 0.1 %
    _spec("kenngr.dyn_monitoring_j_warn", Kind.KNOWN),
    _spec("kenngr.dyn_monitoring_j_err", Kind.KNOWN),
    _spec("handbetrieb.hb.vb_max", Kind.KNOWN),
)


# Tool list (werkz_data[i]): TF5200 tool data P-TOOL-*, e.g. wz[5].radius 200000 = 20 mm
# https://infosys.beckhoff.com/content/1033/tf5200_tool_data/104778123.html
TOOL_KEYS_NOT_READ = (  # known to the CNC, not read by liftd
    "laenge", "ax_versatz[i]", "log_ax_nr_spdl", "vb_min", "vb_max", "a_max", "param[i]",
    "path[i].radius",
)  # fmt: skip
TOOL_KEYS = (
    _spec("wz[i].radius", Kind.INT, S32),  # P-TOOL-00004, 0.1 µm (0.0001 inch)
    _spec("wz[i].gueltig", Kind.BOOL),  # validity flag
    _spec("wz[i].mass_einheit", Kind.BOOL),  # 0 mm, 1 inch
    *(_spec(f"wz[i].{key}", Kind.KNOWN) for key in TOOL_KEYS_NOT_READ),
)

# Zero-offset list (nullp_data[i]): TF5200 zero offsets P-ZERO-*
# https://infosys.beckhoff.com/content/1033/tf5200_zero_offsets/103724043.html
ZERO_OFFSET_KEYS = (
    _spec("g53_verfuegbar", Kind.BOOL),  # P-ZERO-00001: G53 data block used as an offset
    _spec("default_index", Kind.INT, (0, 96)),  # P-ZERO-00002: group active at start
    _spec("np_grp[i].achse[i].versch", Kind.INT, S32),  # P-ZERO-00003, 0.1 µm
    _spec("np_grp[i].achse[i].inaktiv", Kind.BOOL),  # P-ZERO-00004: offset not applied
)


@dataclass(frozen=True, slots=True)
class Value:
    """A typed list value and the raw entry it came from (for messages)."""

    value: int | float | bool | str | frozenset[str]
    entry: RawEntry


TypedList = dict[str, Value]


def _bound(x: float) -> str:
    return str(int(x)) if float(x).is_integer() else f"{x:g}"


def _type_entry(entry: RawEntry, spec: KeySpec, problems: list[Problem]) -> Value | None:
    def bad(message: str) -> None:
        problems.append(
            Problem(Severity.ERROR, entry.file, entry.line, entry.key, entry.value, message)
        )

    if spec.kind in (Kind.INT, Kind.BOOL):
        number = parse_number(entry.value) if entry.numeric else None
        if not isinstance(number, int):
            bad(f"expected an {'integer' if spec.kind is Kind.INT else 'boolean 0 or 1'}")
            return None
        if spec.kind is Kind.BOOL:
            if number not in (0, 1):
                bad("expected a boolean 0 or 1")
                return None
            return Value(bool(number), entry)
        if spec.bounds is not None and not spec.bounds[0] <= number <= spec.bounds[1]:
            bad(f"out of range [{_bound(spec.bounds[0])}, {_bound(spec.bounds[1])}]")
            return None
        return Value(number, entry)
    if spec.kind is Kind.REAL:
        real = parse_number(entry.value) if entry.numeric else None
        if real is None:
            bad("expected a number")
            return None
        if spec.bounds is not None and not spec.bounds[0] <= real <= spec.bounds[1]:
            bad(f"out of range [{_bound(spec.bounds[0])}, {_bound(spec.bounds[1])}]")
            return None
        return Value(float(real), entry)
    if spec.kind is Kind.FLAGS:
        tokens = [tok.strip() for tok in entry.value.split("|")]
        if any(not tok for tok in tokens):
            bad("empty flag in a '|'-joined flag set")
            return None
        allowed = spec.flags or frozenset()
        unknown = [tok for tok in tokens if tok not in allowed]
        if unknown:
            bad(f"unknown flag {unknown[0]!r} (known: {', '.join(sorted(allowed))})")
            return None
        return Value(frozenset(tokens), entry)
    if spec.kind is Kind.PATH:
        return Value(entry.value.replace("\\", "/"), entry)
    return Value(entry.value, entry)


def type_list(parsed: ParsedList, specs: tuple[KeySpec, ...]) -> tuple[TypedList, list[Problem]]:
    """Type every entry of a parsed list against `specs`; unknown keys become warnings."""
    problems = list(parsed.problems)
    values: TypedList = {}
    for entry in parsed.entries:
        spec = next((s for s in specs if s.pattern.match(entry.key)), None)
        if spec is None:
            problems.append(
                Problem(
                    Severity.WARNING,
                    entry.file,
                    entry.line,
                    entry.key,
                    entry.value,
                    "unknown parameter, ignored",
                )
            )
            continue
        if spec.kind is Kind.KNOWN:
            continue
        if entry.key in values:
            first = values[entry.key].entry
            problems.append(
                Problem(
                    Severity.WARNING,
                    entry.file,
                    entry.line,
                    entry.key,
                    entry.value,
                    f"given again (first at line {first.line}); the last value is used",
                )
            )
        typed = _type_entry(entry, spec, problems)
        if typed is not None:
            values[entry.key] = typed
    return values, problems


def parse_m_synch(text: str) -> int | None:
    """m_synch values are a name (MVS_SVS), a hex/decimal number, or names joined by '|'."""
    total = 0
    for part in text.split("|"):
        words = part.split()
        if not words:
            return None
        tok = words[0]  # "MNS_SNS 0x00000008": the name, then its value as a note
        number = parse_number(tok)
        if isinstance(number, int):
            total |= number
        elif tok in M_SYNCH_NAMES:
            total |= M_SYNCH_NAMES[tok]
        else:
            return None
    return total
