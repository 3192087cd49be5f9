"""The check's other side (tests/support/motion_overrun.py; issue 36 item 1, sixth round part
O): the path is never faster than the rules let it be. A fifth-round cache bug ran a 1 mm/s
(F60) block at 19.3 mm/s and no check saw it. And a rest just before an M00 that registers a
cycle later is the M00's, not a rest without a rule."""

from __future__ import annotations

import dataclasses

from liftd.cnc.geo_task import GeoTask
from liftd.cnc.plc import Schedule, SimPlc, parse_override_spec
from liftd.sim.simulate import run_cycles
from tests.support.channel import shipped
from tests.support.motion_check import Recorder, Sample, check_motion
from tests.support.motion_overrun import boundary_velocity
from tests.support.motion_rules import PathRules, crossing_velocity
from tests.unit.cnc.path.test_dense_constraints import poisoned
from tests.unit.cnc.path.test_motion_check import at, drive

MM = 1e-3
DT = 1e-3
LINE = "G01 X0 Y0 F600\n" + "".join(f"G01 X{10 * (i + 1)} F6000\n" for i in range(8)) + "M30\n"


def findings(task: GeoTask, samples: list[Sample], look_ahead: int = 30) -> list[str]:
    return check_motion(task.interp.program, task.interp.table, look_ahead, DT, samples)


def overruns(found: list[str]) -> list[str]:
    return [f for f in found if f.startswith("overrun")]


def line_task() -> GeoTask:
    """10 mm collinear blocks at F6000 (100 mm/s), 1 ms cycles, the shipped machine."""
    return GeoTask(dataclasses.replace(shipped(), cycle_time=DT), LINE)


def test_a_path_above_its_ceiling_is_an_overrun() -> None:
    """At 1.2 × F (120 mm/s on F6000) the path is too fast in every cycle and at every
    boundary; at F itself it is not (the tolerance is rounding only)."""
    task = line_task()
    fast = overruns(findings(task, drive(task, 0.12, DT, 200)))
    assert (
        fast[0]
        == "overrun: 120.0000 mm/s in segment 0 (line 2) above its ceiling 100.0000 (t=0.0010 s)"
    )
    assert (
        "overrun: boundary 1 (line 2) at 120.0000 mm/s above its cap 100.0000 (t=0.0840 s)" in fast
    )
    assert overruns(findings(task, drive(task, 0.1, DT, 200))) == []
    assert overruns(findings(task, drive(task, 0.1 * (1 + 1e-5), DT, 200)))


def brake(stop_at: float) -> list[Sample]:
    """The path cruises at 100 mm/s; the override drops to 50 % in cycle 40 and the path
    brakes from there at −2 m/s² (jerk-limited in and out at 500 m/s³) to `stop_at` and
    cruises on there (10 mm blocks: from segment 0 into 1)."""
    out: list[Sample] = []
    s, v, a = 0.0, 0.1, 0.0
    for i in range(121):
        ov = 1.0 if i < 40 else 0.5
        if i >= 40:
            # the acceleration that ends the brake at stop_at: ramp out when v + a²/2J reaches it
            a = (
                max(a - 500.0 * DT, -2.0)
                if v + a * abs(a) / 1000.0 > stop_at
                else min(a + 500.0 * DT, 0.0)
            )
        if i:
            s += v * DT + a * DT * DT / 2.0
            v += a * DT
        out.append(at(s, v, int(s / 0.01), t=i * DT, a=a, ov=ov))
    return out


def test_the_brake_after_an_override_drop_is_no_overrun() -> None:
    """After the override drops the path is above the new ceiling while it brakes (the CNC
    brakes from the velocity it has): no overrun while it comes down without a pause."""
    task = line_task()
    samples = brake(0.05)
    assert samples[45].v > 0.05 * 1.1  # still well above the new ceiling, braking
    assert overruns(findings(task, samples)) == []


def test_a_brake_that_stops_above_the_new_ceiling_is_an_overrun() -> None:
    """The same brake ends at 70 mm/s, above the new ceiling of 50, and the path cruises
    there: found once, where the brake paused."""
    task = line_task()
    found = overruns(findings(task, brake(0.07)))
    assert len(found) == 1 and "paused at 70." in found[0], found


