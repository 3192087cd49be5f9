"""The GEO core's promises on programs the first generation got wrong (issue 14): ranges longer
than the look-ahead land exactly, override steps in every lift phase, the override decrease that
came late or dipped, short blocks that crawled, and what the summary reports."""

from __future__ import annotations

import itertools
import json
import math

import numpy as np
import pytest

from liftd.cnc.geo_task import GeoTask
from liftd.cnc.nc.blocks import ErrorId
from liftd.cnc.params import LiftMethod
from liftd.cnc.path.velocity import reach_velocity
from liftd.cnc.plc import Schedule, parse_feedhold_spec, parse_override_spec
from liftd.cnc.snapshot import ChannelState, GeoInputs, GeoSnapshot, LiftPhase
from tests.support.channel import make_channel
from tests.support.closed_loop import events, fd_ratios, run_task
from tests.support.pure_core import PureCore

TOL = 1 + 1e-9
LANDED = 1e-6  # m: Z at POS when the path passes LIFT_END


def sched(override: str = "", hold: str = "") -> Schedule:
    return Schedule(tuple(parse_override_spec(override)), tuple(parse_feedhold_spec(hold)))


def polyline_range(blocks: int, step_mm: float = 0.5, feed: int = 12000, pos: float = 1.0,
                   limit: float = 60.0) -> str:  # fmt: skip
    """A lift range over a straight polyline of `blocks` short blocks, then a cut."""
    lines = ["G01 X10 Y10 Z1 F6000", f"Z[LIFT_START POS={pos} POS_LIMIT={limit}]", f"F{feed}"]
    lines += [f"G01 X{10 + (i + 1) * step_mm:.4f}" for i in range(blocks)]
    lines += ["Z[LIFT_END]", f"G01 Y{20 + 0.0:.1f} F3000", "M30"]
    return "\n".join(lines) + "\n"


def landing_checks(task: GeoTask, snaps: list[GeoSnapshot]) -> None:
    """Every lift landed: Z at POS in the cycle the path passed LIFT_END and after, never late,
    never above POS_LIMIT, every axis within its limits on every sampled cycle."""
    assert snaps[-1].state is ChannelState.READY, snaps[-1]
    assert not events(snaps, "lift.late")
    assert fd_ratios(task.ch, snaps).max() <= TOL
    z = task.ch.lift_axis_index
    recs = task.lift.records
    for i, rec in enumerate(recs):
        spec = rec.range.start
        assert rec.arrival_error <= LANDED, (spec.line, rec.arrival_error)
        until = recs[i + 1].t_start if i + 1 < len(recs) else math.inf
        after = [s for s in snaps if rec.t_end <= s.t < until]  # empty: the next began at once
        assert all(abs(s.positions[z] - spec.target) <= LANDED for s in after[:50])
        if not rec.range.direct:
            assert rec.peak <= spec.pos_limit  # exactly: never a nanometre above


@pytest.mark.parametrize("look_ahead", [5, 30, 120, 190, 200])
@pytest.mark.parametrize("factor", [1.2, 2.5])
def test_a_range_longer_than_the_look_ahead_lands_on_time(look_ahead: int, factor: float) -> None:
    ch = make_channel(look_ahead=look_ahead)
    task, snaps = run_task(ch, polyline_range(round(look_ahead * factor) + 10))
    landing_checks(task, snaps)
    rec = task.lift.records[0]
    spec = rec.range.start
    rise = task.lift.z_time(spec.z_start, spec.pos_limit)
    if rec.t_end - rec.t_start > 2 * rise + 0.01:  # time to go up and down: it reaches the top
        assert rec.peak == pytest.approx(spec.pos_limit, abs=1e-9)
    else:  # it lifted as far as the time allowed (not a defensive crawl)
        assert rec.peak > spec.z_start + 0.001


@pytest.mark.parametrize("blocks", [1, 10, 400, 2000])
def test_ranges_of_any_length_land_on_time(blocks: int) -> None:
    ch = make_channel(look_ahead=30)
    task, snaps = run_task(ch, polyline_range(blocks, step_mm=2.0 if blocks < 20 else 0.5),
                           max_time=60)  # fmt: skip
    landing_checks(task, snaps)


