"""`simulate` with its quiet cycles in batches (the default) gives the run it gives by single
steps, bit for bit: the trace text, the summary (its step times aside) and the plot's series,
and `--compare`'s samples;
with override steps (0 % too) and feed holds on a cycle's time, a hair before and after it,
M functions, lift ranges of both methods, an NC error."""

from __future__ import annotations

import dataclasses
import io
import json

import pytest

from liftd.cnc.params import ChannelParams, LiftMethod
from liftd.cnc.plc import Schedule
from liftd.settings import load_settings
from liftd.sim.compare import Comparison, compare
from liftd.sim.simulate import SimResult, quiet_span, simulate
from tests.support.paths import REPO
from tests.support.programs import nesting_program
from tests.support.scenarios import wide_scenario

CH = load_settings(str(REPO / "config" / "liftd.toml")).channel
DEMO = (REPO / "config" / "programs" / "demo.nc").read_text()
NC_ERROR = (
    "G90 G01 X10 Y10 Z1 F6000\nZ[LIFT_START POS=1 POS_LIMIT=30]\nG01 X60 F12000\n"
    "G01 X80 Y30\nQ1 oops\nG01 X120\nZ[LIFT_END]\nG01 X140\nM30\n"
)
# steps on a cycle's time (0.5 s), 1 ps before one (tolerated as on it), 0.4 µs after one,
# a 0 % stretch and feed holds, one inside a lift range of the demo
SCHEDULE = Schedule(
    override=((0.3705, 0.6), (0.5, 1.5), (0.9 - 1e-12, 0.0), (1.2, 2.0), (2.0004, 1.0)),
    feed_hold=((1.6, 1.8), (3.0000004, 3.25)),
)


def run(
    ch: ChannelParams, text: str, schedule: Schedule, batch: bool
) -> tuple[str, str, SimResult]:
    out = io.StringIO()
    res = simulate(ch, text, schedule, 0.02, out, max_time=300.0, batch=batch)
    summary = dataclasses.asdict(res.summary)
    del summary["step_cpu_us"]
    return out.getvalue(), json.dumps(summary, default=str), res


def _scenario(
    seed: int, method: LiftMethod = LiftMethod.ADVANCED
) -> tuple[ChannelParams, str, Schedule]:
    sc = wide_scenario(seed, method)
    return sc.channel, sc.text, sc.schedule


CASES = {
    "demo": (CH, DEMO, Schedule()),
    "demo-schedule": (CH, DEMO, SCHEDULE),
    "nesting-4-schedule": (CH, nesting_program(4), SCHEDULE),
    "nc-error": (CH, NC_ERROR, SCHEDULE),
    **{f"wide-{s}": _scenario(s) for s in (2, 5, 17, 23)},
    "wide-13-lifting": _scenario(13, LiftMethod.LIFTING),
}


@pytest.mark.parametrize("name", list(CASES))
def test_batches_give_the_run_of_single_steps(name: str) -> None:
    ch, text, schedule = CASES[name]
    trace, summary, res = run(ch, text, schedule, batch=True)
    trace1, summary1, res1 = run(ch, text, schedule, batch=False)
    assert summary == summary1
    rows, rows1 = trace.splitlines(), trace1.splitlines()
    assert len(rows) == len(rows1) == res.summary.cycles + 1
    assert [(i, r) for i, (r, q) in enumerate(zip(rows, rows1, strict=True)) if r != q][:3] == []
    assert res.series.rows.tobytes() == res1.series.rows.tobytes()
    assert res.series.stride == res1.series.stride
    # each cycle of a batch counts once in the step times
    assert res.summary.step_cpu_us.p50_us > 0.0


def test_a_batch_stops_before_the_schedules_next_step() -> None:
    dt = 0.001
    edges = [0.5 - 1e-12, 0.9]
    assert quiet_span(100, dt, 10_000, edges) == 400  # cycles 100 … 499: before 0.5 s
    assert quiet_span(499, dt, 10_000, edges) == 1
    assert quiet_span(500, dt, 10_000, edges) == 400  # 0.5 s on: up to 0.899 s
    assert quiet_span(950, dt, 10_000, edges) == 1024  # the last step behind: BATCH
    assert quiet_span(950, dt, 1000, edges) == 51  # up to the run's last cycle


@pytest.mark.parametrize("name", ["demo-schedule", "nesting-4-schedule", "nc-error", "wide-5"])
def test_compare_with_batches_samples_every_cycle(name: str) -> None:
    """`--compare --plot` with batches: each method's summary and the per-lift
    samples of its figure (t, path distance, Z, Z's second difference: sums over every
    cycle) as by single steps, bit for bit."""
    ch, text, schedule = CASES[name]
    got = compare(ch, text, schedule, 0.02, max_time=300.0)
    want = compare(ch, text, schedule, 0.02, max_time=300.0, batch=False)
    assert _json(got) == _json(want)
    for method in got.samples:
        a, b = got.samples[method], want.samples[method]
        assert repr(a.lifts) == repr(b.lifts)
        assert repr(list(a.recent)) == repr(list(b.recent))
        assert (a.s, a.v, a.z1, a.z2) == (b.s, b.v, b.z1, b.z2)
    assert sum(len(lift.rows) for lift in got.samples["advanced"].lifts) > 0


def _json(cmp: Comparison) -> str:
    """The comparison's JSON without the step times (the one field that differs)."""
    out = cmp.summary.to_json()
    for method in ("advanced", "lifting"):
        summary = out[method]
        assert isinstance(summary, dict)
        summary.pop("step_cpu_us")
    return json.dumps(out, default=str)


def test_a_run_cut_by_max_time_ends_at_the_same_cycle() -> None:
    """`--max-time` inside a batch: the same last cycle, trace and summary (not finished)."""
    out, out1 = io.StringIO(), io.StringIO()
    res = simulate(CH, DEMO, SCHEDULE, 0.02, out, max_time=2.5)
    res1 = simulate(CH, DEMO, SCHEDULE, 0.02, out1, max_time=2.5, batch=False)
    assert not res.finished and not res1.finished
    assert res.summary.cycles == res1.summary.cycles == 2500
    assert out.getvalue() == out1.getvalue()


def test_an_on_cycle_hook_without_on_rows_sees_every_cycle() -> None:
    """A caller that wants every snapshot gets every one: no batches without `on_rows`."""
    seen: list[float] = []
    res = simulate(CH, DEMO, Schedule(), 0.02, on_cycle=lambda s: seen.append(s.t))
    assert len(seen) == res.summary.cycles
    assert seen == [k * CH.cycle_time for k in range(1, len(seen) + 1)]