def test_a_rise_after_an_override_drop_is_an_overrun() -> None:
    """While above the new ceiling the path does not accelerate: a brake that turns back up
    (to 80 mm/s) is found at once."""
    task = line_task()
    samples = brake(0.07)
    up = [dataclasses.replace(x, v=x.v + (i - 100) * 1e-3, a=1.0) if i >= 100 else x
          for i, x in enumerate(samples)]  # fmt: skip
    assert len(overruns(findings(task, up))) == 1


def test_the_poisoned_cache_s_overrun_is_found() -> None:
    """The review's program of the fifth round (`poisoned`, /tmp/rv5/poison_run.py): before
    54f1834 a cached chain value let the path pass boundary 25 into the F60 blocks
    at 19.3 mm/s and brake there; the core now passes at 1 mm/s. The core's run has no
    overrun; the same samples with the path 19.3 mm/s at boundary 25, braking at 8 m/s² into
    the F60 block as it did then, are found."""
    ch = dataclasses.replace(shipped(), look_ahead_blocks=200)
    task = GeoTask(ch, poisoned())
    rec = Recorder(task)
    for snap in run_cycles(task, SimPlc(0.02), Schedule(), ch.cycle_time, 60.0):
        rec(snap)
    assert overruns(rec.check()) == []
    s25 = rec.program.boundaries[25].s
    i = next(i for i, x in enumerate(rec.samples) if x.s >= s25)
    v, s = 19.3 * MM, rec.samples[i - 1].s
    bad = rec.samples[:i]
    for k in range(3):
        s += v * ch.cycle_time
        v -= 8.0 * ch.cycle_time
        bad.append(dataclasses.replace(rec.samples[i + k], s=s, v=v, a=-8.0, seg=25))
    found = overruns(check_motion(rec.program, rec.table, 200, ch.cycle_time, bad))
    assert found and "above its ceiling 1.0000" in found[0], found


def m00_program() -> str:
    """The reviewer's generator (/tmp/r5/cut5.py, seed 0, case 4): 300 blocks of 0.1 mm at
    F60000/45000/24000/36000, M00 after blocks 63, 149 and 280, corners at 104 and 276."""
    feeds = (60000, 45000, 24000, 36000)
    lines = ["G01 X0 Y0 F600"]
    x = y = 0.0
    for i in range(300):
        if i in (104, 276):
            y += 0.1
            lines.append(f"G01 Y{y:.4f} F{feeds[i % 4]}")
        else:
            x += 0.1
            lines.append(f"G01 X{x:.4f} F{feeds[i % 4]}")
        if i in (63, 149, 280):
            lines.append("M00")
    return "\n".join([*lines, "M30"]) + "\n"


def test_a_rest_a_rounding_before_an_m00_is_the_m00_s() -> None:
    """The path comes to rest 2.6e-18 m before the M00 after block 63 at t = 0.080 s, a few
    ns before the cycle ends; the core registers the stop (`stopped_at`) in the next cycle.
    The check read it as a rest without a rule."""
    ch = dataclasses.replace(shipped(), look_ahead_blocks=200, cycle_time=2e-3)
    task = GeoTask(ch, m00_program())
    rec = Recorder(task)
    schedule = Schedule(tuple(parse_override_spec("0.03:60,0.06:180,0.3:100")), ())
    for snap in run_cycles(task, SimPlc(0.02), schedule, ch.cycle_time, 60.0):
        rec(snap)
    rest = next(x for x in rec.samples if x.v == 0.0 and x.stopped_at is None and x.t > 0.0)
    b = rest.seg + 1
    assert rec.program.boundaries[b].stop and 0.0 < rec.program.boundaries[b].s - rest.s < 1e-12
    assert not [f for f in rec.check() if f.startswith(("rest", "stopped"))]


def test_a_rest_before_a_stop_only_where_the_stop_registers_next() -> None:
    """Only there: the same rest read where the next cycle does not register the stop, or 1 µm
    before it, is a rest without a rule."""
    task = GeoTask(
        dataclasses.replace(shipped(), cycle_time=DT),
        "G01 X0 Y0 F600\nG01 X10 F6000\nM00\nX20\nM30\n",
    )
    s1 = task.interp.program.boundaries[1].s
    moving = at(s1 - 1e-3, 0.01, 0, t=0.0, a=-1.0)

    def rest(gap: float, registered: bool) -> list[Sample]:
        still = at(s1 - gap, 0.0, 0, t=DT)
        after = dataclasses.replace(at(s1, 0.0, 1, t=2 * DT), stopped_at=1 if registered else None)
        return [moving, still, after]

    def rests(samples: list[Sample]) -> list[str]:
        return [f for f in findings(task, samples) if f.startswith("rest")]

    assert rests(rest(1e-18, True)) == []
    assert rests(rest(1e-18, False))
    assert rests(rest(1e-6, True))