def _phase_times(task: GeoTask, snaps: list[GeoSnapshot]) -> dict[LiftPhase, float]:
    out: dict[LiftPhase, float] = {}
    for s in snaps:
        out.setdefault(s.lift_phase, s.t)
    return out


@pytest.mark.parametrize("phase", [LiftPhase.UP, LiftPhase.DOWN])
@pytest.mark.parametrize("step", ["200", "150", "60", "0"])
def test_override_steps_in_every_lift_phase(phase: LiftPhase, step: str) -> None:
    ch = make_channel()
    text = polyline_range(60, step_mm=4.0, feed=24000)
    base_task, base = run_task(ch, text)
    t0 = _phase_times(base_task, base)[phase] + 0.01
    back = f",{t0 + 0.15:.3f}:100" if step == "0" else ""
    task, snaps = run_task(ch, text, sched(f"{t0:.3f}:{step}{back}"))
    landing_checks(task, snaps)
    if step in ("200", "150") and phase is LiftPhase.DOWN:  # clamped to the value at descent
        end = task.lift.records[0].t_end
        assert max(s.override for s in snaps if t0 + 0.005 < s.t < end) <= 1.0 + 1e-12


def test_an_override_increase_while_rising_is_limited_so_that_z_still_lands() -> None:
    ch = make_channel()
    text = ("G01 X10 Y10 Z1 F6000\nZ[LIFT_START POS=1 POS_LIMIT=100]\nG01 X220 F30000\n"
            "Z[LIFT_END]\nG01 Y20 F3000\nM30\n")  # fmt: skip
    base_task, base = run_task(ch, text)
    up = _phase_times(base_task, base)[LiftPhase.UP]
    task, snaps = run_task(ch, text, sched(f"{up + 0.12:.3f}:200"))
    landing_checks(task, snaps)
    limited = events(snaps, "lift.override_limited")
    assert limited and all(v < 2.0 for _, _, v in limited)
    after = [s for s in snaps if up + 0.12 < s.t < task.lift.records[0].t_end]
    assert max(s.override for s in after) < 2.0  # the PLC's 200 % was not granted in full
    assert max(s.override_max for s in after if s.lift_phase is LiftPhase.UP) < 2.0


@pytest.mark.parametrize("after_up", [0.12, 0.2])
def test_a_cut_override_request_costs_a_few_re_plans_not_one_a_cycle(after_up: float) -> None:
    """200 % written while Z rises and cut: the verdict is re-examined every cycle and creeps up
    as the path advances, but each grant is a re-plan of the path (the committed future
    discarded: an event's cost in the GEO cycle). It used to be re-granted in almost every
    cycle (39 re-plans and 128 `lift.override_limited` events for one write at +0.12 s); now a
    higher grant comes in steps of 5 %, each one event, the override in effect never falls while
    the request stands, and Z still lands."""
    ch = make_channel()
    text = ("G01 X10 Y10 Z1 F6000\nZ[LIFT_START POS=1 POS_LIMIT=100]\nG01 X220 F30000\n"
            "Z[LIFT_END]\nG01 Y20 F3000\nM30\n")  # fmt: skip
    base_task, base = run_task(ch, text)
    t0 = _phase_times(base_task, base)[LiftPhase.UP] + after_up
    task, snaps = run_task(ch, text, sched(f"{t0:.3f}:200"))
    landing_checks(task, snaps)
    # the write itself, at most two higher grants, and the full 200 % after the lift
    assert task.interp.restarts - base_task.interp.restarts <= 4
    grants = [v for _, _, v in events(snaps, "lift.override_limited")]
    assert 1 <= len(grants) <= 3 and grants == sorted(set(grants)) and grants[-1] < 2.0
    end = task.lift.records[0].t_end
    ov = [s.override for s in snaps if t0 < s.t < end]
    assert all(b >= a for a, b in itertools.pairwise(ov))  # monotone under the request
    assert set(ov[1:]) <= {*grants, ov[0]}  # what it runs at is what the events said


