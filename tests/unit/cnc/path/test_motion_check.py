"""The independent motion check itself (tests/support/motion_check.py, motion_rules.py; issue
36, item 2): what it expects where the rules allow the path to be fast, so that a path slower
than that is found. Its findings are the project's evidence that the path does not slow down
without a rule: a check that expects too little hides exactly those slowdowns."""

from __future__ import annotations

import dataclasses
import math
import random
from collections.abc import Callable, Sequence

import pytest
import ruckig

from liftd.cnc.geo_task import GeoTask
from liftd.cnc.params import ChannelParams
from liftd.cnc.plc import Schedule, SimPlc
from liftd.sim.simulate import run_cycles
from tests.support.cam_cases import cam_scenario
from tests.support.cam_runs import check, time_limit
from tests.support.channel import shipped
from tests.support.feed_cases import drop_scenario, feed_scenario, moved_steps, short_drop_scenario
from tests.support.motion_check import Expected, Recorder, check_motion
from tests.support.motion_rules import (
    PathRules,
    Sample,
    brake_distance,
    brake_phases,
    jerk_gap,
    travel,
    velocity_at,
)
from tests.support.scenarios import Scenario

MM = 1e-3


def alternating(blocks: int, step_mm: float, high: int, low: int) -> str:
    """Collinear blocks whose feed alternates: a feed drop at every second boundary."""
    lines = ["G01 X0 Y0 F600"]
    for i in range(blocks):
        lines.append(f"G01 X{(i + 1) * step_mm:.4f} F{high if i % 2 else low}")
    return "\n".join([*lines, "M30"]) + "\n"


def at(s: float, v: float, seg: int, t: float = 0.0, a: float = 0.0, ov: float = 1.0) -> Sample:
    """A sample of the path: running, no hold, no stop for Z."""
    return Sample(t, s, v, a, seg, None, False, ov, False, frozenset(), frozenset(), True)


def many_drops() -> tuple[ChannelParams, GeoTask]:
    """400 collinear blocks of 0.2 mm at F30000 / F60000 (a feed drop every 0.4 mm),
    look-ahead 200, the shipped machine: at 500 mm/s the path needs ~17 mm to stop, 40 feed
    drops lie within that brake."""
    ch = dataclasses.replace(shipped(), look_ahead_blocks=200, cycle_time=1e-3)
    return ch, GeoTask(ch, alternating(400, 0.2, 60000, 30000))


def test_one_brake_passes_every_feed_drop_inside_a_run() -> None:
    """The backward pass took the path acceleration as zero at every feed drop, as at a run
    boundary: from the window's end 40 mm ahead, a chain of 100 brakes of 0.4 mm each with
    zero acceleration at both ends allowed 166.9 mm/s where one brake through them all
    allows the low feed, 500 mm/s. (The core runs at 314 there, known deviation 1 of
    docs/geo-core.md: the check finds it now.)"""
    ch, task = many_drops()
    rules = PathRules(task.interp.program, task.interp.table, ch.look_ahead_blocks)
    assert not any(rules.gate[1:400])  # one run from the first boundary to the program's end
    for b in range(50, 201):  # 10 … 40 mm, the window's end 200 blocks on
        smp = at(rules.bounds[b].s, 0.3, b)
        assert abs(rules.target(b, 1.0) - 500 * MM) < 1e-9
        assert rules.backward(b, smp, b - 1 + ch.look_ahead_blocks) >= 0.95 * 500 * MM, b


def drive(
    task: GeoTask, v: float, dt: float, cycles: int,
    accel: Callable[[int], float] = lambda i: 0.0, override: Callable[[int], float] = lambda i: 1.0,
) -> list[Sample]:  # fmt: skip
    """Samples of a made-up path from the program's start at v, with the acceleration
    `accel(i)` and the override `override(i)` in cycle i (not a motion that a core makes:
    the check's input, to see what it finds)."""
    bounds = task.interp.program.boundaries
    out: list[Sample] = []
    seg = 0
    s = 0.0
    for i in range(cycles + 1):
        a = accel(i)
        if i:
            s += v * dt + a * dt * dt / 2.0
            v += a * dt
        while seg + 1 < len(bounds) - 1 and bounds[seg + 1].s <= s:
            seg += 1
        out.append(at(s, v, seg, t=i * dt, a=a, ov=override(i)))
    return out