def drop_before_feed_drop(drop_mm: float, decel: float) -> tuple[GeoTask, list[Sample]]:
    """11 mm at F12000 (200 mm/s), then F6000; the override drops to 50 % (ceilings 100 and 50
    mm/s) as the path passes `drop_mm` at 200 mm/s, and it brakes from there, its
    deceleration raised at 500 m/s³ up to `decel`, until it is at 50 mm/s."""
    task = GeoTask(dataclasses.replace(shipped(), cycle_time=DT),
                   "G01 X0 Y0 F600\nG01 X11 F12000\nX30 F6000\nM30\n")  # fmt: skip
    s_1 = task.interp.program.boundaries[1].s
    out: list[Sample] = []
    s, v, a, ov = 0.0, 0.2, 0.0, 1.0
    for i in range(200):
        if ov < 1.0 or s >= drop_mm * MM:
            ov = 0.5
            a = max(a - 500.0 * DT, -decel) if v > 0.05 else 0.0
        if i:
            s += v * DT + a * DT * DT / 2.0
            v = max(v + a * DT, 0.05)
        out.append(at(s, v, 1 if s >= s_1 else 0, t=i * DT, a=a, ov=ov))
    return task, out


def test_a_feed_cap_out_of_reach_at_the_drop_is_passed_above_braking() -> None:
    """The drop 1 mm before the feed drop: from 200 mm/s the path cannot get down to its new
    cap of 50 mm/s there (that takes ~4 mm), so it passes it above, braking on (the tracker's
    `Plan.soft_from`): no overrun. The same boundary 9 mm after the drop, passed above at
    ~150 mm/s by a brake of 1 m/s²: an overrun (50 mm/s was within reach)."""
    task, samples = drop_before_feed_drop(10.0, 8.0)
    assert overruns(findings(task, samples)) == []
    task, samples = drop_before_feed_drop(2.0, 1.0)
    found = overruns(findings(task, samples))
    assert len(found) == 1 and found[0].startswith("overrun: boundary 1 (line 2) at 14"), found
    assert "above its cap 50.0000" in found[0]


def test_a_brake_through_a_run_boundary_has_zero_acceleration_there_without_a_pause() -> None:
    """A run boundary (a kink) needs zero acceleration: the brake after an override drop
    through it ramps its deceleration out there, and a sample can fall on it. Made up: from
    200 mm/s, override 100 → 50 % at 2 mm, the path brakes at −1 m/s², at 0 in the cycle
    it passes the kink at 5 mm, and on at −1 m/s²: no pause; the same with the acceleration
    still 0 in the next cycle, a pause above the ceiling."""
    task = GeoTask(dataclasses.replace(shipped(), cycle_time=DT),
                   "G01 X0 Y0 F600\nG01 X5 F12000\nG01 X10 Y0.01\nX20\nM30\n")  # fmt: skip
    s_1 = task.interp.program.boundaries[1].s
    assert task.interp.table.gate[1]

    def samples(zero_cycles: int) -> list[Sample]:
        out: list[Sample] = []
        s, v, ov, zero = 0.0, 0.2, 1.0, 0
        for i in range(120):
            a = 0.0
            if ov < 1.0 or s >= 2.0 * MM:
                ov = 0.5
                crossing = s < s_1 <= s + v * DT
                zero = zero_cycles if crossing else max(zero - 1, 0)
                a = 0.0 if zero or v <= 0.1 else -1.0
            if i:
                s += v * DT + a * DT * DT / 2.0
                v = max(v + a * DT, 0.1)
            out.append(at(s, v, 1 if s >= s_1 else 0, t=i * DT, a=a, ov=ov))
        return out

    assert overruns(findings(task, samples(1))) == []
    found = overruns(findings(task, samples(2)))
    assert len(found) == 1 and "paused" in found[0], found