@pytest.mark.parametrize("t_step", [0.12, 0.2, 0.5])  # accelerating (below / above), cruising
def test_an_override_decrease_acts_at_once_and_never_dips(t_step: float) -> None:
    """150 % → 100 % on a straight block: the acceleration turns down in the very next cycle
    (the only rise left is the jerk-limited ramp-down of the acceleration there was), the path
    comes down to the new velocity within the braking time of its limits, and never below it."""
    ch = make_channel()
    task, snaps = run_task(ch, "G01 X10 Y10 F6000\nG01 X900 F20000\nM30\n",
                           sched(f"0:150,{t_step}:100"))  # fmt: skip
    tb = task.prog.table
    a_max, j_max = tb.run_a[tb.run[1]], tb.run_j[tb.run[1]]
    v = np.array([s.v_path for s in snaps])
    t = np.array([s.t for s in snaps])
    on = np.array([s.segment == 1 for s in snaps])
    dt = ch.cycle_time
    k = int(np.argmax(t >= t_step - 1e-12))  # the cycle the step takes effect in
    target = 20000 / 60_000
    a_k = (v[k] - v[k - 1]) / dt
    # at once: the acceleration only decreases from the step on, at the jerk limit
    acc = np.diff(v[k - 1 : k + 12]) / dt
    if v[k] > target:
        assert (np.diff(acc) < 0).all()
        assert v[k:].max() <= v[k] + max(a_k, 0.0) ** 2 / (2 * j_max) + a_max * dt
    # within the braking time of the limits (from the worst state at the step)
    settled = np.flatnonzero(on & (t > t_step) & (np.abs(v - target) <= 1e-9))
    assert settled.size
    brake = abs(v[k] - target) / a_max + 2 * a_max / j_max + 2 * abs(a_k) / j_max
    assert t[settled[0]] - t_step <= brake + 5 * dt
    # monotone: from there on never below the new velocity, until the block's final brake
    cruise = (t >= t[settled[0]]) & on & (t < t[on].max() - 0.2)
    assert v[cruise].min() >= target * (1 - 1e-9)


def test_a_straight_polyline_of_short_blocks_runs_at_its_look_ahead_bound() -> None:
    """Item 6: acceleration is continuous across collinear blocks; the path reaches
    min(F × override, axis limits, the velocity from which it stops within the look-ahead)."""
    for step, feed, look in [(0.5, 30000, 120), (0.2, 60000, 30), (2.0, 60000, 30)]:
        ch = make_channel(look_ahead=look)
        n = int(300 / step)
        text = (
            f"G01 X10 Y10 F{feed}\n"
            + "".join(f"X{10 + (i + 1) * step:.4f}\n" for i in range(n))
            + "M30\n"
        )
        task, snaps = run_task(ch, text)
        tb = task.prog.table
        a_max, j_max = tb.run_a[tb.run[5]], tb.run_j[tb.run[5]]
        bound = min(feed / 60_000, tb.cap[5],
                    reach_velocity(0.0, (look - 1) * step * 1e-3, a_max, j_max))  # fmt: skip
        mid = [s.v_path for s in snaps if s.segment >= 1 and 0.12 < s.positions[0] < 0.2]
        assert mid and min(mid) >= 0.95 * bound, (step, feed, look, min(mid), bound)
        assert fd_ratios(ch, snaps).max() <= TOL


def test_a_feed_hold_released_just_before_lift_end_makes_the_path_wait_there() -> None:
    ch = make_channel()
    text = ("G01 X10 Y10 Z1 F6000\nZ[LIFT_START POS=1 POS_LIMIT=100]\nG01 X160 F30000\n"
            "Z[LIFT_END]\nG01 Y20 F3000\nM30\n")  # fmt: skip
    base_task, base = run_task(ch, text)
    rec = base_task.lift.records[0]
    hold = f"{rec.t_end - 0.09:.3f}:0.5"  # stops a few mm before LIFT_END, Z goes up meanwhile
    task, snaps = run_task(ch, text, sched(hold=hold))
    landing_checks(task, snaps)
    assert events(snaps, "lift.path_waits") or events(snaps, "lift.override_limited")