def test_a_path_held_below_the_rules_is_found_along_the_whole_stretch() -> None:
    """The forward pass started again at every boundary the path passed below it, with zero
    acceleration there, also where it was only a little below it (within REL_TOL): from there
    it could gain only a little per block, and a path held at any velocity below the rules'
    was not found (this one: no finding; the core's 314 mm/s where the rules allow 500, known
    deviation 1, neither). Now it starts again only at a run boundary, where a cap held the
    path, or where the check found it too slow: a path cruising at 300 mm/s on the 0.2 mm
    blocks at F30000 / F60000 is found again in every 10 mm (every 4 mm)."""
    ch, task = many_drops()
    samples = drive(task, 0.3, ch.cycle_time, 150)  # 45 mm
    found = check_motion(task.interp.program, task.interp.table, 200, ch.cycle_time, samples)
    boundaries = [int(f.split()[1]) for f in found if f.startswith("boundary")]
    for start_mm in range(5, 40, 10):  # every 10 mm stretch after the first block
        lo, hi = start_mm / 0.2, (start_mm + 10) / 0.2
        assert any(lo <= b < hi for b in boundaries), (start_mm, found)


def test_a_boundary_inside_an_event_s_ramp_is_checked_against_the_ramp() -> None:
    """After an event planned while the path decelerates, its deceleration is ramped out at
    full jerk first: the ramp's velocity is the highest the path can have there. Boundaries
    inside the ramp were skipped, so a path that went on braking there for no cap passed.
    Made up: 0.2 mm blocks at F12000 (200 mm/s), override 100 → 120 % while the path
    brakes at −4 m/s² (the X axis's 500 m/s³: a ramp of 8 ms to 184 mm/s, 1.5 mm), and it
    keeps braking at −4 m/s² through the ramp to 164 mm/s and cruises on there (9 ms: with 8,
    to 168, its last boundary in the ramp is 5.1 % below the ramp's velocity, at the check's
    REL_TOL, and was found only where the check read it from the sample before as braking
    on, which the made-up samples' step to zero acceleration does not do)."""
    ch = dataclasses.replace(shipped(), cycle_time=1e-3)
    text = "G01 X0 Y0 F600\n" + "".join(f"G01 X{(i + 1) * 0.2:.1f} F12000\n" for i in range(150))
    task = GeoTask(ch, text + "M30\n")
    samples = drive(task, 0.2, ch.cycle_time, 150, lambda i: -4.0 if 40 <= i < 49 else 0.0,
                    lambda i: 1.0 if i < 40 else 1.2)  # fmt: skip
    trace: list[Expected] = []
    found = check_motion(task.interp.program, task.interp.table, 30, ch.cycle_time, samples, trace)
    in_ramp = [e for e in trace if e.ramp < math.inf]
    assert len(in_ramp) >= 5
    assert all(e.ramp > e.v for e in in_ramp)  # the made-up path below the ramp
    assert any(f.startswith("boundary") and "in an event's ramp" in f for f in found), found


def test_a_dip_after_an_event_is_found() -> None:
    """After an event the interval the path was in was not checked for a dip at all: a plan
    made at an event that goes below both the event's velocity and the next boundary's and
    comes back passed unseen (known deviation 2 of docs/geo-core.md keeps such dips). Made
    up: 20 mm blocks at 200 mm/s, override 100 → 80 % at 8 mm, the path brakes to 100 mm/s
    and comes back to 160 before the boundary."""
    ch = dataclasses.replace(shipped(), cycle_time=1e-3)
    task = GeoTask(ch, "G01 X0 Y0 F600\nG01 X20 F12000\nX40\nX60\nM30\n")

    def accel(i: int) -> float:
        return -4.0 if 40 <= i < 65 else 4.0 if 65 <= i < 80 else 0.0

    samples = drive(task, 0.2, ch.cycle_time, 200, accel, lambda i: 1.0 if i < 40 else 0.8)
    found = check_motion(task.interp.program, task.interp.table, 30, ch.cycle_time, samples)
    assert found == [
        "dip to 100.0000 mm/s before boundary 1 (line 2) between 176.0000 and 160.0000 (t=0.1200 s)"
    ]


