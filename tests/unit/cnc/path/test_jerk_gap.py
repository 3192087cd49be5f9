"""Issue 36, known deviation 6 of docs/geo-core.md: a run boundary's feed cap in the jerk gap.

With a jerk limit the end velocities the path can have at a run boundary (zero acceleration
there) within a distance are [0, x1] ∪ [x2, v_p]. An override drop can put the boundary's new
feed cap between x1 and x2; the path took x1, a near-stop where the CNC only slows down. It now
passes the cap at x2, as slowly as it can above it, as the rule for an override drop says,
within the boundary's hard cap and what the candidates after it allow."""

from __future__ import annotations

import dataclasses
import math

import pytest

from liftd.cnc.geo_task import GeoTask
from liftd.cnc.path.tracker import Tracker
from liftd.cnc.path.velocity import brake_distance
from liftd.cnc.plc import Schedule, SimPlc
from liftd.sim.simulate import run_cycles
from tests.support.cam_cases import cam_scenario
from tests.support.cam_runs import check, time_limit
from tests.support.channel import shipped
from tests.support.feed_cases import feed_scenario, short_drop_scenario
from tests.support.motion_check import Expected, Recorder, check_motion
from tests.support.scenarios import Scenario, describe, wide_scenario


def test_an_override_drop_before_a_rounding_kink_slows_the_path_and_does_not_stop_it() -> None:
    """Wide seed 641 (look-ahead 120, a polyline of 2 mm blocks with rounding kinks at F12000):
    override 120 → 50 % at 2.160 s at 230 mm/s; boundary 318's new cap of 100 mm/s lay in the
    gap, x1 = 0.03 mm/s: the path passed it at 0.0278 mm/s and came back to 100. (The run's
    other findings, 206–215 mm/s where the rules allow 219–230, are the 24th constraint
    counted as a stop, known deviation 1: the check finds them since the fifth round, part C.)"""
    sc = wide_scenario(641)
    _, hard, slow, errors = check(sc)
    assert hard == [] and errors == 0, (hard, describe(sc))
    assert not [f for f in slow if f.startswith(("dip", "boundary 318 "))], (slow, describe(sc))


@pytest.mark.parametrize("seed", [74, 465, 629])
def test_cam_programs_pass_a_cap_in_the_gap_above_it(seed: int) -> None:
    """CAM seeds whose override change left a run boundary's feed cap in the gap (seed 465:
    18.8 mm/s for 43.4, x1 below the cap)."""
    sc = cam_scenario(seed)
    _, hard, slow, errors = check(sc)
    assert hard == [] and errors == 0, (hard, describe(sc))
    assert slow == [], (slow, describe(sc))


def test_an_exact_brake_ruckig_refuses_at_the_edge_ends_just_below_the_cap_not_at_rest() -> None:
    """CAM seed 482: override 87 → 18 % at 0.949 s as the path, at 370 mm/s and accelerating,
    began its exact brake to a corner of 12.2034 mm/s 24 mm on (no room left: the brake needs
    the whole distance within 0.1 nm). Ruckig refused that target at the edge of what is
    feasible, the fallback took rest, and the path passed the corner at 0.033 mm/s. The
    highest velocity below the cap that ruckig accepts is 12.2034 · (1 − 1e-8), no dip."""
    sc = cam_scenario(482)
    _, hard, slow, errors = check(sc)
    assert hard == [] and errors == 0, (hard, describe(sc))
    assert slow == [], (slow, describe(sc))


# runs of tests/support/feed_cases.py whose target with zero acceleration at a boundary lay in
# the gap and which took x1, a near-stop, on 756cfb7 (thirteenth round): 915 (a forced re-plan
# toward a feed cap that an M00 beyond the brake to rest caps), 676 (x1 nearer the cap by 0.1
# mm/s after an override drop), 942 (above a lowered ceiling that ends before the boundary);
# 310 guards the fix for 915 (its first version aimed past a feed cap at a corner 0.1 mm on and
# braked through the cap at once: 3.77 mm/s for 13.6)


