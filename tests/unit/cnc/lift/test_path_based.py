"""Path-based Lifting (vendor §2.2, docs/reference/design.md §4): z = f(s) planned in path preparation,
coupled to the path. Small programs with hand-checkable numbers.

Hand figures for the test machine's Z (a = 10 m/s², j = 500 m/s³, v_max 1 m/s): a rest-to-rest
move of D = 50 mm reaches a_max (D ≥ 2a³/j² = 8 mm), so with t_j = a/j = 20 ms its peak
velocity is v_p = a·(−t_j + √(t_j² + 4D/a))/2 = 0.614143 m/s and it takes
T = 2·(v_p/a + t_j) = 162.8286 ms.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from liftd.cnc.geo_program import lifting_profiles, load_program
from liftd.cnc.lift.path_based import LOOK_AHEAD, _extremes, plan_part
from liftd.cnc.lift.profile import state_at
from liftd.cnc.nc import DecoderContext, decode
from liftd.cnc.nc.blocks import ErrorId, Severity
from liftd.cnc.params import ChannelParams, LiftMethod, SlopeType
from liftd.cnc.plc import Schedule, parse_feedhold_spec, parse_override_spec
from liftd.cnc.snapshot import ChannelState, GeoInputs, GeoSnapshot, LiftPhase
from tests.support.channel import make_channel
from tests.support.closed_loop import events, fd_ratios, run_task

MM = 1e-3
A, J = 10.0, 500.0
T_J = A / J


def rest_to_rest(d: float, a: float = A, j: float = J) -> tuple[float, float]:
    """(peak velocity, duration) of a time-optimal rest-to-rest move that reaches a."""
    t_j = a / j
    v_p = a * (-t_j + math.sqrt(t_j * t_j + 4.0 * d / a)) / 2.0
    return v_p, 2.0 * (v_p / a + t_j)


V_P, T_50 = rest_to_rest(0.05)


def lifting(**kw: object) -> ChannelParams:
    return make_channel(LiftMethod.LIFTING, **kw)  # type: ignore[arg-type]


def with_p442(ch: ChannelParams, err: float, warn: float = 0.5) -> ChannelParams:
    axes = tuple(
        dataclasses.replace(ax, dyn_a_err=err, dyn_a_warn=warn) if ax.name == "Z" else ax
        for ax in ch.axes
    )
    return dataclasses.replace(ch, axes=axes)


def sched(override: str = "", hold: str = "") -> Schedule:
    return Schedule(tuple(parse_override_spec(override)), tuple(parse_feedhold_spec(hold)))


def in_range(snaps: list[GeoSnapshot]) -> list[GeoSnapshot]:
    return [s for s in snaps if s.lift_phase is LiftPhase.COUPLED]


def test_hand_figures_of_the_test_axis() -> None:
    assert pytest.approx(0.614143, abs=1e-6) == V_P and pytest.approx(0.1628286, abs=1e-7) == T_50


@pytest.mark.parametrize(
    ("z0", "v0", "a0", "target"),
    [
        (0.0, 0.0, 0.0, 0.05),
        (0.0, 0.0, 0.0, 0.002),
        (0.05, 0.0, 0.0, 0.0),
        (0.01, 0.3, 4.0, 0.0),
        (0.0, 0.0, 0.0, 0.5),
        (0.02, -0.2, -6.0, 0.03),
        (0.0, 1.3, 12.0, 0.3),
    ],
)
def test_extremes_are_exact_on_every_profile_shape(
    z0: float, v0: float, a0: float, target: float
) -> None:
    """max |v|, |a|, |j| over a window of a profile, against dense sampling (the path limits
    of a range are built on them: `segment_cap`)."""
    prof = lifting_profiles(lifting())
    traj = prof.to_rest(z0, v0, a0, target)  # with and without constant-a or constant-v phases
    d = traj.duration
    for t0, t1 in ((0.0, d), (0.0, d * 0.37), (d * 0.21, d * 0.64), (d * 0.5, d * 1.5)):
        states = [state_at(traj, min(t0 + (t1 - t0) * k / 4000, d)) for k in range(4001)]
        v, a, j = _extremes(traj, t0, t1)
        assert v == pytest.approx(max(abs(x[1]) for x in states), rel=1e-5, abs=1e-9)
        assert a == pytest.approx(max(abs(x[2]) for x in states), rel=1e-3, abs=1e-9)
        fd_jerk = np.abs(np.diff([x[2] for x in states])).max() / ((t1 - t0) / 4000)
        assert j == pytest.approx(fd_jerk, rel=1e-2)


# -- the plan ------------------------------------------------------------------------------------
def test_plan_rises_holds_and_lowers_at_constant_path_velocity() -> None:
    prof = lifting_profiles(lifting())
    # 100 mm of path at 100 mm/s: 1 s of plan time, Z 0 → 50 mm (POS_LIMIT) → 0
    part = plan_part(prof, 0.0, 0.1, 0.0, 0.0, 0.05, t_feed=1.0)
    assert part.t_plan == pytest.approx(1.0)
    rate = 1.0 / 0.1  # τ per metre of path
    z_mid_rise, dz, _ = part.state(T_50 / 2 / rate)
    assert z_mid_rise == pytest.approx(0.025, abs=1e-7)  # symmetric profile: half way up
    assert dz == pytest.approx(V_P * rate, rel=1e-5)  # dz/ds = Zp'·T/L
    assert part.state(T_50 / rate)[0] == pytest.approx(0.05, abs=1e-9)  # at POS_LIMIT
    assert part.state(0.05)[0] == pytest.approx(0.05, abs=1e-9)  # holding
    assert part.state((1.0 - T_50) / rate)[0] == pytest.approx(0.05, abs=1e-9)  # fall starts
    assert part.state((1.0 - T_50 / 2) / rate)[0] == pytest.approx(0.025, abs=1e-7)
    assert part.state(0.1) == (0.0, 0.0, 0.0)
    assert part.bounds(0.0, 0.1)[0] == pytest.approx(V_P * rate, rel=1e-5)  # max dz/ds


def test_plan_switches_during_the_rise_when_time_is_short() -> None:
    prof = lifting_profiles(lifting())
    part = plan_part(prof, 0.0, 0.1, 0.0, 0.0, 0.05, t_feed=0.2)  # < 2·T_50: no hold
    z = [part.state(0.1 * k / 400)[0] for k in range(401)]
    # stopping at the top and coming back rest-to-rest would give 15 mm (0.1 s up, 0.1 s
    # down: v_p = (T/2 − t_j)·a = 0.3 m/s, D = v_p·(v_p/a + t_j)); switching to the descent
    # while still rising gets higher, the vendor's "maximum acceleration" profile
    assert 0.015 < max(z) < 0.05 and z[-1] == 0.0
    assert part.rise is not None and part.fall is not None
    assert part.t_switch + part.fall.duration == pytest.approx(0.2, abs=1e-9)  # lands on time


def test_p442_scales_the_planning_acceleration() -> None:
    ch = with_p442(lifting(), 0.5)  # P-AXIS-00442 = 500 → a_plan = a_max · 500/1000
    prof = lifting_profiles(ch)
    assert prof.a_max == pytest.approx(5.0)
    part = plan_part(prof, 0.0, 0.1, 0.0, 0.0, 0.05, t_feed=1.0)
    v_p, t_50 = rest_to_rest(0.05, a=5.0)
    assert t_50 == pytest.approx(0.21025, abs=1e-5)
    assert part.state(t_50 / 10.0)[0] == pytest.approx(0.05, abs=1e-9)
    assert part.state(0.999 * t_50 / 10.0)[0] < 0.05
    assert part.bounds(0.0, 0.1)[0] == pytest.approx(v_p * 10.0, rel=1e-5)


def test_path_preparation_limits_the_path_inside_the_range() -> None:
    """Each segment of a range gets the path limits that keep Z within a_max and j_max at
    100 % override (issue 37 item 3, `segment_cap`): with C1..C3 the largest |dz/ds|,
    |d²z/ds²|, |d³z/ds³| over the segment, C2·V² + C1·A ≤ a_max and C3·V³ + 3·C2·V·A + C1·J
    ≤ j_max; Z's plan takes all of a_max at the programmed feed, so the feed is reduced."""
    ch = lifting()
    text = "G01 X10 Y10 Z0 F6000\nZ[LIFT_START POS=0 POS_LIMIT=50]\nG01 X110\nZ[LIFT_END]\nM30\n"
    prog = load_program(text, ch, (0.0, 0.0, 0.0))
    seg = prog.path.segments[1]
    plan = prog.plans[0]
    assert plan is not None
    c1, c2, c3 = plan.parts[0].bounds(seg.s0, seg.s0 + seg.length)
    assert c1 == pytest.approx(V_P * 10.0, rel=1e-5)  # dz/ds max = v_p·T/L, T = 1 s, L = 0.1 m
    assert c2 == pytest.approx(A * 100.0, rel=1e-5) and c3 == pytest.approx(J * 1000.0, rel=1e-5)
    v, a, j = seg.v_lift_ov, seg.a_max, seg.j_max
    assert 0.05 < v < 0.1  # the programmed 100 mm/s, reduced
    assert c2 * v * v + c1 * a <= A * (1 + 1e-9)
    assert c3 * v**3 + 3.0 * c2 * v * a + c1 * j <= J * (1 + 1e-9)
    assert seg.v_lift == pytest.approx(1.0 / c1, rel=1e-5)  # Z within v_max at any override
    plain = load_program(text, make_channel(LiftMethod.ADVANCED), (0.0, 0.0, 0.0))
    assert prog.path.segments[0] == plain.path.segments[0]  # outside the range: untouched