def test_a_brake_longer_than_the_window_is_checked() -> None:
    """The check reads the window as it stood when the brake toward a boundary began; where
    the path had braked since more than the window's length before, that window ended at or
    before the boundary, and the check expected 0 there: every boundary of a long brake
    passed. Now such a boundary is read with at least the window that ended a block after
    it. Made up: 1 mm blocks at F6000 (100 mm/s, which the path can stop from within 1.4 mm),
    look-ahead 3, and a brake at −1 m/s² from 100 to 20 mm/s over 4.8 mm for nothing."""
    ch = dataclasses.replace(shipped(), cycle_time=1e-3)
    text = "G01 X0 Y0 F600\n" + "".join(f"G01 X{i + 1} F6000\n" for i in range(40)) + "M30\n"
    task = GeoTask(ch, text)
    samples = drive(task, 0.1, ch.cycle_time, 200, lambda i: -1.0 if 100 <= i < 180 else 0.0)
    found = check_motion(task.interp.program, task.interp.table, 3, ch.cycle_time, samples)
    braking = [f for f in found if 0.1 < float(f.split("t=")[1].split(" s")[0]) <= 0.18]
    assert braking, found


def test_the_forward_pass_goes_through_the_caps_it_passes() -> None:
    """CAM seed 244 (override 165 %): from run boundary 59 at 53.5 mm/s the path accelerates
    through a feed rise 1 mm on (F3600 × 1.65 = 99.0 mm/s before it, F12173 after), crossing
    it at 93.3 mm/s and 2.4 m/s², and reaches run boundary 67, 3 mm after the rise, at 172.8.
    The forward pass from boundary 59 alone expected 188.1 there, a motion that passes the
    rise at 105 mm/s, above its cap; from the cap (zero acceleration there, as the backward
    pass takes each cap) 163 are reachable. No finding, and the run has no other problem."""
    _, hard, slow, errors = check(cam_scenario(244))
    assert (hard, slow, errors) == ([], [], 0)


def _brake_through_a_ceiling(extra: int) -> list[str]:
    """Made up: 100 mm/s at F6000 on X, override 100 → 20 % 0.6 mm before the end of the
    block: the path brakes at once at the check's jerk limit (to at most −6 m/s²) from above
    the new ceilings, through a 0.2 mm block of 2 mm/s (F600, out of reach from the drop)
    into a block of 100 mm/s (F30000), crossing that boundary at 80 mm/s still braking;
    `extra` cycles later it ramps the deceleration out at the same jerk and accelerates at
    2 m/s² to 98 mm/s."""
    ch = dataclasses.replace(shipped(), cycle_time=1e-3)
    task = GeoTask(ch, "G01 X0 Y0 F6000\nG01 X10\nX10.2 F600\nX20 F30000\nX30\nM30\n")
    program, table = task.interp.program, task.interp.table
    bounds = program.boundaries
    drop = bounds[1].s - 0.6e-3  # the override drops 0.6 mm before the F600 block
    _, j = PathRules(program, table, 30).limits(0, len(bounds) - 1)
    dt = 1e-3
    s, v, a, seg = 0.0, 0.1, 0.0, 0
    samples: list[Sample] = []
    crossed = first = -1
    for i in range(400):
        if i:
            s += v * dt + a * dt * dt / 2.0
            v += a * dt
        while seg + 1 < len(bounds) - 1 and bounds[seg + 1].s <= s:
            seg += 1
        if seg == 2 and crossed < 0:
            crossed = i
        if s >= drop and first < 0:
            first = i
            a = -j * dt  # the brake begins in the cycle of the drop
        samples.append(at(s, v, seg, t=i * dt, a=a, ov=1.0 if first < 0 else 0.2))
        if (first >= 0 and crossed < 0) or (crossed >= 0 and i < crossed + extra):
            a = max(a - j * dt, -6.0)  # at full jerk
        elif a < 0.0:
            a = min(a + j * dt, 0.0)
        elif crossed >= 0:
            a = 2.0 if v < 0.097 else 0.0
        if seg >= 4:
            break
    return check_motion(program, table, 30, dt, samples)


def test_a_brake_from_above_a_ceiling_ramps_out_where_the_ceiling_rises() -> None:
    """The brake after an input change from above a lowered ceiling that ends before the
    brake does: its deceleration is ramped out at full jerk after the boundary where the
    ceiling rises, as after an event, and that ramp's end is no dip (feeds seed 931:
    override 200 → 20 % at 102 mm/s, a 1 mm block of 10 mm/s, then 80; the path passed the
    block's end at 15.4 mm/s and −2.1 m/s² and ramped out to 10.09). Braking on for one
    cycle more after the boundary is still a dip (the ramp is read from the boundary's
    state too, a cold review found)."""
    assert not [f for f in _brake_through_a_ceiling(0) if f.startswith("dip")]
    found = [f for f in _brake_through_a_ceiling(1) if f.startswith("dip")]
    assert found and "before boundary 3" in found[0], found