@pytest.mark.parametrize("seed", [310, 676, 915, 942])
def test_a_cap_in_the_gap_is_no_near_stop(seed: int) -> None:
    """Seed 915: 72.2 mm/s at +7.6 m/s², 5.04 mm before an F6000 boundary that an M00 0.5 mm
    after it caps at 46.3 mm/s with zero acceleration; the brake to 46.3 is longer than the
    brake to rest, and the path passed the boundary at 1.38 mm/s. It aims at the M00 now,
    passing the boundary as it brakes. Seed 676: override 180 → 100 % 2.9 mm before a run
    boundary of 50 mm/s; reachable with zero acceleration there 10.09 or 90.0, and the path
    took 10.09 (nearer by 0.1 mm/s), dipping to 3.84. Seed 942: override 100 → 10 % at
    38.9 mm/s, 0.4 mm before a run boundary of 29.3 mm/s, the 10 mm/s ceiling ending 0.2 mm
    before it; the path dipped to 0.75 mm/s, then (thirteenth round) passed it at x2 above
    the ceiling, 21.0 for 27.2 (`test_the_brake_from_above_a_short_lowered_ceiling_ramps_out
    _where_it_ends`). No finding now, no overrun, no tracker error."""
    sc = feed_scenario(seed)
    _, hard, slow, errors = check(sc)
    assert (hard, slow, errors) == ([], [], 0), describe(sc)


@pytest.mark.parametrize(("cycle", "found_before"), [(2e-3, 6.66), (1e-3, 24.68)])
def test_the_brake_from_above_a_short_lowered_ceiling_ramps_out_where_it_ends(
    cycle: float, found_before: float
) -> None:
    """0.2 mm blocks over rounding kinks (`short_drop`: F2400, then F60000, a 0.2 mm F6000
    block, three at F60000 and F6000 again), override 100 → 10 % 0.65 mm before the first
    F6000 block. The path enters it at about 29 mm/s, above its new ceiling of 10; the run
    boundary 0.4 mm on is capped at about 26 by the second F6000 block, and braking to 10
    does not fit before it. The target there was taken against the ceiling: as slowly as
    the path could pass it above 10 (x2), a brake that fills the whole 0.4 mm: 6.66 mm/s
    for 26.1 at 2 ms, 24.68 for 29.05 at 1 ms. The ceiling ends 0.2 mm before it: the
    brake at once toward it, ramped out where it ends (`Brakes._ceiling_end`), is what the
    CNC does and keeps the boundary (feeds seed 942: 21.0 → 27.2 mm/s)."""
    _, hard, slow, errors = check(short_drop_scenario(2400, 6, 0.65, 0.1, 30, cycle))
    assert (hard, slow, errors) == ([], [], 0), f"was {found_before} mm/s"


def _kinked(look_ahead: int, corner_deg: float, lift_stops: set[int]) -> Tracker:
    """F6000 on X with a slight kink at X10 (boundary 1) and a kink of `corner_deg` at X10.5
    (boundary 2), then 9.5 mm on: the tracker of that program."""
    ch = dataclasses.replace(shipped(), cycle_time=1e-3, look_ahead_blocks=look_ahead)
    dy = 0.5 * math.tan(math.radians(corner_deg))
    text = f"G01 X0 Y0 F6000\nG01 X10 Y0\nG01 X10.5 Y0.001\nG01 X20 Y{0.001 + 19 * dy:.4f}\nM30\n"
    return Tracker(GeoTask(ch, text).interp.table, look_ahead, lift_stops=lift_stops)


@pytest.mark.parametrize(("look_ahead", "corner_deg", "stops"), [(3, 0.0, {2}), (2, 0.0, {2}),
                                                                 (3, 30.0, set())])  # fmt: skip
def test_what_a_run_boundary_holds_for_after_it_is_kept_by_the_gap_rule(
    look_ahead: int, corner_deg: float, stops: set[int]
) -> None:
    """A cold review: the gap rule's x2 may pass a run boundary above its feed cap, within
    its hard cap, but never so fast that a stop or a hard cap after it is lost (a lift's stop
    0.5 mm on, also where it is the window's end; a corner 0.5 mm on). `hard_reach` is the
    highest velocity at the boundary, with zero acceleration there, that keeps them: the brake
    from it to the stop (the corner's transition cap) fits within the 0.5 mm, and from 1 %
    more it does not."""
    tr = _kinked(look_ahead, corner_deg, stops)
    tb = tr.con.tb
    w = min(1 + look_ahead, tb.n)
    v = tr.con.hard_reach(1, w)
    end = 0.0 if stops else min(tb.point_cap[2], tb.cap[2])
    a_max, j_max = tr.con.limits(1)
    room = tb.s[2] - tb.s[1]
    assert end < 0.5 * min(tb.point_cap[1], tb.cap[1])  # the case: it binds at boundary 1
    assert brake_distance(v, 0.0, end, a_max, j_max) <= room
    assert brake_distance(1.01 * v, 0.0, end, a_max, j_max) > room