def test_too_short_a_range_gets_its_feed_reduced() -> None:
    ch = lifting()
    # 10 mm at 200 mm/s = 50 ms, but Z needs T_50 for 0 → 50 mm: feed reduced to L / T_50
    # (and below, for the path to accelerate within Z's limits)
    text = "G01 X10 Y10 Z0 F6000\nZ[LIFT_START POS=50 POS_LIMIT=50]\nG01 X20 F12000\nZ[LIFT_END]\nM30\n"
    prog = load_program(text, ch, (0.0, 0.0, 0.0))
    v_ov = prog.path.segments[1].v_lift_ov
    assert 0.5 * 0.01 / T_50 < v_ov <= 0.01 / T_50 * (1 + 1e-9)
    task, snaps = run_task(ch, text)
    assert snaps[-1].state is ChannelState.READY
    (rec,) = task.lift.records
    assert rec.arrival_error == 0.0
    assert max(s.v_path for s in in_range(snaps)) <= v_ov * (1 + 1e-6)
    assert fd_ratios(ch, snaps)[1:, 2].max() <= 1.0 + 1e-9  # Z within a_max and j_max


def test_z_keeps_its_limits_when_the_path_accelerates_inside_the_range() -> None:
    """Issue 37 item 3, its program: a range that starts from rest, one block at F6000. The
    path's ramps inside the range took Z to 1.08 × a_max (jerk 1.28 × j_max) at 100 %
    override; vendor §2.2.1 keeps Z within its maximum acceleration there, and only feed
    changes (override, feed hold) use the overload band of P-AXIS-00442."""
    ch = lifting()
    text = (
        "G01 X0 Y0 Z1 F6000\nZ[LIFT_START POS=1 POS_LIMIT=40]\nG01 X100 F6000\nZ[LIFT_END]\nM30\n"
    )
    task, snaps = run_task(ch, text)
    assert snaps[-1].state is ChannelState.READY
    (rec,) = task.lift.records
    assert rec.peak == pytest.approx(0.04) and rec.arrival_error == 0.0
    assert rec.z_a_max_ratio <= 1.0
    # from the range's start: before it Z is a path axis of the first block, which passes its
    # 90° corner into X at the transition cap (issue 36), within the transition parameters
    start = next(i for i, s in enumerate(snaps) if any(e.name == "lift.start" for e in s.events))
    v, a, j = fd_ratios(ch, snaps[start:])[:, 2]
    assert a <= 1.0 + 1e-9 and j <= 1.0 + 1e-9
    assert not events(snaps, "lift.z_acc_warning") and not events(snaps, "lift.z_acc_error")