def _recorded(sc: Scenario) -> tuple[Recorder, list[Sample]]:
    """A scenario's run through the core, recorded cycle by cycle."""
    task = GeoTask(sc.channel, sc.text)
    rec = Recorder(task)
    for snap in run_cycles(task, SimPlc(0.02), sc.schedule, sc.channel.cycle_time,
                           time_limit(task.prog.table, sc)):  # fmt: skip
        rec(snap)
    return rec, rec.samples


def _expected_at(sc: Scenario, b: int) -> tuple[Recorder, list[Sample], Expected]:
    """A scenario's run, which the check passes, and what the check expected at boundary b."""
    rec, samples = _recorded(sc)
    ch = rec.task.ch
    trace: list[Expected] = []
    found = check_motion(rec.program, rec.table, ch.look_ahead_blocks, ch.cycle_time, samples,
                         trace)  # fmt: skip
    assert found == [], found
    (at_b,) = [e for e in trace if e.b == b]
    return rec, samples, at_b


def _scaled(
    rec: Recorder, samples: list[Sample], b: int, offsets: Sequence[int], factor: float
) -> list[str]:
    """The check of `samples` with the velocity of the samples at `offsets` from the first
    one past boundary b scaled by `factor` (a made-up path, slower there)."""
    s_b = rec.table.s[b]
    k = next(i for i, smp in enumerate(samples) if smp.s >= s_b)
    out = list(samples)
    for i in offsets:
        out[k + i] = dataclasses.replace(out[k + i], v=out[k + i].v * factor)
    ch = rec.task.ch
    return check_motion(rec.program, rec.table, ch.look_ahead_blocks, ch.cycle_time, out)


def _slowed_at(
    rec: Recorder, samples: list[Sample], b: int, factor: float, before: int = 0
) -> list[str]:
    """`_scaled` at the two samples around boundary b (a made-up path that passes b slower;
    with `before`, the `before` samples before those two instead: a path that dips before b
    and comes back)."""
    return _scaled(rec, samples, b, range(-1 - before, -1) if before else (-1, 0), factor)


@pytest.mark.parametrize(("seed", "b", "cap"), [(48, 23, 0.02), (383, 17, 0.0165867)])
def test_a_run_boundary_in_the_jerk_gap_is_expected_at_x1_where_x1_is_nearer(
    seed: int, b: int, cap: float
) -> None:
    """Feeds seed 48: override 150 → 40 % at 130.2 mm/s and −1.16 m/s², 2.09 mm before a run
    boundary (a rounding kink) whose cap drops from 75 to 20 mm/s. No brake has 20 mm/s
    there with zero acceleration: the velocities it can have are [0, 9.63] and [74.3, …];
    by ratio 9.63 is the nearer (20 / 9.63 = 2.1 against 74.3 / 20 = 3.7), and the core
    passes the boundary at it (known deviation 6 of docs/geo-core.md). The check expected
    20 there, in its own model (zero acceleration at a run boundary) a velocity no motion
    has: now x1, and a path slower than x1 is still found. Feeds seed 383, the gap from a
    run boundary passed at x2: override 100 → 10 % at 126.3 mm/s 1.27 mm before run
    boundary 16 (its cap 12.6 mm/s out of reach, passed at its x2 of 115.3), from where
    boundary 17's cap of 16.6 lies in the gap (x1 = 5.75). A path that goes below x1
    before the boundary and comes back is found too."""
    rec, samples, at_b = _expected_at(feed_scenario(seed), b)
    assert at_b.held_by == pytest.approx(cap, rel=1e-5)
    assert at_b.gap == pytest.approx(at_b.v, rel=0.01) and at_b.gap < 0.5 * cap
    slower = _slowed_at(rec, samples, b, 0.5)
    assert any(f.startswith(f"boundary {b} ") for f in slower), slower
    dipped = _slowed_at(rec, samples, b, 0.5, before=2)  # the brake to x1 goes no lower
    assert any(f.startswith("dip") and f"boundary {b} " in f for f in dipped), dipped