def test_path_delay_is_what_the_lift_cost() -> None:
    ch = make_channel()
    # Z must climb 80 mm over 20 mm of path: the path is slowed for it
    slow = ("G01 X10 Y10 Z1 F6000\nZ[LIFT_START POS=81 POS_LIMIT=90]\nG01 X30 F30000\n"
            "Z[LIFT_END]\nG01 Y20 F3000\nM30\n")  # fmt: skip
    task, snaps = run_task(ch, slow)
    landing_checks(task, snaps)
    rec = task.lift.records[0]
    z_time = task.lift.z_time(0.001, 0.081)
    assert rec.t_end - rec.t_start >= z_time - 1e-6
    assert rec.path_delay == pytest.approx(rec.t_end - rec.t_start - rec.nominal_time, abs=1e-9)
    assert rec.path_delay > 0.05 and rec.nominal_time < z_time
    # a normal lift costs the path nothing
    task, snaps = run_task(ch, slow.replace("POS=81 POS_LIMIT=90", "POS=1 POS_LIMIT=60")
                           .replace("X30", "X300"))  # fmt: skip
    assert task.lift.records[0].path_delay == pytest.approx(0.0, abs=1e-9)


@pytest.mark.parametrize("wait", ["G04 X0.2", "M08", "M04"])
def test_path_delay_of_a_range_that_starts_at_a_waiting_point_is_not_the_wait(wait: str) -> None:
    """Issue 15 item 6: a range starting where the path waits (a dwell, an M function the PLC
    acknowledges) reported the wait as path delay (0.074 s for a 68 ms range); the delay is
    what the lift cost, measured from the moment the path leaves."""
    ch = make_channel()
    text = (f"G01 X10 Y10 Z1 F6000\n{wait}\nZ[LIFT_START POS=1 POS_LIMIT=30]\n"
            "G01 X60 F24000\nZ[LIFT_END]\nM30\n")  # fmt: skip
    task, snaps = run_task(ch, text)
    landing_checks(task, snaps)
    (rec,) = task.lift.records
    assert rec.path_delay == pytest.approx(0.0, abs=1e-9)
    assert rec.nominal_time == pytest.approx(rec.t_end - rec.t_start - rec.waits, abs=1e-9)
    assert rec.t_end - rec.t_start < 0.2  # the range itself: the wait lies before it


@pytest.mark.parametrize("method", [LiftMethod.ADVANCED, LiftMethod.LIFTING])
@pytest.mark.parametrize("wait", ["G04 X1.5", "M08"])
@pytest.mark.parametrize("path", ["G01 X300 F24000\n", ""])
def test_path_delay_of_a_range_that_ends_at_a_waiting_point_is_not_the_wait(
    wait: str, path: str, method: LiftMethod
) -> None:
    """A dwell or an acknowledged M function where the path rests before LIFT_END (also in a
    range without path motion) is the program's time, not the lift's: it was reported as path
    delay (1.5 s for a G04 X1.5; exploratory session). The delay is what the same range costs
    without the wait (0 with Advanced Lifting; path-based Lifting's path runs slower in the
    range so that Z keeps its limits, issue 37 item 3)."""
    ch = make_channel(method)
    text = (f"G01 X10 Y10 Z1 F6000\nZ[LIFT_START POS=1 POS_LIMIT=30]\n{path}{wait}\n"
            "Z[LIFT_END]\nM30\n")  # fmt: skip
    task, snaps = run_task(ch, text)
    assert snaps[-1].state is ChannelState.READY and not events(snaps, "lift.late")
    (rec,) = task.lift.records
    plain, _ = run_task(ch, text.replace(f"{wait}\n", ""))
    (without,) = plain.lift.records
    assert rec.path_delay == pytest.approx(without.path_delay, abs=1e-9), (rec.t_end - rec.t_start,
                                                                            rec.waits)  # fmt: skip
    assert without.path_delay == 0.0 or (method is LiftMethod.LIFTING and path)


def test_path_delay_after_a_dwell_is_the_wait_for_z_that_remains() -> None:
    """A range without path motion: Z climbs 60 mm (about 0.18 s); a dwell of 0.05 s before
    LIFT_END leaves the rest of Z's climb as the path's delay."""
    ch = make_channel()
    text = "G01 X10 Y10 Z1 F6000\nZ[LIFT_START POS=61 POS_LIMIT=70]\nG04 X0.05\nZ[LIFT_END]\nM30\n"
    task, snaps = run_task(ch, text)
    (rec,) = task.lift.records
    z_time = task.lift.z_time(0.001, 0.061)
    assert z_time > 0.1
    assert rec.path_delay == pytest.approx(rec.t_end - rec.t_start - 0.05, abs=1e-9)
    assert rec.t_end - rec.t_start == pytest.approx(z_time, abs=2e-3)