# -- coupling in the GEO task ----------------------------------------------------------------------
RANGE = "G01 X10 Y10 Z1 F6000\nZ[LIFT_START POS=1 POS_LIMIT=40]\nG01 X110\nZ[LIFT_END]\nM30\n"


def z_by_x(snaps: list[GeoSnapshot]) -> tuple[np.ndarray, np.ndarray]:
    r = in_range(snaps)
    return np.array([s.positions[0] for s in r]), np.array([s.positions[2] for s in r])


@pytest.mark.parametrize(("override", "hold"), [("0:50", ""), ("0:100", "0.32:0.3"), ("0:130", "")])
def test_z_is_a_function_of_the_path_position(override: str, hold: str) -> None:
    ch = lifting()
    task, snaps = run_task(ch, RANGE, sched(override, hold))
    assert snaps[-1].state is ChannelState.READY
    plan = task.prog.plans[0]
    assert plan is not None
    x, z = z_by_x(snaps)
    s0 = plan.parts[0].s0  # the range starts at X10 (after the diagonal first block)
    want = np.array([plan.state(s0 + xi - 0.01)[0] for xi in x])
    assert np.abs(z - want).max() <= 1e-9
    assert z.max() == pytest.approx(0.04, abs=1e-9)
    (rec,) = task.lift.records
    assert rec.arrival_error == 0.0
    if hold:  # feed hold while Z rises: Z stops with the path, half way up
        held = [s for s in in_range(snaps) if s.v_path == 0.0]
        assert len(held) > 100 and {s.positions[2] for s in held} == {held[0].positions[2]}
        assert 0.002 < held[0].positions[2] < 0.039 and all(s.lift_vz == 0.0 for s in held)