def test_x1_is_found_where_x2_is_the_nearer_side_of_the_jerk_gap() -> None:
    """CAM seed 465: an override change leaves run boundary 12's cap of 43.38 mm/s in the
    gap, where x2 above it is the nearer by ratio, and the core passes it above (no finding).
    A path that passes it at x1, 18.84 mm/s (what the core did before the fourth round), is
    found: the check holds the core to the nearer side, not to either."""
    rec, samples, at_b = _expected_at(cam_scenario(465), 12)
    assert at_b.v > at_b.held_by and at_b.gap == math.inf  # above the cap, x2's side
    slower = _slowed_at(rec, samples, 12, 18.84e-3 / at_b.v)
    assert any(f.startswith("boundary 12 ") for f in slower), slower


@pytest.mark.parametrize(("seed", "b"), [(2237, 4), (3667, 10)])
def test_a_boundary_reachable_only_at_x1_from_the_change_is_expected_there(
    seed: int, b: int
) -> None:
    """Two programs of the drops corpus with their override drop 20 ms earlier (a cold
    review's variant), each run boundary's cap in the jerk gap from the state the gaps open
    from, and only x1 below it kept by the rules; the core passes it at x1, and a path
    slower than x1 is still found.
    2237: override 10 → 100 % at 28.05 mm/s, 0.26 mm before a kink whose transition cap,
    11.46 mm/s, no override lifts: x1 = 2.0, x2 = 15.9 above it. The check took x2 for the
    nearer side (within the segments' own caps alone) and expected 11.46.
    3667: override 100 → 10 % 0.1 mm before run boundary 9 at 34.5 mm/s, passed at the end
    of the drop's ramp-out, 32.76 (neither rest nor that ramp-out fits before it in the
    check's arithmetic: no side of its gap); from there boundary 10's 2 mm/s, 0.3 mm on, is
    reachable only at x1 = 0.80. The check read boundary 10 from the drop's state. (A
    slower made-up path is not built there: at 1 µm a cycle the crossing the check reads
    follows the samples' positions, not their scaled velocities.)"""
    rec, samples, at_b = _expected_at(moved_steps(drop_scenario(seed), -0.02), b)
    assert at_b.gap == pytest.approx(at_b.v, rel=0.01) and at_b.gap < 0.6 * at_b.held_by
    if seed == 2237:
        assert at_b.held_by == pytest.approx(rec.program.boundaries[b].v_cap, rel=1e-6)
    if seed != 3667:  # (there 1 µm a cycle: the crossing is read from the positions)
        slower = _slowed_at(rec, samples, b, 0.5)  # at b, or the dip before it in the gap
        assert any(f"boundary {b} " in f for f in slower), slower


def _min_velocity(v: float, a: float, length: float, v1: float, a_max: float,
                  j_max: float) -> float | None:  # fmt: skip
    """The lowest velocity of ruckig's time-optimal profile from (0, v, a) to (length, v1, 0)
    with the velocity kept ≥ 0 (sampled), or None where ruckig finds none."""
    otg, inp, traj = ruckig.Ruckig(1), ruckig.InputParameter(1), ruckig.Trajectory(1)
    inp.current_position, inp.current_velocity, inp.current_acceleration = [0.0], [v], [a]
    inp.target_position, inp.target_velocity, inp.target_acceleration = [length], [v1], [0.0]
    inp.max_velocity, inp.min_velocity = [10.0], [0.0]
    inp.max_acceleration, inp.max_jerk = [a_max], [j_max]
    try:
        result = otg.calculate(inp, traj)
    except ruckig.RuckigError:  # out of reach (ruckig raises where no profile exists)
        return None
    if result not in (ruckig.Result.Working, ruckig.Result.Finished):
        return None
    return min(float(traj.at_time(traj.duration * k / 500)[1][0]) for k in range(501))


def test_the_jerk_gap_is_what_ruckig_can_reach() -> None:
    """`jerk_gap`, in the check's own arithmetic, against ruckig: for 150 random states
    (0.02–0.4 m/s, ±a_max, 2–12 m/s², 100–800 m/s³) and distances short of the brake to
    rest, where it names a gap around v1, ruckig reaches its x1 and x2 with zero
    acceleration at that distance (where it names no x1, not even rest), and its profile to
    v1 itself, where it has one, goes down to x1 or below on the way (so a path passed the
    boundary at most at x1 or at least at x2, or dipped lower before it)."""
    rnd = random.Random(36)
    found = 0
    while found < 150:
        a_max, j_max = rnd.uniform(2.0, 12.0), rnd.uniform(100.0, 800.0)
        v, a = rnd.uniform(0.02, 0.4), rnd.uniform(-a_max, a_max)
        length = rnd.uniform(0.1, 1.2) * brake_distance(v, a, 0.0, a_max, j_max)
        v1 = rnd.uniform(0.0, 1.0) * (v + a * abs(a) / (2.0 * j_max))
        gap = jerk_gap(v, a, length, v1, a_max, j_max)
        if gap is None:
            continue
        found += 1
        x1, x2 = gap
        assert x1 < v1 < x2
        if x1 >= 0.0:  # (−1: not even rest is within length)
            assert _min_velocity(v, a, length, x1, a_max, j_max) is not None, (v, a, length)
        else:
            assert _min_velocity(v, a, length, 0.0, a_max, j_max) is None, (v, a, length)
        if x2 < math.inf:
            assert _min_velocity(v, a, length, x2, a_max, j_max) is not None, (v, a, length, x2)
        low = _min_velocity(v, a, length, v1, a_max, j_max)
        assert low is None or low <= x1 * (1.0 + 1e-6) + 1e-9, (v, a, length, v1, x1, low)


