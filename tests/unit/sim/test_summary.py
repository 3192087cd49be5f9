"""The typed summaries: the JSON they give is docs/reference/design.md §3.3 (keys, their order, units), and
the comparison pairs lifts by start line and occurrence."""

from __future__ import annotations

import dataclasses
import json

from liftd.cnc.params import LiftMethod
from liftd.cnc.plc import Schedule
from liftd.sim.compare import compare, compare_summary
from liftd.sim.simulate import simulate
from tests.support.channel import make_channel

START = "G90 G17 G94\nG00 X10 Y10 Z0.001\n"
TWO_LIFTS = START + (
    "Z[LIFT_START POS=1 POS_LIMIT=40]\nG01 X100 F24000\nZ[LIFT_END]\n"
    "M04\nG01 Y20 F6000\nM05\n"
    "Z[LIFT_START POS=1 POS_LIMIT=40]\nG01 X10 F24000\nZ[LIFT_END]\nM30\n"
)
SUMMARY_KEYS = [  # §3.3 first, then liftd's extensions
    "cycle_time_s",
    "duration_s",
    "cycles",
    "method",
    "lifts",
    "limits",
    "z_overload",
    "errors",
    "step_cpu_us",
]
LIFT_KEYS = [
    "start_line",
    "end_line",
    "method",
    "suppressed",
    "z_start",
    "z_target",
    "pos_limit",
    "peak",
    "mean_clearance",
    "t_start",
    "t_end",
    "arrival_error",
    "path_delay_s",
    "duration_s",
    "z_a_max_ratio",
    "premature",
    "open",
]


def test_json_keys_in_contract_order_and_units_in_mm() -> None:
    res = simulate(make_channel(), TWO_LIFTS, Schedule(), 0.02)
    out = json.loads(json.dumps(res.summary.to_json()))
    assert list(out) == SUMMARY_KEYS
    assert [list(x) for x in out["lifts"]] == [LIFT_KEYS, LIFT_KEYS]
    first = res.summary.lifts[0]
    assert out["lifts"][0]["peak"] == first.peak_mm and 1.0 < first.peak_mm <= 40.0  # mm, not m
    assert first.height_mm == first.peak_mm - first.z_start_mm
    assert list(out["limits"])[:3] == ["z_v_max_ratio", "z_a_max_ratio", "z_j_max_ratio"]
    assert res.summary.limits.worst() == max(out["limits"].values())
    assert list(out["step_cpu_us"]) == ["p50", "p99", "p999", "max"]
    assert out["errors"] == [] and not res.program_error


def test_comparison_pairs_both_runs_and_its_json_holds_both_summaries() -> None:
    cmp = compare(make_channel(), TWO_LIFTS, Schedule(), 0.02, program="two.nc")
    s = cmp.summary
    assert [p.start_line for p in s.lifts] == [3, 9]
    for p in s.lifts:
        assert p.advanced is not None and p.lifting is not None
        assert p.advanced.method == "advanced" and p.lifting.method == "lifting"
        assert p.clearance_ratio == round(
            p.advanced.mean_clearance_mm / p.lifting.mean_clearance_mm, 6
        )
    out = s.to_json()
    assert list(out) == ["program", "cycle_time_s", "lifts", "totals", "advanced", "lifting"]
    assert out["totals"]["z_overload_cycles"] == {
        "advanced": s.advanced.z_overload.cycles,
        "lifting": s.lifting.z_overload.cycles,
    }
    assert out["advanced"] == s.advanced.to_json()


def test_a_run_stopped_early_leaves_its_partner_unpaired() -> None:
    adv = simulate(make_channel(), TWO_LIFTS, Schedule(), 0.02).summary
    lifting_ch = make_channel(method=LiftMethod.LIFTING)
    cut = TWO_LIFTS.split("M04")[0] + "M30\n"  # only the first lift
    lift = simulate(lifting_ch, cut, Schedule(), 0.02).summary
    s = compare_summary(adv, lift, "x.nc")
    assert [(p.advanced is not None, p.lifting is not None) for p in s.lifts] == [
        (True, True),
        (True, False),
    ]
    assert s.lifts[1].clearance_ratio is None and s.lifts[1].ref is s.lifts[1].advanced


def test_a_run_without_a_figure_keeps_no_series_and_the_same_summary() -> None:
    """`liftd simulate` without --plot skips the decimated series; nothing else changes."""
    plotted = simulate(make_channel(), TWO_LIFTS, Schedule(), 0.02)
    bare = simulate(make_channel(), TWO_LIFTS, Schedule(), 0.02, series=False)
    rows = plotted.series.rows
    assert rows.shape == (plotted.summary.cycles, 3 + 6)  # every cycle, below the capacity
    assert rows[-1][0] == plotted.summary.duration_s
    assert bare.series.rows.shape == (0, 9)

    def same(s: dict) -> dict:
        return {k: v for k, v in s.items() if k != "step_cpu_us"}  # a clock, not the run

    assert same(bare.summary.to_json()) == same(plotted.summary.to_json())


def test_a_lift_axis_other_than_z_keeps_its_limits_beside_a_path_axis_z() -> None:
    """A channel X Y Z W where W lifts: `z_*` is the lift axis (W), as the contract says, and
    the path axis Z gets keys of its own; before, Z's ratios overwrote W's under `z_*`."""
    ch = make_channel()
    w = dataclasses.replace(ch.axes[2], name="W", log_axis_nr=4, v_max=2.0)
    ch = dataclasses.replace(ch, axes=(*ch.axes, w), lift_axis="W")
    program = START + (
        "G00 W1\nW[LIFT_START POS=1 POS_LIMIT=40]\nG01 X100 F24000\nW[LIFT_END]\nG01 Z5 F600\nM30\n"
    )
    res = simulate(ch, program, Schedule(), 0.02)
    limits = res.summary.to_json()["limits"]
    assert isinstance(limits, dict)
    # one key per axis and derivative, and apart for the segments and the transitions (issue
    # 36), none lost
    assert len(limits) == 9 * len(ch.axes)
    assert limits["z_a_max_ratio"] > 0.99  # W at its acceleration limit while it lifts
    assert limits["z_v_max_ratio"] < 0.5  # W's v_max, not Z's
    assert 0.0 < limits["path_z_a_max_ratio"] < 0.5  # Z's slow feed move