def test_z_acceleration_scales_with_override_squared_and_is_reported() -> None:
    ch = lifting()
    # the range continues the block before and after it in one direction at one feed:
    # constant path velocity inside, so Z's acceleration is the plan's × override²; at 100 %
    # Z stays within a_max (the feed in the range is reduced for that, `segment_cap`)
    text = (
        "G01 X10 Y10 Z1 F6000\nG01 X20\nZ[LIFT_START POS=1 POS_LIMIT=40]\nG01 X120\n"
        "Z[LIFT_END]\nG01 X140\nM30\n"
    )
    ratios = {}
    for pct in (100, 150, 200):
        task, snaps = run_task(ch, text, sched(f"0:{pct}"))
        (rec,) = task.lift.records
        ratios[pct] = rec.z_a_max_ratio
        errors = events(snaps, "lift.z_acc_error")
        warnings = events(snaps, "lift.z_acc_warning")
        if pct == 100:
            assert not errors and not warnings and rec.z_a_max_ratio <= 1.0
        if pct == 200:
            assert errors and task.z_monitor.error_cycles > 0  # above a_max·(1 + 1000/1000)
    assert 0.5 < ratios[100] <= 1.0
    assert ratios[150] == pytest.approx(2.25 * ratios[100], rel=5e-3)
    assert ratios[200] == pytest.approx(4.0 * ratios[100], rel=5e-3)
    adv = make_channel(LiftMethod.ADVANCED)
    task, _ = run_task(adv, text, sched("0:150"))
    assert task.lift.records[0].z_a_max_ratio <= 1.0 + 1e-9  # Advanced never overloads Z


def test_look_ahead_overflow_lifts_early_and_lowers_over_the_last_part() -> None:
    ch = lifting()
    blocks = "".join(f"G01 X{14 + 4 * i}\n" for i in range(25))  # 25 motion blocks of 4 mm
    text = f"G01 X10 Y10 Z1 F6000\nZ[LIFT_START POS=1 POS_LIMIT=30]\n{blocks}Z[LIFT_END]\nM30\n"
    task, snaps = run_task(ch, text)
    assert snaps[-1].state is ChannelState.READY
    (rec,) = task.lift.records
    assert rec.premature and rec.arrival_error == 0.0
    x, z = z_by_x(snaps)
    x_cut = 0.010 + LOOK_AHEAD * 0.004  # inserted LIFT_END after the 20th block
    assert np.all(np.abs(z[np.abs(x - x_cut) < 0.0005] - 0.03) < 1e-9)  # at POS_LIMIT there
    # the lowering happens within the last 5 blocks only
    assert np.all(z[x <= x_cut] >= z[x <= x_cut][0] - 1e-12)
    assert z[x < x_cut + 1e-9].max() == pytest.approx(0.03, abs=1e-9)