def test_the_deceleration_at_a_boundary_is_read_within_the_jerk_limit() -> None:
    """Feeds seed 247: override 150 → 40 % 0.3 mm before the end of an F1200 block whose
    ceiling drops to 8 mm/s; the path brakes from 28.7 mm/s and passes into the F60000 block
    after it at 20.0 mm/s, its deceleration at its peak there (−2.55 m/s²), and ramps it out
    at full jerk to 9.92. The samples a cycle apart read −2.33 and −2.45 m/s²; a linear
    reading between them gave −2.41 at the boundary and a ramp to 11.0, and the ramp's own
    end was a dip. The deceleration at the boundary is now the lowest the jerk limit allows
    from either sample: no finding. A path 10 % below that, after the ramp, is a dip."""
    rec, samples = _recorded(feed_scenario(247))
    ch = rec.task.ch
    assert check_motion(rec.program, rec.table, ch.look_ahead_blocks, ch.cycle_time,
                        samples) == []  # fmt: skip
    found = _scaled(rec, samples, 13, range(6, 10), 0.9)  # the ramp's end, 7.5 ms after it
    assert any(f.startswith("dip") and "boundary 14 " in f for f in found), found


def test_a_brake_the_window_s_move_releases_ramps_out_after_the_boundary() -> None:
    """Feeds seed 46 (look-ahead 3, override 180 %): the path brakes for the window's end and
    passes an F3000 drop at 86.5 mm/s and −2.0 m/s², above the 69.4 zero acceleration there
    would allow under that window, so braking as it must; entering
    the block after it moves the window a block on and releases the brake, whose
    deceleration is ramped out at full jerk to 81.5 mm/s before the path speeds up to 86.0
    at the next boundary. That ramp was a dip finding; it is the jerk limit's, as after an
    event. A path 10 % below that after the ramp is still a dip."""
    rec, samples = _recorded(feed_scenario(46))
    ch = rec.task.ch
    assert check_motion(rec.program, rec.table, ch.look_ahead_blocks, ch.cycle_time,
                        samples) == []  # fmt: skip
    found = _scaled(rec, samples, 16, range(12, 18), 0.9)  # after the ramp's end (5 ms)
    assert any(f.startswith("dip") and "boundary 17 " in f for f in found), found


def test_the_gap_s_anchor_moves_to_each_run_boundary_passed_as_expected() -> None:
    """CAM seed 619: override 35 → 122 % while the path brakes at 392 mm/s, 18 mm before a
    run boundary it passes at its cap of 1.29 mm/s, two more after it. From the event's
    state the third one's cap of 70.7 mm/s lay in a jerk gap (x1 = 59.9), and the second
    one's cap of 49.6 before it read as a dip below x1. What lies after a run boundary
    passed at what the rules expect there is reachable from that boundary's state: no
    finding, and the run has no other problem."""
    _, hard, slow, errors = check(cam_scenario(619))
    assert (hard, slow, errors) == ([], [], 0)


