"""`--compare`'s per-lift samples (the figure's data) stay bounded on a lift of any length and
keep what the figure shows: Z's course, its peak acceleration (the over-limit marks), the
cycles before and after; a study keeps none of them and gets the same summary."""

from __future__ import annotations

import numpy as np
import pytest

from liftd.cnc.plc import Schedule
from liftd.settings import load_settings
from liftd.sim import compare as compare_module
from liftd.sim.compare import MAX_ROWS, Comparison, LiftSamples, as_arrays, compare
from tests.support.paths import REPO

CH = load_settings(str(REPO / "config" / "liftd.toml")).channel
# one lift range of ~41 s (Advanced) / ~44 s (path-based): ~10 × MAX_ROWS cycles
LONG_LIFT = (
    "G90 G01 X10 Y10 Z1 F6000\nZ[LIFT_START POS=20 POS_LIMIT=25]\nG01 X100 F300\n"
    "G01 X110 Y20 F300\nG01 X200 F300\nZ[LIFT_END]\nG01 X210\nM30\n"
)


def test_a_lift_of_any_length_keeps_at_most_two_max_rows_with_its_peak() -> None:
    lift = LiftSamples(3)
    n = 11 * MAX_ROWS + 17
    for i in range(n):
        a = 50.0 if i == 7 * MAX_ROWS + 5 else np.sin(i * 1e-3)
        lift.push((i * 1e-3, i * 1e-4, i * 1e-5, a))
    lift.close()
    rows = as_arrays(lift)
    assert len(rows) <= 2 * MAX_ROWS
    assert len(rows) >= MAX_ROWS  # halved, not emptied
    assert np.all(np.diff(rows[:, 0]) > 0)  # in time order
    assert rows[0, 0] < lift.stride * 1e-3 and rows[-1, 0] > (n - 2 * lift.stride) * 1e-3  # ends
    assert rows[:, 3].max() == 50.0  # the spike survives every halving


def _both(plot: bool) -> tuple[Comparison, Comparison]:
    return (
        compare(CH, LONG_LIFT, Schedule(), 0.02, max_time=120.0, plot=plot),
        compare(CH, LONG_LIFT, Schedule(), 0.02, max_time=120.0, batch=False, plot=plot),
    )


def test_a_long_lift_is_sampled_within_the_bound_as_by_single_steps(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    got, single = _both(True)
    monkeypatch.setattr(compare_module, "MAX_ROWS", 10**9)
    full = compare(CH, LONG_LIFT, Schedule(), 0.02, max_time=120.0)
    for method in ("advanced", "lifting"):
        (lift,) = got.samples[method].lifts
        assert repr(lift) == repr(single.samples[method].lifts[0])  # batches = single steps
        rows, every = as_arrays(lift), as_arrays(full.samples[method].lifts[0])
        assert len(every) > 8 * MAX_ROWS  # the lift is long enough to be halved
        assert len(rows) <= 2 * MAX_ROWS
        assert rows[0, 0] < every[0, 0] + lift.stride * CH.cycle_time  # MARGIN cycles before
        assert rows[-1, 0] >= every[-1, 0] - lift.stride * CH.cycle_time
        assert np.abs(rows[:, 3]).max() == np.abs(every[:, 3]).max()  # the peak a_z
        assert rows[:, 2].max() == pytest.approx(every[:, 2].max(), abs=1e-6)  # Z's top


def test_a_study_keeps_no_samples_and_gets_the_same_summary() -> None:
    with_plot = compare(CH, LONG_LIFT, Schedule(), 0.02, max_time=120.0)
    without = compare(CH, LONG_LIFT, Schedule(), 0.02, max_time=120.0, plot=False)
    assert without.samples == {}
    a, b = with_plot.summary.to_json(), without.summary.to_json()
    for doc in (a, b, a["advanced"], b["advanced"], a["lifting"], b["lifting"]):
        assert isinstance(doc, dict)
        doc.pop("step_cpu_us", None)
    assert a == b
    assert all(r.series.rows.size == 0 for r in without.results.values())