def _crossing(
    a: float, j1: float, j2: float, t0: float, t1: float
) -> tuple[PathRules, Sample, Sample, float]:
    """Two samples at t0 < 0 < t1 of a motion that crosses boundary 1 of `line_task` at t = 0
    at 100 mm/s and acceleration a, under jerk j1 before and j2 after (the rules, the two
    samples and the boundary's position)."""
    task = line_task()
    rules = PathRules(Recorder(task).program, task.interp.table, 30)
    b = 1
    s_b = task.interp.table.s[b]
    base = Sample(0.0, 0.0, 0.0, 0.0, 0, None, False, 1.0, False, frozenset(), frozenset(), True)
    states = [_state(0.1, a, j1 if t < 0 else j2, t) for t in (t0, t1)]
    last, smp = (
        dataclasses.replace(base, t=t, s=s_b + st[0], v=st[1], a=st[2], seg=k)
        for t, st, k in zip((t0, t1), states, (b - 1, b), strict=True)
    )
    return rules, last, smp, s_b


def _state(v: float, a: float, j: float, t: float) -> tuple[float, float, float]:
    """(s, v, a) t after a state at s = 0 under constant jerk j (t < 0: before it)."""
    return v * t + a * t * t / 2.0 + j * t**3 / 6.0, v + a * t + j * t * t / 2.0, a + j * t


def test_the_bound_on_a_crossing_holds_for_every_jerk_within_the_limit() -> None:
    """`boundary_velocity` reads the velocity at a boundary from the nearer sample and bounds
    how far the jerk can have moved it; the true crossing lies within that bound for every
    jerk history within J. Its first form (J·Δt²/2) left out that the jerk moves the
    crossing's time too: a brake state passes a feed drop at its cap at −2.8 m/s², and the
    check read 100.0001 mm/s for a crossing at 100.0000 (feeds seed 956, 0.7 ms from the
    sample). Here: crossings at 100 mm/s at −4 … +4 m/s², jerks ±J on either side, samples
    1 ms apart, the boundary 0.1 … 0.7 ms after the first: within 1e-8 (relative; one
    Newton step's rounding, 2.3e-9 at most here, the check's tolerance is 1e-6; the first
    form was off by up to 7.2e-7)."""
    j_lim = _crossing(0.0, 0.0, 0.0, -DT, 0.0)[0].run_jerk(1)
    for a in (-4.0, -2.8, -1.0, 0.0, 1.0, 4.0):
        for j1, j2 in ((j_lim, j_lim), (-j_lim, -j_lim), (j_lim, -j_lim), (-j_lim, j_lim)):
            for near in (1e-4, 3e-4, 5e-4, 7e-4):
                for before in (True, False):
                    t0, t1 = (-near, DT - near) if before else (near - DT, near)
                    rules, last, smp, _ = _crossing(a, j1, j2, t0, t1)
                    v_b, moved = boundary_velocity(rules, last, smp, 1)
                    assert v_b - moved <= 0.1 * (1.0 + 1e-8), (a, j1, j2, near, before, v_b)
                    assert v_b + moved >= 0.1 * (1.0 - 1e-8), (
                        a, j1, j2, near, before, v_b, moved,
                    )  # fmt: skip


def test_a_crossing_s_velocity_is_exact_for_constant_jerk_through_both_samples() -> None:
    """`crossing_velocity` (the quintic through both samples' position, velocity and
    acceleration) reads a crossing exactly where the jerk is constant from one sample to the
    next: crossings at 100 mm/s at −4 … +4 m/s², jerks ±J, 1 ms samples, the boundary 0.1 …
    0.9 ms after the first. Constant jerk read from the first sample alone (the check's first
    form) leaves the second sample's position and velocity out: 25.047 mm/s for 24.781 at
    drops seed 1444, where a brake lay between two samples of −0.071 m/s²."""
    j_lim = _crossing(0.0, 0.0, 0.0, -DT, 0.0)[0].run_jerk(1)
    for a in (-4.0, -1.0, 0.0, 1.0, 4.0):
        for j in (j_lim, -j_lim, 0.0):
            for near in (1e-4, 5e-4, 9e-4):
                _, last, smp, s_b = _crossing(a, j, j, -near, DT - near)
                assert abs(crossing_velocity(last, smp, s_b) - 0.1) <= 1e-9, (a, j, near)