def test_a_gap_is_read_with_the_limits_before_the_boundary() -> None:
    """A cold review's program: a line at F12000 (8 m/s², 400 m/s³ on X) into a tangent arc of
    4 mm (its cap 60.8 mm/s, 3.2 m/s² and 160 m/s³). With the arc's lower limits, 60.8 mm/s
    at the arc lay in a jerk gap from 200 mm/s 8.2 mm before it, and a made-up path that
    brakes to 8 mm/s after an override step of 1 % and crawls into the arc passed. The path
    brakes toward the arc under the line's limits, which reach 60.8: found."""
    ch = dataclasses.replace(shipped(), cycle_time=1e-3)
    task = GeoTask(ch, "G01 X0 Y0 F600\nG01 X40 F12000\nG03 X44 Y4 I0 J4\nM30\n")
    # the state the path re-plans from at the override step (cycle 159), 8.254 mm before the
    # arc at 199.66 mm/s: with the arc's limits x1 = 3.0 and x2 = 61.0 mm/s, above the arc's
    # own cap
    v0 = 0.19966
    samples = drive(task, v0, ch.cycle_time, 1300, lambda i: -8.0 if 161 <= i < 185 else 0.0,
                    lambda i: 1.0 if i < 160 else 1.01)  # fmt: skip
    found = check_motion(task.interp.program, task.interp.table, 30, ch.cycle_time, samples)
    assert any(f.startswith("boundary 1 ") for f in found), found


def test_a_brake_zero_acceleration_would_spare_is_no_window_release() -> None:
    """A cold review's made-up path: 0.5 mm blocks at F12000, look-ahead 3 (the window's end
    holds the path at 43.6 mm/s with zero acceleration at each boundary); the path passes
    boundary 30 there but braking at −4 m/s², goes down to about 23 mm/s and comes back. Zero
    acceleration at 30 would have done, so the window's move there releases no brake it
    needed: the dip is found."""
    ch = dataclasses.replace(shipped(), cycle_time=1e-3)
    text = "G01 X0 Y0 F600\n" + "".join(f"G01 X{(i + 1) * 0.5:.1f} F12000\n" for i in range(80))
    task = GeoTask(ch, text + "M30\n")

    def accel(i: int) -> float:
        return -4.0 if 344 <= i < 349 else 4.0 if 349 <= i < 354 else 0.0  # b30 in cycle 344

    samples = drive(task, 0.0437, ch.cycle_time, 400, accel)
    found = check_motion(task.interp.program, task.interp.table, 3, ch.cycle_time, samples)
    assert any(f.startswith(("dip", "boundary 31 ")) for f in found), found


def test_a_window_release_is_credited_only_the_deceleration_its_caps_need() -> None:
    """Feeds seed 46 (`test_a_brake_the_window_s_move_releases_ramps_out_after_the_boundary`,
    clean as it ran) made up: its deceleration doubled in the two samples around boundary 16
    (−3.9 m/s² there) and the path 12 % slower for 13 ms after it. Ramped out from −3.9 the
    release ends at 67.2 mm/s, and the check took the dip down to 72.0 for the jerk limit's;
    what lies after 16 under the window before (rest at its end, boundary 17) needs −2.56
    there (`PathRules.least_brake`), whose ramp ends at 78.2: the dip is found."""
    rec, samples = _recorded(feed_scenario(46))
    ch = rec.task.ch
    k = next(i for i, smp in enumerate(samples) if smp.s >= rec.table.s[16])
    out = list(samples)
    for i in (k - 1, k):
        out[i] = dataclasses.replace(out[i], a=2.0 * out[i].a)
    for i in range(k + 1, k + 14):
        out[i] = dataclasses.replace(out[i], v=0.88 * out[i].v)
    found = check_motion(rec.program, rec.table, ch.look_ahead_blocks, ch.cycle_time, out)
    assert any(f.startswith("dip") and "boundary 17 " in f for f in found), found


def _short_drop_made_up(decel: float, slower: float) -> list[str]:
    """`short_drop_scenario` (F3000, six blocks at F60000, override 100 → 25 % 1.55 mm
    before the F6000 block, look-ahead 30, 1 ms) as the core ran it, checked with the
    deceleration read in the two samples around the F6000 block's end (boundary 27, where
    the ceiling rises from 25 to 250 mm/s) times `decel` and the velocity in the 6 ms after it
    times `slower`."""
    sc = short_drop_scenario(3000, 6, 1.55, 0.25, 30, 1e-3)
    rec, samples = _recorded(sc)
    b = sc.seed + 1
    k = next(i for i, smp in enumerate(samples) if smp.s >= rec.table.s[b])
    out = list(samples)
    for i in (k - 1, k):
        out[i] = dataclasses.replace(out[i], a=decel * out[i].a)
    for i in range(k + 1, k + 7):
        out[i] = dataclasses.replace(out[i], v=slower * out[i].v)
    ch = rec.task.ch
    return check_motion(rec.program, rec.table, ch.look_ahead_blocks, ch.cycle_time, out)