@pytest.mark.parametrize("method", [LiftMethod.ADVANCED, LiftMethod.LIFTING])
def test_any_axis_of_the_channel_lifts_with_its_own_dynamics(method: LiftMethod) -> None:
    """Vendor §3: the lift command names its axis. Here Y lifts while X cuts, then Z: each axis
    lands at its POS within its own limits, the flags and counters are that axis's, and the
    other axes never move in a range."""
    ch = make_channel(method)
    text = ("G01 X10 Y10 Z1 F6000\nY[LIFT_START POS=40 POS_LIMIT=60]\nG01 X200 F20000\n"
            "Y[LIFT_END]\nZ[LIFT_START POS=5 POS_LIMIT=50]\nG01 X300\nZ[LIFT_END]\nM30\n")  # fmt: skip
    task, snaps = run_task(ch, text)
    assert snaps[-1].state is ChannelState.READY and not events(snaps, "lift.late")
    assert [r.range.start.axis for r in task.lift.records] == ["Y", "Z"]
    assert all(r.arrival_error <= LANDED for r in task.lift.records)
    # velocity within every axis's limit; path-based Lifting may overload the lift axis's
    # acceleration (z(s) is followed at the path's acceleration), as on Z (monitor reports)
    ratios = fd_ratios(ch, snaps)
    assert (ratios if method is LiftMethod.ADVANCED else ratios[0]).max() <= TOL
    y_range = [s for s in snaps if s.lift_active and s.lift_axis == 1]
    assert y_range and max(s.positions[1] for s in y_range) > 0.040  # Y rose above its POS
    assert all(abs(s.positions[2] - 0.001) < 1e-12 for s in y_range)  # Z stays
    assert snaps[-1].lift_counts == (0, 1, 1)
    assert snaps[-1].positions[1:] == pytest.approx((0.040, 0.005), abs=1e-9)


def test_a_late_lift_is_reported_with_its_error_id_and_the_distance(pure_core: PureCore) -> None:
    """Never expected, but never hidden: if Z is not at POS when the path passes LIFT_END (here
    the generator is made to land 20 mm short on purpose), the summary's arrival_error is the
    distance, the event lift.late is emitted and the errors list carries 990037 with the
    LIFT_END line; the program still counts as run (not a program error). The fault is patched
    into the generator, which only the core run as Python allows (a subprocess)."""
    code = """
import json
from liftd.cnc.lift.advanced import AdvancedLift
from liftd.cnc.plc import Schedule
from liftd.sim.simulate import simulate
from tests.support.channel import make_channel

start = AdvancedLift.start
def short(self, t, z, vz, az, target, *rest):
    start(self, t, z, vz, az, target - 0.020, *rest)
AdvancedLift.start = short
text = ("G01 X10 Y10 Z1 F6000\\nZ[LIFT_START POS=21 POS_LIMIT=60]\\nG01 X100 F12000\\n"
        "Z[LIFT_END]\\nM30\\n")
res = simulate(make_channel(), text, Schedule(), 0.02)
out = res.summary.to_json()
print(json.dumps({"errors": out["errors"], "lift": out["lifts"][0],
                  "program_error": res.program_error, "finished": res.finished}))
"""
    res = json.loads(pure_core.run(code))
    late = [e for e in res["errors"] if e["id"] == ErrorId.LIFT_LATE]
    assert len(late) == 1 and late[0]["line"] == 4, res["errors"]
    assert res["lift"]["arrival_error"] == pytest.approx(20.0, abs=1e-3)
    assert not res["program_error"] and res["finished"]