def test_m_functions_count_as_internal_blocks() -> None:
    ch = lifting()
    blocks = "".join(f"G01 X{14 + 4 * i}\nM05\n" for i in range(11))  # 11 + 11 = 22 blocks
    text = f"G01 X10 Y10 Z1 F6000\nZ[LIFT_START POS=1 POS_LIMIT=30]\n{blocks}Z[LIFT_END]\nM30\n"
    task, snaps = run_task(ch, text)
    assert snaps[-1].state is ChannelState.READY
    assert task.lift.records[0].premature
    short = text.replace(blocks, "".join(f"G01 X{14 + 4 * i}\n" for i in range(20)))
    task, _ = run_task(ch, short)
    assert not task.lift.records[0].premature  # exactly 20: still one plan


def test_waiting_inside_the_range_stops_path_and_lift_together() -> None:
    ch = lifting()
    text = (
        "G01 X10 Y10 Z1 F6000\nZ[LIFT_START POS=1 POS_LIMIT=40]\nG01 X60\nG04 0.2\nG01 X110\n"
        "Z[LIFT_END]\nM30\n"
    )
    task, snaps = run_task(ch, text)
    assert snaps[-1].state is ChannelState.READY
    dwell = [s for s in in_range(snaps) if s.v_path == 0.0 and s.positions[0] == 0.06]
    assert len(dwell) >= 195  # 200 ms
    assert len({s.positions[2] for s in dwell}) == 1 and dwell[0].positions[2] > 0.02
    assert task.lift.records[0].arrival_error == 0.0


def test_suppressed_lift_sets_only_lift_suppressed_and_moves_z_with_the_path() -> None:
    ch = lifting(lift_min_dist=0.005)
    text = "G01 X10 Y10 Z1 F6000\nZ[LIFT_START POS=3 POS_LIMIT=40]\nG01 X14\nZ[LIFT_END]\nM30\n"
    task, snaps = run_task(ch, text)
    assert snaps[-1].state is ChannelState.READY
    flagged = [s for s in snaps if s.lift_suppressed]
    assert flagged and not any(s.lift_active for s in snaps)  # no double flag (vendor §2.6)
    z = np.array([s.positions[2] for s in flagged])
    assert z.max() <= 0.003 + 1e-12 and np.all(np.diff(z) >= -1e-12)  # straight, no lift
    assert snaps[-1].positions[2] == pytest.approx(0.003)


def test_range_without_path_motion_runs_time_based_and_the_path_waits() -> None:
    ch = lifting()
    text = "G01 X10 Y10 Z1 F6000\nZ[LIFT_START POS=51 POS_LIMIT=60]\nZ[LIFT_END]\nG01 X20\nM30\n"
    task, snaps = run_task(ch, text)
    assert snaps[-1].state is ChannelState.READY
    lifted = [s for s in snaps if s.lift_active]
    assert lifted and all(s.v_path == 0.0 for s in lifted)
    assert len(lifted) == pytest.approx(T_50 * 1000, abs=2)  # Z's time-optimal 50 mm
    assert snaps[-1].positions[2] == pytest.approx(0.051)


@pytest.mark.parametrize("inside", ["G01 X60\n", ""])
def test_program_error_inside_the_range_lifts_to_pos_limit_and_stays(inside: str) -> None:
    ch = lifting()
    text = f"G01 X10 Y10 Z1 F6000\nZ[LIFT_START POS=1 POS_LIMIT=40]\n{inside}X70 Q5\nZ[LIFT_END]\n"
    task, snaps = run_task(ch, text, max_time=5.0)
    line = 3 + inside.count("\n")
    assert snaps[-1].state is ChannelState.ERROR and snaps[-1].error_line == line
    # simulate's driver runs on until Z is at rest, up at POS_LIMIT
    assert snaps[-1].positions[2] == pytest.approx(0.04, abs=1e-9)
    assert snaps[-1].lift_vz == 0.0 and snaps[-1].lift_az == 0.0
    t0 = snaps[-1].t
    snaps += [task.step(GeoInputs(), t0 + k * 1e-3) for k in range(1, 201)]  # and stays
    assert snaps[-1].positions[2] == pytest.approx(0.04, abs=1e-9)
    assert snaps[-1].lift_phase is LiftPhase.HOLD_LIMIT
    # the time-based rise takes over from Z's state without a jolt (Z within its v, a, j)
    k = next(i for i, s in enumerate(snaps) if s.state is ChannelState.ERROR)
    assert fd_ratios(ch, snaps[k - 3 :])[:, 2].max() <= 1.0 + 1e-6


