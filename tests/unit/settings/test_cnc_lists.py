"""Mapping of the ISG lists to channel parameters, and the lift activation rules."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

from liftd.cnc.params import LiftMethod, MSync, SlopeType
from liftd.settings import ConfigError, Severity, load_settings
from tests.support.paths import REPO

Machine = Callable[..., Path]


def errors_of(exc: ConfigError) -> list[str]:
    return [str(p) for p in exc.problems if p.severity is Severity.ERROR]


def test_shipped_config_in_si_units() -> None:
    s = load_settings(str(REPO / "config" / "liftd.toml"))
    ch = s.channel
    assert ch.axis_names == ("X", "Y", "Z")
    x, y, z = ch.axes
    assert (x.log_axis_nr, y.log_axis_nr, z.log_axis_nr) == (1, 2, 3)
    assert x.v_max == pytest.approx(1.5)  # 1500000 µm/s
    assert y.a_max == pytest.approx(8.0)  # 8000 mm/s²
    assert z.j_max == pytest.approx(10.0 / 0.02)  # a_max / tr_min (20000 µs)
    assert z.sw_limit_neg == pytest.approx(-0.005)  # -50000 × 0.1 µm
    assert z.sw_limit_pos == pytest.approx(0.15)
    assert (z.dyn_a_warn, z.dyn_a_err) == (pytest.approx(0.5), pytest.approx(1.0))
    assert ch.lift_method is LiftMethod.ADVANCED
    assert ch.lift_min_dist == pytest.approx(0.005)  # 50000 × 0.1 µm
    assert ch.cycle_time == pytest.approx(1e-3)
    assert ch.look_ahead_blocks == 120
    assert ch.slope is SlopeType.TRAPEZ  # from the default channel list
    assert ch.m_sync_of(4) is MSync.MVS_SVS and ch.m_sync_of(5) is MSync.MOS
    assert ch.max_radius_diff == pytest.approx(5e-6)
    assert s.warnings == ()


def test_lifting_variant() -> None:
    s = load_settings(str(REPO / "config" / "liftd-lifting.toml"))
    assert s.channel.lift_method is LiftMethod.LIFTING


def test_channel_list_overrides_default_list(machine: Machine) -> None:
    cfg = machine({"cnc/sda_mds1.lis": {"prog_start.slope.profile": "2"}})
    assert load_settings(str(cfg)).channel.slope is SlopeType.SIN2


def test_default_list_value_kept_when_channel_list_is_silent(machine: Machine) -> None:
    cfg = machine(
        {
            "cnc/default_sda.lis": {"lift_min_dist": "1234"},
            "cnc/sda_mds1.lis": {"lift_min_dist": None},
        }
    )
    assert load_settings(str(cfg)).channel.lift_min_dist == pytest.approx(1234e-7)


def test_channel_parameters_override_startup_flags(machine: Machine) -> None:
    # P-CHAN-00600/00650 are the channel-level alternatives of P-STUP-00060/00070.
    cfg = machine(
        {
            "cnc/hochlauf.lis": {
                "configuration.channel[0].path_preparation.function": "FCT_DEFAULT",
                "configuration.channel[0].interpolator.function": "FCT_IPO_DEFAULT",
            },
            "cnc/sda_mds1.lis": {
                "configuration.path_preparation.function": "FCT_DEFAULT | FCT_LIFT_UP_TIME",
                "configuration.interpolator.function": "FCT_LOOK_AHEAD_LOW | FCT_LIFT_UP_TIME",
            },
        }
    )
    ch = load_settings(str(cfg)).channel
    assert ch.lift_method is LiftMethod.ADVANCED
    assert ch.look_ahead_blocks == 30


@pytest.mark.parametrize(
    ("flags", "expect"),
    [("FCT_LOOK_AHEAD_HIGH", 190), ("FCT_IPO_DEFAULT", 120), ("FCT_LOOK_AHEAD_STANDARD", 120)],
)
def test_look_ahead_sizes(machine: Machine, flags: str, expect: int) -> None:
    cfg = machine(
        {
            "cnc/hochlauf.lis": {
                "configuration.channel[0].interpolator.function": f"{flags} | FCT_LIFT_UP_TIME"
            }
        }
    )
    assert load_settings(str(cfg)).channel.look_ahead_blocks == expect


def test_custom_look_ahead(machine: Machine) -> None:
    cfg = machine(
        {
            "cnc/hochlauf.lis": {
                "configuration.channel[0].interpolator.function": "FCT_LOOK_AHEAD_CUSTOM | FCT_LIFT_UP_TIME"
            },
            "cnc/sda_mds1.lis": {"configuration.interpolator.number_blocks_lah": "55"},
        }
    )
    assert load_settings(str(cfg)).channel.look_ahead_blocks == 55


def test_custom_look_ahead_under_the_older_startup_key(machine: Machine) -> None:
    # P-STUP-00071 in a list written for an older build: `interpolator.parameter`
    cfg = machine(
        {
            "cnc/hochlauf.lis": {
                "configuration.channel[0].interpolator.function": "FCT_LOOK_AHEAD_CUSTOM | FCT_LIFT_UP_TIME",
                "configuration.channel[0].interpolator.parameter": "45",
            },
        }
    )
    assert load_settings(str(cfg)).channel.look_ahead_blocks == 45


def test_custom_look_ahead_without_size_is_an_error(machine: Machine) -> None:
    cfg = machine(
        {
            "cnc/hochlauf.lis": {
                "configuration.channel[0].interpolator.function": "FCT_LOOK_AHEAD_CUSTOM | FCT_LIFT_UP_TIME"
            }
        }
    )
    with pytest.raises(ConfigError) as exc:
        load_settings(str(cfg))
    assert "number_blocks_lah" in errors_of(exc.value)[0]


PP = "configuration.channel[0].path_preparation.function"
IPO = "configuration.channel[0].interpolator.function"


@pytest.mark.parametrize(
    ("pp", "ipo", "time_based", "method"),
    [
        ("FCT_DEFAULT | FCT_LIFT_UP_TIME", "FCT_IPO_DEFAULT | FCT_LIFT_UP_TIME", "1", "advanced"),
        ("FCT_DEFAULT | FCT_LIFT_UP", "FCT_IPO_DEFAULT", "0", "lifting"),
        ("FCT_DEFAULT | FCT_LIFT_UP", "FCT_IPO_DEFAULT", None, "lifting"),
        ("FCT_DEFAULT", "FCT_IPO_DEFAULT", "0", "none"),
        ("FCT_DEFAULT", "FCT_IPO_DEFAULT", None, "none"),
    ],
)
def test_activation_rules(
    machine: Machine, pp: str, ipo: str, time_based: str | None, method: str
) -> None:
    cfg = machine(
        {
            "cnc/hochlauf.lis": {PP: pp, IPO: ipo},
            "cnc/sda_mds1.lis": {"enable_time_based_lift": time_based},
        }
    )
    assert load_settings(str(cfg)).channel.lift_method.value == method


@pytest.mark.parametrize(
    ("pp", "ipo", "time_based", "message", "line_key"),
    [
        (
            "FCT_DEFAULT",
            "FCT_IPO_DEFAULT",
            "1",
            "without FCT_LIFT_UP_TIME",
            "enable_time_based_lift",
        ),
        ("FCT_DEFAULT | FCT_LIFT_UP_TIME", "FCT_IPO_DEFAULT", "1", "interpolator functions", PP),
        ("FCT_DEFAULT", "FCT_IPO_DEFAULT | FCT_LIFT_UP_TIME", "1", "path-preparation", IPO),
        (
            "FCT_DEFAULT | FCT_LIFT_UP_TIME",
            "FCT_IPO_DEFAULT | FCT_LIFT_UP_TIME",
            "0",
            "needs enable_time_based_lift 1",
            "enable_time_based_lift",
        ),
        (
            "FCT_DEFAULT | FCT_LIFT_UP | FCT_LIFT_UP_TIME",
            "FCT_IPO_DEFAULT | FCT_LIFT_UP_TIME",
            "1",
            "exclude each other",
            PP,
        ),
        (
            "FCT_DEFAULT | FCT_LIFT_UP",
            "FCT_IPO_DEFAULT",
            "1",
            "path-based Lifting (FCT_LIFT_UP) needs 0",
            "enable_time_based_lift",
        ),
    ],
)
def test_inconsistent_activation_is_a_configuration_error(
    machine: Machine, pp: str, ipo: str, time_based: str, message: str, line_key: str
) -> None:
    cfg = machine(
        {
            "cnc/hochlauf.lis": {PP: pp, IPO: ipo},
            "cnc/sda_mds1.lis": {"enable_time_based_lift": time_based},
        }
    )
    with pytest.raises(ConfigError) as exc:
        load_settings(str(cfg))
    errs = [p for p in exc.value.problems if p.severity is Severity.ERROR]
    assert len(errs) == 1
    assert message in errs[0].message
    assert errs[0].key == line_key and errs[0].line is not None


def test_fct_lift_up_is_not_an_interpolator_flag(machine: Machine) -> None:
    cfg = machine({"cnc/hochlauf.lis": {IPO: "FCT_IPO_DEFAULT | FCT_LIFT_UP"}})
    with pytest.raises(ConfigError) as exc:
        load_settings(str(cfg))
    assert "unknown flag 'FCT_LIFT_UP'" in errors_of(exc.value)[0]


def test_missing_axis_list_names_the_referencing_line(machine: Machine) -> None:
    cfg = machine({"cnc/hochlauf.lis": {"achs_mds[2]": "nowhere/achsmds3.lis"}})
    with pytest.raises(ConfigError) as exc:
        load_settings(str(cfg))
    errs = errors_of(exc.value)
    assert any(
        "hochlauf.lis:" in e
        and "achs_mds[2]" in e
        and "cannot read list file" in e
        and "No such file" in e
        for e in errs
    )


def test_relative_paths_are_relative_to_the_startup_list(machine: Machine, tmp_path: Path) -> None:
    cfg = machine()
    (tmp_path / "config" / "cnc" / "axes").mkdir()
    (tmp_path / "config" / "cnc" / "achsmds3.lis").rename(
        tmp_path / "config" / "cnc" / "axes" / "z.lis"
    )
    cfg = machine({"cnc/hochlauf.lis": {"achs_mds[2]": "axes\\z.lis"}})  # Windows separators too
    assert load_settings(str(cfg)).channel.axis("Z").v_max == pytest.approx(1.0)


def test_path_axis_without_axis_list(machine: Machine) -> None:
    cfg = machine({"cnc/sda_mds1.lis": {"gruppe[0].achse[2].log_achs_nr": "7"}})
    with pytest.raises(ConfigError) as exc:
        load_settings(str(cfg))
    assert "no axis list with kopf.achs_nr 7" in errors_of(exc.value)[0]


def test_out_of_range_and_inverted_limits(machine: Machine) -> None:
    cfg = machine(
        {"cnc/achsmds3.lis": {"getriebe[0].dynamik.a_max": "0", "kenngr.swe_neg": "2000000"}}
    )
    with pytest.raises(ConfigError) as exc:
        load_settings(str(cfg))
    errs = errors_of(exc.value)
    assert any(
        "achsmds3.lis" in e and "getriebe[0].dynamik.a_max = '0'" in e and "out of range" in e
        for e in errs
    )
    assert any("swe_neg (2000000) must be below swe_pos" in e for e in errs)


def test_unknown_m_synch(machine: Machine) -> None:
    cfg = machine({"cnc/default_sda.lis": {"m_synch[9]": "MVS_BOGUS"}})
    with pytest.raises(ConfigError) as exc:
        load_settings(str(cfg))
    assert "m_synch[9] = 'MVS_BOGUS'" in errors_of(exc.value)[0]


def test_unknown_keys_are_warnings_not_errors(machine: Machine) -> None:
    cfg = machine({"cnc/achsmds1.lis": {"getriebe[0].fantasy": "1"}})
    s = load_settings(str(cfg))
    assert [w.key for w in s.warnings] == ["getriebe[0].fantasy"]


def test_lift_axis_must_be_a_channel_axis(machine: Machine) -> None:
    cfg = machine()
    cfg.write_text(cfg.read_text().replace('lift_axis = "Z"', 'lift_axis = "A"'))
    with pytest.raises(ConfigError) as exc:
        load_settings(str(cfg))
    (err,) = errors_of(exc.value)
    assert err.startswith(f"{cfg}:8: cnc.lift_axis = 'A' error: not an axis of channel 1")


def test_an_unreadable_tool_list_hides_no_other_problem(machine: Machine) -> None:
    cfg = machine()
    cfg.write_text('[cnc]\nstartup_list = "cnc/hochlauf.lis"\nchannel = 7\n'
                   '[nc]\ntool_list = "nope.lis"\n')  # fmt: skip
    with pytest.raises(ConfigError) as exc:
        load_settings(str(cfg))
    errors = errors_of(exc.value)
    assert any(
        ":5: nc.tool_list = 'nope.lis' error: cannot read the tool list" in e for e in errors
    )
    assert any(":3: cnc.channel = '7' error:" in e for e in errors), errors


def test_a_nul_in_a_list_name_is_a_configuration_error_not_a_traceback(machine: Machine) -> None:
    cfg = machine()
    cfg.write_text('[cnc]\nstartup_list = "cnc/hochlauf.lis"\n[nc]\ntool_list = "a\\u0000b"\n')
    with pytest.raises(ConfigError) as exc:  # ValueError (embedded null byte) escaped
        load_settings(str(cfg))
    assert ":4: nc.tool_list = " in errors_of(exc.value)[0]


def test_an_older_look_ahead_key_out_of_range_is_one_error(machine: Machine) -> None:
    cfg = machine(
        {
            "cnc/hochlauf.lis": {
                "configuration.channel[0].interpolator.function": "FCT_LOOK_AHEAD_CUSTOM | FCT_LIFT_UP_TIME",
                "configuration.channel[0].interpolator.parameter": "300",
            },
        }
    )
    with pytest.raises(ConfigError) as exc:
        load_settings(str(cfg))
    errors = errors_of(exc.value)
    assert len(errors) == 1 and "interpolator.parameter" in errors[0], errors


def test_block_transition_parameters_are_read_with_their_documented_defaults(
    machine: Machine,
) -> None:
    """Issue 36: P-AXIS-00013/00154/00339/00340 per axis, P-CHAN-00009/00117 per channel,
    defaults as the TF5200 pages give them (0, 1000, 0, 0; off, 0)."""
    ch = load_settings(str(REPO / "config" / "liftd.toml")).channel
    x = ch.axis("X")
    assert (x.a_trans_weight, x.r_trans_weight, x.j_trans_c0, x.j_trans_c1) == (0, 1.0, 0, 0)
    assert (ch.corr_v_trans_jerk, ch.mode_trans_jerk) == (False, 0)
    cfg = machine({
        "cnc/achsmds1.lis": {"getriebe[0].dynamik.a_trans_weight": "250",
                             "getriebe[0].dynamik.r_trans_weight": "0",
                             "getriebe[0].dynamik.j_trans_c0": "1500.5"},
        "cnc/sda_mds1.lis": {"corr_v_trans_jerk": "1", "mode_trans_jerk": "2"},
    })  # fmt: skip
    ch = load_settings(str(cfg)).channel
    x = ch.axis("X")
    assert (x.a_trans_weight, x.r_trans_weight, x.j_trans_c0) == (0.25, 0.0, 1500.5)
    assert (ch.corr_v_trans_jerk, ch.mode_trans_jerk) == (True, 2)


@pytest.mark.parametrize(
    ("file", "key", "value"),
    [
        ("cnc/achsmds1.lis", "getriebe[0].dynamik.a_trans_weight", "1001"),
        ("cnc/achsmds2.lis", "getriebe[0].dynamik.r_trans_weight", "-1"),
        ("cnc/achsmds1.lis", "getriebe[0].dynamik.j_trans_c1", "-0.5"),
        ("cnc/achsmds1.lis", "getriebe[0].dynamik.j_trans_c0", "fast"),
        ("cnc/sda_mds1.lis", "mode_trans_jerk", "3"),
        ("cnc/sda_mds1.lis", "corr_v_trans_jerk", "2"),
    ],
)
def test_block_transition_parameters_out_of_their_range_are_configuration_errors(
    machine: Machine, file: str, key: str, value: str
) -> None:
    cfg = machine({file: {key: value}})
    with pytest.raises(ConfigError) as exc:
        load_settings(str(cfg))
    errs = errors_of(exc.value)
    assert any(Path(file).name in e and f"{key} = '{value}'" in e for e in errs), errs