def test_what_events_discard_is_released_within_a_few_cycles() -> None:
    """An event discards the committed future without freeing it, or anything else, in its own
    cycle (that cost ~50 µs): a few entries per cycle go in the cycles without an event, also
    while events keep coming, so nothing is left a bounded number of cycles later."""
    from liftd.cnc.release import RELEASE_PER_CYCLE  # noqa: PLC0415

    ch = make_channel()
    task = GeoTask(ch, "G01 X10 Y10 F6000\nG01 X900 F20000\nM30\n")
    dt = ch.cycle_time
    for k in range(1, 300):  # the committed future grows to its lead
        task.step(GeoInputs(override=1.0), k * dt)
    queued = len(task.interp.queue)
    task.step(GeoInputs(override=0.9), 300 * dt)  # an event
    held = sum(len(b) for b in task.interp.discarded.bins)
    assert queued > 100 and held >= queued  # nothing freed in the event's cycle
    for k in range(301, 351):  # a new override every third cycle: each discards a little more
        task.step(GeoInputs(override=0.9 + 0.01 * (k // 3 % 20)), k * dt)
    task.step(GeoInputs(override=1.0), 351 * dt)  # the last event
    held = sum(len(b) for b in task.interp.discarded.bins)
    assert 0 < held < queued
    for k in range(352, 352 + held // RELEASE_PER_CYCLE + 1):  # no more events
        task.step(GeoInputs(override=1.0), k * dt)
    assert not task.interp.discarded.bins


def test_an_event_cycle_plans_only_its_own_state() -> None:
    """The cycle of an event re-plans the path from where it is and makes only the entry it
    runs (the re-plan is its work); the committed future grows again from the next cycle on,
    by `fill_per_cycle` entries a cycle, while the event has acted at once."""
    ch = make_channel()
    task = GeoTask(ch, "G01 X10 Y10 F6000\nG01 X900 F20000\nM30\n")
    dt = ch.cycle_time
    for k in range(1, 600):  # cruising
        task.step(GeoInputs(override=1.0), k * dt)
    ip = task.interp
    assert len(ip.queue) > 100
    v_before = ip.v
    restarts = ip.restarts
    task.step(GeoInputs(override=0.5), 600 * dt)  # an event
    assert ip.restarts == restarts + 1
    assert len(ip.queue) == 0 and ip.k_next == 601  # the entry of cycle 600 only
    assert ip.v < v_before and ip.a < 0.0  # it acts in its own cycle: the path brakes
    task.step(GeoInputs(override=0.5), 601 * dt)
    assert len(ip.queue) == ip.fill_per_cycle  # growing again


def test_a_lift_start_follows_the_rise_prepared_with_the_program() -> None:
    """Each time-based range's rise from Z at rest at its start is solved when the program
    is prepared (`GeoProgram.rises`), and the lift start's GEO cycle follows that profile
    instead of solving it again; a lift whose Z does not start at rest (the path enters the
    range moving Z too) solves its own."""
    ch = make_channel(lift_min_dist=0.005)  # the last range (2 mm) is suppressed
    text = ("G01 X10 Y10 Z1 F6000\nZ[LIFT_START POS=1 POS_LIMIT=30]\nG01 X60 F12000\n"
            "Z[LIFT_END]\nZ[LIFT_START POS=1 POS_LIMIT=20]\nG01 Y40\nZ[LIFT_END]\n"
            "Z[LIFT_START POS=1 POS_LIMIT=25]\nG01 X20\nZ[LIFT_END]\n"
            "Z[LIFT_START POS=1 POS_LIMIT=20]\nG01 X22\nZ[LIFT_END]\nM30\n")  # fmt: skip
    task = GeoTask(ch, text)
    rises = task.prog.rises
    assert len(rises) == 4 and None not in rises[:3]
    assert rises[3] is None  # suppressed: Z goes straight to POS
    followed = []
    for k in range(1, 20_000):
        before = task.lift.current
        snap = task.step(GeoInputs(1.0, False, None, False), k * ch.cycle_time)
        rng = task.lift.current
        if rng is not None and rng is not before and rises[rng.index] is not None:
            gen = task.lift.motion.gen  # type: ignore[union-attr]
            followed.append(gen.rise is rises[rng.index].traj)  # type: ignore[union-attr]
        if snap.state is ChannelState.READY and k > 1:
            break
    assert followed == [False, True, True]  # the first enters moving Z (X10 Y10 Z1)