def test_down_is_an_nc_error_and_step_slope_a_warning() -> None:
    ch = lifting()
    start = (0.0, 0.0, 0.0)
    res = decode("Z[LIFT_START DOWN POS_LIMIT=-5]\n", DecoderContext.from_channel(ch, start))
    assert [e.id for e in res.errors] == [ErrorId.LIFT_DOWN_PATH_BASED]
    step = "#SLOPE[TYPE=STEP]\nZ[LIFT_START POS_LIMIT=5]\nG01 X10 F600\nZ[LIFT_END]\n"
    res = decode(step, DecoderContext.from_channel(ch, start))
    assert [(e.id, e.line, e.severity) for e in res.errors] == [
        (ErrorId.LIFT_STEP_SLOPE, 2, Severity.WARNING)
    ]
    adv = make_channel(slope=SlopeType.STEP)
    assert not decode(step, DecoderContext.from_channel(adv, start)).errors


def test_hsc_slope_is_allowed_with_path_based_lifting() -> None:
    ch = lifting()
    text = "#SLOPE[TYPE=HSC]\n" + RANGE
    task, snaps = run_task(ch, text)
    assert snaps[-1].state is ChannelState.READY and snaps[-1].error_id == 0
    assert task.lift.records[0].peak == pytest.approx(0.04, abs=1e-9)


def _range_time_without_lift(ch: ChannelParams, text: str, x0: float, x1: float) -> float:
    """The same program without its lift commands: the path's time from leaving X = x0 to
    arriving at X = x1 (cycle-resolved)."""
    plain = text.replace("Z[LIFT_START POS=1 POS_LIMIT=40]\n", "").replace("Z[LIFT_END]\n", "")
    _, snaps = run_task(ch, plain)
    t0 = max(s.t for s in snaps if s.positions[0] <= x0 + 1e-12)
    t1 = min(s.t for s in snaps if s.positions[0] >= x1 - 1e-12)
    return t1 - t0


@pytest.mark.parametrize(
    "blocks",
    [
        "X100 F12000\nX200 F6000\n",  # a programmed feed drop (issue 37 item 4)
        "X100 F6000\nX200 F12000\n",
        "X200 F6000\n",  # from rest, one block: the lift's limits cost time here
    ],
)
def test_path_delay_is_what_the_lift_cost_against_the_nominal_run(blocks: str) -> None:
    """path_delay_s is the time the lift cost against the same program's nominal run: the
    range's time minus the time the path takes there without the lift's limits (the same
    program without lift commands), never below 0. A programmed feed drop inside the range
    is the program's, not the lift's: it reported the whole range (1.57 s) when the path
    arrived at LIFT_END before the nominal run did."""
    ch = lifting()
    text = f"G01 X0 Y0 Z1 F12000\nZ[LIFT_START POS=1 POS_LIMIT=40]\n{blocks}Z[LIFT_END]\nM30\n"
    task, snaps = run_task(ch, text)
    assert snaps[-1].state is ChannelState.READY
    (rec,) = task.lift.records
    nominal = _range_time_without_lift(ch, text, 0.0, 0.2)
    lifted = rec.t_end - rec.t_start
    # the plain run's time is resolved to a cycle at both ends (its path leaves X = 0 at the
    # corner's transition cap since issue 36, not from rest, so its start falls between two
    # cycles too): 2 cycles
    assert rec.path_delay == pytest.approx(max(0.0, lifted - nominal), abs=2.5e-3)
    assert rec.path_delay < 0.5 * lifted