def test_a_brake_from_just_above_a_ceiling_ramps_out_where_the_ceiling_rises() -> None:
    """The path brakes at once from 32.2 mm/s toward the F6000 block's lowered ceiling of
    25 mm/s and passes its end at 25.55 mm/s and −0.66 m/s², 2 % above the ceiling: its
    ramp-out ends at 25.0, and from there 28.6 mm/s is what it reaches at the next run
    boundary. The check credited the ramp-out only 5 % (REL_TOL) above the ceiling and
    expected 30.6 there as from zero acceleration. Now from any velocity above it, but
    never below the ceiling: the same path with three times the deceleration read at the
    boundary and 12 % slower after it is found (ramped out from −2.0 m/s² it would end at
    20.6 mm/s)."""
    assert _short_drop_made_up(1.0, 1.0) == []
    found = _short_drop_made_up(3.0, 0.88)
    assert any(f.startswith(("dip", "boundary 28 ")) for f in found), found


def test_a_run_boundary_inside_the_ramp_toward_the_ceiling_credits_the_whole_brake() -> None:
    """A cold review's program: override 100 → 10 % at 47 mm/s, 0.16 mm before the end of
    an F4800 block (8 mm/s now); the path passes that end (the ceiling rises to 100) at
    13.29 mm/s and −2.57 m/s², and a run boundary 0.05 mm on, passed with zero acceleration,
    at x1 = 5.0. The brake toward the ceiling would ramp out over 0.055 mm, past that
    boundary: there the whole deceleration is the path's to ramp out (the bound expected
    8.0 at the boundary, which nothing with zero acceleration there reaches)."""
    moves = [(20.2, 0, 4800), (20.25, 0, 60000), (20.45, 0.00035, 24000),
             (20.94966, 0.01867, 4800), (21.14952, 0.02635, 3000), (21.24944, 0.03019, 1200),
             (22.99541, 2.14537, 3000)]  # fmt: skip
    text = "G01 X0 Y0 F3000\nG01 X20 Y0\n" + "".join(f"G01 X{x} Y{y} F{f}\n" for x, y, f in moves)
    ch = dataclasses.replace(shipped(), look_ahead_blocks=8, cycle_time=1e-3)
    sched = Schedule(((0.4084522748996617, 0.1),), ())
    rec, samples = _recorded(Scenario(0, ch, text + "M30\n", sched))
    assert check_motion(rec.program, rec.table, 8, 1e-3, samples) == []


def test_the_brake_s_phases_are_the_brake_distance_s() -> None:
    """`brake_phases` (the lowest motion `least_brake` reads the caps off) covers what
    `brake_distance` says and ends at the velocity it brakes to, with zero acceleration, on
    random states within the limits (whose ramp-out alone stays at or above rest); from a
    deceleration above a_max (a lower limit ahead) it ends at v1 too, never harder than it
    started; `velocity_at` follows it."""
    rng = random.Random(5)
    for _ in range(2000):
        a_max, j_max = rng.uniform(1.0, 12.0), rng.choice((50.0, 400.0, 2000.0))
        v, a, v1 = rng.uniform(0.0, 1.0), rng.uniform(-a_max, a_max), rng.uniform(0.0, 1.0)
        above = rng.random() < 0.2  # a deceleration above a_max (a lower limit ahead)
        if above:
            a = -rng.uniform(a_max, 1.5 * a_max)
        if v + a * abs(a) / (2.0 * j_max) < 0.0:
            continue  # ramping the deceleration out alone ends below rest: a stop's brake
        phases = brake_phases(v, a, v1, a_max, j_max)
        d = travel(v, a, phases)
        if not above:  # (brake_distance jumps to a_max there)
            assert math.isclose(d, brake_distance(v, a, v1, a_max, j_max), rel_tol=1e-9,
                                abs_tol=1e-15)  # fmt: skip
        u, acc = v, a
        for t, jk in phases:
            assert t >= 0.0 and abs(acc) <= max(a_max, -a) * (1.0 + 1e-9) + 1e-12
            u, acc = u + t * (acc + t * jk / 2.0), acc + jk * t
            assert abs(acc) <= max(a_max, -a) * (1.0 + 1e-9) + 1e-12
        assert abs(acc) < 1e-9
        assert u <= v1 + 1e-9 or v1 >= v + a * abs(a) / (2.0 * j_max)  # at v1, or never above
        assert math.isclose(velocity_at(v, a, phases, d), u, abs_tol=1e-9)