@pytest.mark.parametrize("seed", [48, 381])
def test_x1_is_reached_without_a_dip(seed: int) -> None:
    """Feeds seed 48: override 150 → 40 % 2.09 mm before a run boundary of 20 mm/s, x1 =
    9.62 mm/s computed within the distance + 1 nm; ruckig's profile to it braked to 3.64 and
    came back. Seed 381: from a cruise at 73.0 mm/s (override 10 %) to x1 = 2.19 mm/s 1 mm
    on, ruckig's profile went down to 1.40 (the exact brake and a cruise at its end is not
    in its profile family) and `_unpin` found none without the dip. x1 is now within the
    distance itself, and the exact brake is planned where `_unpin` finds nothing: no dip."""
    sc = feed_scenario(seed)
    _, hard, slow, errors = check(sc)
    assert hard == [] and errors == 0, (hard, describe(sc))
    assert not any(f.startswith("dip") for f in slow), slow


def test_a_deceleration_too_long_to_ramp_out_before_a_run_boundary_ends_at_x1() -> None:
    """Feeds seed 193: override 40 → 200 % at 48.0 mm/s and −3.46 m/s², 0.36 mm before a
    run boundary whose cap rises from 8 to 40 mm/s. Ramping the deceleration out alone ends
    beyond the boundary, at 29.6 mm/s: zero acceleration there only after a harder brake,
    at x1 = 8.0 or below, and no x2. The tracker aimed at 29.6, ruckig refused it, and the
    fallback's profile went down to 0.0014 mm/s and came back to 9.1 at the boundary (a
    near-stop); it now brakes to x1 and passes the boundary at it (`Targets.pick_target`).
    The check's trace shows x1 expected there, met."""
    sc = feed_scenario(193)
    task = GeoTask(sc.channel, sc.text)
    rec = Recorder(task)
    for snap in run_cycles(task, SimPlc(0.02), sc.schedule, sc.channel.cycle_time,
                           time_limit(task.prog.table, sc)):  # fmt: skip
        rec(snap)
    trace: list[Expected] = []
    ch = sc.channel
    found = check_motion(rec.program, rec.table, ch.look_ahead_blocks, ch.cycle_time,
                         rec.samples, trace)  # fmt: skip
    assert found == [] and task.interp.plan_errors == 0, found
    (at_b,) = [e for e in trace if e.b == 23]
    assert at_b.ramp < math.inf and at_b.gap == pytest.approx(0.008, rel=1e-3)
    assert at_b.v == pytest.approx(at_b.gap, rel=1e-3)
    low = min(smp.v for smp in rec.samples if smp.t >= 6.69 and smp.s <= rec.table.s[23])
    assert low >= 0.99 * at_b.gap


RISING_AFTER_A_DROP = "\n".join([
    "G01 X20 Y10 F6000", "G01 X21.5249 Y10.7366 F10347", "G01 X22.6823 Y11.2957 F11422",
    "F12030", "G01 X23.4857 Y11.6838", "F13820", "G01 X24.8752 Y12.3550",
    "G01 X26.3158 Y13.0509 F15098", "G01 X27.0163 Y13.3893 F16379",
    "G01 X28.2988 Y14.0088 F2823", "F3065", "G01 X29.3251 Y14.5045", "F3399",
    "G01 X30.3072 Y15.0411", "G01 X31.2140 Y15.5365 F3808", "G01 X32.7834 Y16.3938 F4219",
    "G01 X34.4377 Y17.2975 F4441", "G01 X35.3427 Y17.7919 F4811", "M30",
]) + "\n"  # fmt: skip


def test_the_brake_from_an_override_drop_passes_a_run_boundary_above_its_lowered_cap() -> None:
    """A review's program (its generator's gen4 seed 413, the first 18 lines): feeds rising
    block by block over rounding kinks (run boundaries), override 100 → 15 % at 74 mm/s,
    0.96 mm before the kink into the F4811 block, whose cap the drop lowered to 12.0 mm/s
    (the ceiling behind the path 11.1). From there 12.0 with zero acceleration at the kink
    is in the jerk gap: x1 2.2 mm/s, x2 above the cap, which `pick_target` allowed only up
    to the kink's own feed cap, the same input's. The path passed the kink at 2.2 mm/s, a
    near-stop; now at x2, braking from the drop on, as the CNC brakes at once (known
    deviation 10), within the kink's transition cap and what lies after it."""
    ch = dataclasses.replace(shipped(), look_ahead_blocks=20, cycle_time=2e-3)
    sc = Scenario(413, ch, RISING_AFTER_A_DROP, Schedule(((0.4491, 0.15),), ()))
    _, hard, slow, errors = check(sc)
    assert (hard, slow, errors) == ([], [], 0)
