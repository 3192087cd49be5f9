"""What a channel's function flags and parameters make the CNC do, by the vendor's rules: which
lift method is active (FCT_LIFT_UP_TIME / FCT_LIFT_UP with enable_time_based_lift), how many
blocks the look-ahead holds (FCT_LOOK_AHEAD_*, P-CHAN-00653), how each M function is
synchronised (m_synch). Inconsistent settings are reported where they are written."""

from __future__ import annotations

from liftd.cnc.params import LiftMethod, MSync
from liftd.settings.isg_schema import TypedList, Value, parse_m_synch
from liftd.settings.list_reader import ListReader, as_int

# Look-ahead sizes per interpolator flag, CNC builds ≥ V2.11.2800 (vendor text §4.2.1).
LOOK_AHEAD_BLOCKS = {
    "FCT_LOOK_AHEAD_LOW": 30,
    "FCT_LOOK_AHEAD_STANDARD": 120,
    "FCT_LOOK_AHEAD_HIGH": 190,
}
DEFAULT_LOOK_AHEAD = 120  # FCT_IPO_DEFAULT = FCT_LOOK_AHEAD_STANDARD
LIFT_FLAG_TIME = "FCT_LIFT_UP_TIME"
LIFT_FLAG_PATH = "FCT_LIFT_UP"


def lift_method_of(
    rd: ListReader,
    pp: frozenset[str],
    ipo: frozenset[str],
    pp_ref: Value | None,
    ipo_ref: Value | None,
    enable_time: Value | None,
) -> LiftMethod:
    """Activation rules (vendor text §1, §2.1.2, §2.2.2, §4.2; docs/reference/design.md §3.4)."""
    time_based = bool(enable_time.value) if enable_time is not None else False
    where = pp_ref or ipo_ref or enable_time
    if LIFT_FLAG_TIME in pp and LIFT_FLAG_PATH in pp:
        rd.error(pp_ref, "FCT_LIFT_UP_TIME and FCT_LIFT_UP exclude each other; choose one method")
        return LiftMethod.NONE
    if LIFT_FLAG_TIME in pp or LIFT_FLAG_TIME in ipo:
        if LIFT_FLAG_TIME not in pp:
            rd.error(
                ipo_ref,
                "FCT_LIFT_UP_TIME must also be set in the path-preparation "
                "functions (P-STUP-00060 or P-CHAN-00600)",
            )
        elif LIFT_FLAG_TIME not in ipo:
            rd.error(
                pp_ref,
                "FCT_LIFT_UP_TIME must also be set in the interpolator functions "
                "(P-STUP-00070 or P-CHAN-00650)",
            )
        elif not time_based:
            rd.error(
                enable_time or where,
                "FCT_LIFT_UP_TIME (Advanced Lifting) needs enable_time_based_lift 1 (P-CHAN-00345)",
            )
        return LiftMethod.ADVANCED
    if LIFT_FLAG_PATH in pp:
        if time_based:
            rd.error(
                enable_time,
                "enable_time_based_lift 1 needs FCT_LIFT_UP_TIME in "
                "P-STUP-00060 and P-STUP-00070; path-based Lifting (FCT_LIFT_UP) needs 0",
            )
        return LiftMethod.LIFTING
    if time_based:
        rd.error(
            enable_time,
            "enable_time_based_lift 1 without FCT_LIFT_UP_TIME in "
            "P-STUP-00060 and P-STUP-00070 (or P-CHAN-00600/00650)",
        )
    return LiftMethod.NONE


def look_ahead_of(
    rd: ListReader,
    ipo: frozenset[str],
    ipo_ref: Value | None,
    chan: TypedList,
    stup: TypedList,
    idx: int,
) -> int:
    sizes = [LOOK_AHEAD_BLOCKS[f] for f in ipo if f in LOOK_AHEAD_BLOCKS]
    custom = "FCT_LOOK_AHEAD_CUSTOM" in ipo
    if len(sizes) + int(custom) > 1:
        rd.error(ipo_ref, "more than one FCT_LOOK_AHEAD_* size selected")
        return DEFAULT_LOOK_AHEAD
    if custom:
        # P-CHAN-00653, else P-STUP-00071 under its key, else under its older key `.parameter`
        # (tf5200_startup_list/1238935151133070859: docs/reference/isg-cnc.md §3.2 [S42])
        value = (
            chan.get("configuration.interpolator.number_blocks_lah")
            or stup.get(f"configuration.channel[{idx}].interpolator.number_blocks_lah")
            or stup.get(f"configuration.channel[{idx}].interpolator.parameter")
        )
        if value is None:
            sizes_keys = (".number_blocks_lah", ".interpolator.parameter")
            if not any(p.key and p.key.endswith(sizes_keys) for p in rd.problems):
                # (a value out of range is reported where it is written, once)
                rd.error(ipo_ref, "FCT_LOOK_AHEAD_CUSTOM needs number_blocks_lah (P-CHAN-00653)")
            return DEFAULT_LOOK_AHEAD
        # 0 blocks (allowed by vendor §4.2.1, its meaning not documented): no look-ahead
        # beyond the block being run, the path planned one block at a time -- it can stop at
        # every block end -- which the interpolator gets as a window of one block
        return max(1, as_int(value))
    return sizes[0] if sizes else DEFAULT_LOOK_AHEAD


def m_synch_of(rd: ListReader, chan: TypedList) -> tuple[tuple[int, MSync], ...]:
    result: list[tuple[int, MSync]] = []
    for key, value in chan.items():
        if not key.startswith("m_synch["):
            continue
        number = int(key[len("m_synch[") : -1])
        if number > 999:
            rd.error(value, "M function numbers are 0..999")
            continue
        code = parse_m_synch(str(value.value))
        kind = next((k for k in MSync if k.value == code), None)
        if kind is None:
            rd.error(
                value,
                "unknown or unsupported synchronisation; liftd emulates NO_SYNCH, MOS, MVS_SVS, "
                "MVS_SNS, MNS_SNS and MNE_SNS",
            )
            continue
        result.append((number, kind))
    return tuple(sorted(result, key=lambda item: item[0]))
