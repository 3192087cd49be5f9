"""Issue 36, known deviation 8 of docs/geo-core.md: one brake passes the caps of a run. Inside a
run the path acceleration is continuous; it is zero only at a run boundary, a stop or the
window's end. The tracker composed a target's chain and the chain behind a run boundary link
by link, zero acceleration at every feed drop (CAM seed 41: boundary 70 at 44.5 for 47.2
mm/s; falling feeds block by block before a corner or an M00: the first drop at 39.8 where
one brake allows 56.4 mm/s). Each run goes through the per-cycle check of
tests/support/motion_check.py and the cycle checker (limits, tracker errors)."""

from __future__ import annotations

import dataclasses

import pytest

from liftd.cnc.geo_task import GeoTask
from liftd.cnc.plc import Schedule
from tests.support.cam_cases import cam_scenario
from tests.support.cam_runs import check, core_time
from tests.support.channel import shipped
from tests.support.feed_cases import (
    FALL_A,
    FALL_B,
    FALL_C,
    falling_feeds,
    falling_to_the_end,
    feed_scenario,
)
from tests.support.reference_bound import lower_bound_time
from tests.support.scenarios import Scenario


@pytest.mark.parametrize("seed", [41, 298, 0, 440])
def test_cam_programs_pass_a_runs_feed_drops_in_one_brake(seed: int) -> None:
    """CAM seed 41 (look-ahead 30: boundaries 70 and 71 at 44.5 and 42.8 for 47.2 and 45.7
    mm/s) and 298 (6 such findings): no slowdown the rules do not explain, nothing else
    either. CAM seed 0: with the caps composed, the shift of `Tracker._replan` gave up
    boundary 52's feed cap, in reach braking, and passed it at 34.19 for 33.09 mm/s (an
    overrun; known deviation 12): a brake at once instead (`Brakes.brake_through`). CAM
    seed 440: that brake, taken wherever an aimed profile failed, held boundary 23 at 317.9
    for 352.2 mm/s; it is taken only where the shift's profile passes the cap above."""
    cycles, hard, slow, errors = check(cam_scenario(seed))
    assert cycles > 0
    assert (hard, slow, errors) == ([], [], 0)


@pytest.mark.parametrize("look_ahead", [30, 120])
@pytest.mark.parametrize(("step_mm", "feeds", "end"), [
    # a corner after four falling feeds (39.8 for 56.4 mm/s at the first one on main)
    (0.2, (12000, 9000, 6000, 4000, 2500), "G01 X30 Y0.3"),
    (0.3, (20000, 15000, 12000, 9000, 6000), "G01 X30 Y0.5"),
    # an M00 after six (68.7 for 75.2, then 53.5 for 68.1 mm/s)
    (0.2, (30000, 24000, 18000, 12000, 8000, 5000, 3000), "M00"),
    (0.5, (60000, 40000, 25000, 15000, 9000, 5000), "M00"),
])  # fmt: skip
def test_falling_feeds_brake_to_the_corner_or_the_stop_with_no_stop_or_overrun(
    look_ahead: int, step_mm: float, feeds: tuple[int, ...], end: str
) -> None:
    """No rest, overrun or tracker error, and no slowdown the rules do not explain: each feed
    drop is passed as one brake to the lowest of the caps after it allows (main before the
    composition: 29 % below; after it, until `Aims.through`, up to 14 % below, 82.1
    for 95.7 mm/s: zero acceleration at a feed drop whose target a later cap lowers, known
    deviation 8)."""
    ch = dataclasses.replace(shipped(), look_ahead_blocks=look_ahead)
    text = falling_feeds(step_mm, feeds, end)
    _, hard, slow, errors = check(Scenario(0, ch, text, Schedule()))
    assert (hard, slow, errors) == ([], [], 0)


FEED_DROP_BEFORE_M00 = "\n".join(
    ["G01 X100 Y300 F3000"]
    + [f"G01 X{100 + 0.5 * i:.1f} Y300 F45000" for i in range(1, 11)]
    + ["G01 X105.5 Y300 F6000", "G01 X106 Y300", "M00", "G01 X110 F6000", "M30"]
)
FEED_DROP_AT_THE_WINDOW_END = "\n".join(
    ["G01 X100 Y300 F3000"]
    + [f"G01 X{100 + 0.1 * i:.1f} Y300 F45000" for i in range(1, 11)]
    + ["G01 X101.1 Y300 F1200", "G01 X101.1878 Y300.0479", "G01 X101.2755 Y300.0959 F45000"]
    + [f"G01 X{101.2755 + 0.0878 * i:.4f} Y{300.0959 + 0.0479 * i:.4f}" for i in range(1, 20)]
    + ["M30"]
)
FEED_DROP_BEFORE_A_SHARP_CORNER = "\n".join(
    ["G01 X100 Y300 F3000"]
    + [f"G01 X{100 + i}.0 Y300 F12000" for i in range(1, 11)]
    + ["G01 X111 Y300 F6000", "G01 X111.3624 Y300.9320", "G01 X111.7247 Y301.8641 F30000"]
    + ["G01 X112.0871 Y302.7961", "M30"]
)


@pytest.mark.parametrize(("text", "look_ahead", "cycle"), [
    (FEED_DROP_BEFORE_M00, 30, 2e-3),
    (FEED_DROP_BEFORE_M00, 200, 1e-3),
    (FEED_DROP_AT_THE_WINDOW_END, 3, 1e-3),
    (FEED_DROP_BEFORE_A_SHARP_CORNER, 120, 1e-3),
])  # fmt: skip
def test_the_brake_at_once_never_rests_or_crawls_where_no_rule_says(
    text: str, look_ahead: int, cycle: float
) -> None:
    """A cold review of `Brakes.brake_through` as first merged: braking at once toward rest
    (an M00 1 mm after a feed drop, or the window end's rest at look-ahead 3) planned a
    cruise at 0 that nothing re-planned, and the path stood still for good; toward a corner
    of 0.43 mm/s 4.8 mm early, it crawled there (the program 12 % longer). Each ends, with no
    rest, overrun or tracker error, in the time of one brake to each cap (within 1 % of the
    lower bound of tests/support/reference_bound.py)."""
    ch = dataclasses.replace(shipped(), look_ahead_blocks=look_ahead, cycle_time=cycle)
    _, hard, _, errors = check(Scenario(0, ch, text + "\n", Schedule()))
    assert (hard, errors) == ([], 0)
    if "M00" not in text:
        task = GeoTask(ch, text + "\n")
        t_core, _ = core_time(task, 1.0)
        bound = lower_bound_time(task.prog.path, task.prog.table, look_ahead, 1.0)
        assert t_core <= 1.01 * bound


@pytest.mark.parametrize("seed", [125, 185, 604, 17, 213, 456, 709, 976])
def test_a_feed_drop_a_later_cap_lowers_is_passed_in_one_brake(seed: int) -> None:
    """Feeds seeds whose start-up over short blocks brakes for a feed drop just before a
    corner: the tracker planned zero acceleration at the drop, below its cap, and braked
    again after it (seed 125: 0.2 mm blocks at F60000, an F3000 block before a corner, the
    boundary before it at 34.6 where one brake allows 38.7 mm/s). `Aims.through`
    plans the one brake; where that passes the drop above its cap, the drop at its cap still
    braking (`Aims._brake_state`; seed 17: 1 mm blocks at F30000, F6000 1 mm before a
    corner of 0.41 mm/s, 100.8 for 109.1 mm/s). Seeds 709 and 976: a corner whose chain
    reaches the window's end, its own cap binding."""
    _, hard, slow, errors = check(feed_scenario(seed))
    assert (hard, slow, errors) == ([], [], 0)


@pytest.mark.parametrize("seed", [39, 577, 940, 950, 86, 921, 394, 713, 956, 48])
def test_the_aim_through_a_feed_drop_keeps_what_its_goal_cannot(seed: int) -> None:
    """Programs that versions of `Aims.through` without one of its guards broke (each
    clean on main before it): an aim at the window end's rest, whose end rose to a corner of
    1.62 mm/s reachable then only at rest (seed 577: 0.0035 mm/s; seed 39: a tracker error);
    a profile from inside the brake to the drop's own cap, zero acceleration there, that rose
    after it (seed 940: 92.4692 in a block of 92.4667 mm/s); an aim whose goal a rest 0.4 mm
    after it, beyond the list, lowered (seed 950: 22.8 for 24.8 mm/s after it); a profile
    that rose above a cap before the drop in its block (seed 86: 171.30 for 171.25); caps
    before the goal or between the drop and the goal that the steps read with zero
    acceleration there, forced re-plans in turns and the shift past them (seeds 921 and 394:
    76.1 for 74.4 and 71.40 for 71.32 mm/s); an aim from a forced re-plan that the next
    re-plan did not see (seed 713: a target of 7.0 mm/s in the jerk gap); the check's
    bound on a crossing braking at its cap (seed 956); a step's check that read every feed
    drop by the brake a later cap needs, not only those between a brake state and its aim
    (seed 48: a profile toward a later goal passed a drop at 100.01 for 100 mm/s); and the
    brake at once at a brake state's goal (seed 394: without it the shift's dip held a
    drop at 20.7 for 23.5 mm/s)."""
    _, hard, slow, errors = check(feed_scenario(seed))
    assert (hard, slow, errors) == ([], [], 0)


@pytest.mark.parametrize(("look_ahead", "feeds", "step_mm", "override", "corner"), [
    # boundary 5 at 103.3 for 109.8 mm/s on 85369f6
    (30, FALL_C, 0.5, (), ""),
    # override 100 → 150 % in the brake: boundary 8 at 79.0 for 89.6
    (30, FALL_A, 0.5, ((6.40, 1.5),), ""),
    # 100 → 50 → 120 %, a corner after: boundary 5 at 141.3 for 150.3
    (30, FALL_B, 1.0, ((6.38, 0.5), (6.40, 1.2)), "G01 Y300.3"),
    # boundaries 6 and 7 at 115.3 and 101.5 for 124.2 and 115.2
    (120, FALL_C, 0.5, ((6.40, 1.5),), "G01 Y300.3"),
])  # fmt: skip
def test_drops_between_a_brake_state_and_its_aim_are_passed_in_the_one_brake(
    look_ahead: int, feeds: tuple[int, ...], step_mm: float,
    override: tuple[tuple[float, float], ...], corner: str,
) -> None:  # fmt: skip
    """Feed drops on short blocks falling into a corner or the program end, under override
    steps: the brake state toward the later cap passes the drops between it and that cap
    braking (`Aims._brake_state` anchored where `aims.free_brake`, the steps reading those drops
    as the brake's). On 85369f6 it was refused where a drop lay between, and the drop's own
    target, lowered for the ones after it with zero acceleration at each, held the path
    below the one brake (26 of 72 such programs with a slowdown, 2 now: FALL_B on 0.5 mm
    blocks at 100 %, boundary 7 at 79.0 for 84.1 mm/s, open)."""
    ch = dataclasses.replace(shipped(), look_ahead_blocks=look_ahead)
    text = falling_to_the_end(feeds, step_mm, corner)
    _, hard, slow, errors = check(Scenario(0, ch, text, Schedule(override, ())))
    assert (hard, slow, errors) == ([], [], 0)


@pytest.mark.parametrize("seed", [441, 726, 50])
def test_feeds_runs_with_drops_between_the_brake_state_and_its_aim(seed: int) -> None:
    """Feeds seeds with a drop between the brake state and the cap that lowers it, each a
    slowdown on 85369f6: seed 441 (override 20 → 120 %, 1 mm blocks falling to the program
    end: boundary 38 at 89.4 for 97.7 mm/s: the brake state refused with a drop between),
    726 (boundary 30 at 80.0 for 91.2: anchored at the first drop, the brake state left the
    next one only to the brake at once, which ruckig does not reach at its cap, and the
    shift's dip went down to 61.3 mm/s; anchored at the drop that binds, `aims.free_brake`). Seed
    50 guards the state's re-plan as the window moves on: ruckig refused the state it had
    planned 3 ms before, and the fallback passed the drop at 152.9 for 152.0 mm/s (an
    overrun on this round's tree before `Aims._brake_state` kept the profile in hand).
    Seed 940 (boundary 16 at 38.8 for 43.6) is among the aim's guards above."""
    _, hard, slow, errors = check(feed_scenario(seed))
    assert (hard, slow, errors) == ([], [], 0)


FALLING_BEFORE_A_KINK = "\n".join(
    ["G01 X110 Y300 F3000", "G01 X113 Y300 F36000"]
    + [f"G01 X{113 + 0.1 * i:.1f} Y300 F{f}" for i, f in enumerate((30000, 15000, 9000), 1)]
    + [f"G01 X{113.3 + 0.1 * i:.1f} Y300 F{f}" for i, f in enumerate((4800, 2400, 1000), 1)]
    + ["G01 X114.5553 Y300.2955 F1800", "M30"]
)


@pytest.mark.parametrize("look_ahead", [8, 12, 30])
@pytest.mark.parametrize("cycle", [5e-4, 1e-3])
def test_drops_between_the_brake_state_and_its_goal_are_kept(look_ahead: int, cycle: float) -> None:
    """A cold review's program (0.1 mm blocks falling from F36000 to F1000 before a kink): a
    brake state at one drop with more drops before its goal left the next one out of reach
    as the steps read it; forced re-plans took turns between the two, and the shift passed
    two drops above their caps (40.29 for 40.00 and 24.93 for 16.67 mm/s). Clean on main."""
    ch = dataclasses.replace(shipped(), look_ahead_blocks=look_ahead, cycle_time=cycle)
    _, hard, slow, errors = check(Scenario(0, ch, FALLING_BEFORE_A_KINK, Schedule()))
    assert (hard, errors) == ([], 0)
    assert slow == []


def test_a_drop_whose_brake_state_ruckig_refuses_is_passed_just_below_its_cap() -> None:
    """Feeds seed 101: from a run boundary at 51.3 mm/s, 0.6 mm before an F1200 drop (36 mm/s
    at 180 %) 0.2 mm before a corner of 0.51 mm/s. The aim's profile toward the corner sped
    up first and passed the drop above its cap, and ruckig refused the brake state (the drop
    at 36 mm/s braking: every deceleration that keeps the corner, in its first step); the
    shift's brake at once took over and passed the drop at 14.3 mm/s, where one brake passes
    it at 36. The brake state now tries a little below the cap (`aims.BELOW`): 35.6 mm/s,
    still braking. Fails on 8dcd176."""
    _, hard, slow, errors = check(feed_scenario(101))
    assert (hard, slow, errors) == ([], [], 0)


def test_a_feed_drop_whose_own_cap_is_in_the_jerk_gap_is_passed_at_it_braking() -> None:
    """Feeds seed 249: override 30 → 200 % as the path brakes at 292.9 mm/s and −5.0 m/s²,
    6.2 mm before an F3000 drop (100 mm/s) 2 mm before a corner of 0.14 mm/s. Zero
    acceleration at the drop was out of reach at its cap, and the tracker took x1 = 50.0
    mm/s there; it now passes the drop at 100 still braking (`Aims.gap_state`)."""
    _, hard, slow, errors = check(feed_scenario(249))
    assert (hard, slow, errors) == ([], [], 0)


def fast_into_a_drop(drop: int) -> str:
    """0.5 mm blocks: ten at F60000, three at F24000, two at `drop`, two at F7200, a corner."""
    feeds = [60000] * 10 + [24000] * 3 + [drop] * 2 + [7200] * 2
    lines = ["G01 X100 Y300 F3000"]
    lines += [f"G01 X{100 + 0.5 * i:.1f} F{f}" for i, f in enumerate(feeds, 1)]
    return "\n".join([*lines, f"G01 X{100 + 0.5 * len(feeds):.1f} Y301", "M30"]) + "\n"


@pytest.mark.parametrize("look_ahead", [8, 10, 12])
def test_a_brake_state_whose_later_cap_the_window_raised_is_kept(look_ahead: int) -> None:
    """An F3000 drop (50 mm/s) after 0.5 mm blocks at F60000 and F24000: as the window's end
    moves past the drop the path plans a brake state there (50 mm/s, −0.54 m/s², toward the
    window's end one block on), and the next move raises that end's value, so zero
    acceleration at the drop would keep it now, but from the path's state zero acceleration
    there at 50 is in the jerk gap. The re-plan took x1: boundary 14 at 26.9 mm/s for 50 at
    look-ahead 10 (24.2 for 43.6 at 8, 27.5 for 50 at 12), fails on 325bd6e. The profile in
    hand reaches the drop at its cap and is kept (`Shift.toward`)."""
    ch = dataclasses.replace(shipped(), look_ahead_blocks=look_ahead, cycle_time=1e-3)
    _, hard, slow, errors = check(Scenario(0, ch, fast_into_a_drop(3000), Schedule()))
    assert (hard, slow, errors) == ([], [], 0)


@pytest.mark.parametrize("override", [0.8, 0.6])
def test_the_brake_at_once_for_a_lost_cap_goes_on_as_the_window_moves(override: float) -> None:
    """The same shape with an F4800 drop and override 100 % → 80 or 60 % 36 ms before it
    (look-ahead 10): its cap out of reach with zero acceleration there (x1 21.1 mm/s for 64),
    the path brakes at once (`Brakes.lost_cap`), but the re-plan as the window moved on, no
    event any more, took x1: boundary 14 at 21.1 mm/s for 64 (48 at 60 %), boundary 13 at
    62.3 for 69.5; fails on 325bd6e (so did the review corpus' gen3 seed 286: 25.4 for 64).
    A re-plan inside that brake keeps braking at once (`shift._brakes_for`)."""
    ch = dataclasses.replace(shipped(), look_ahead_blocks=10, cycle_time=1e-3)
    sched = Schedule(((6.39, override),), ())
    _, hard, slow, errors = check(Scenario(0, ch, fast_into_a_drop(4800), sched))
    assert (hard, slow, errors) == ([], [], 0)


@pytest.mark.parametrize(
    ("drop", "override", "look_ahead", "at", "before"),
    [(3000, 0.8, 10, 6.39, 26.85), (3000, 0.6, 8, 6.40, 24.24), (4800, 0.4, 30, 6.38, 23.09),
     (4800, 0.4, 10, 6.39, 21.06), (6000, 0.6, 10, 6.39, 56.23), (6000, 0.4, 10, 6.385, 28.32)],
)  # fmt: skip
def test_a_feed_cap_an_override_drop_put_out_of_reach_is_passed_braking(
    drop: int, override: float, look_ahead: int, at: float, before: float
) -> None:
    """`fast_into_a_drop` with the override dropped in the brake toward the drop: its new
    cap (40 mm/s for F3000 at 80 %) out of reach with zero acceleration there, x1 below it at
    more than half of it (`GAP_FLOOR`), and the path took x1, braking harder than the brake
    at once: 26.85 mm/s for 40 (F4800 at 40 %: 21.06 for 32; 53 of 1 116 such runs had a
    slowdown). Where the brake at once passes the boundary nearer the cap by ratio than x1
    (`Shift.toward`: v_b / cap < cap / x1, as for a run boundary's x2), it is taken, as the
    CNC brakes after an override drop (known deviation 15), within the check's rule for a
    cap out of reach after an input change. So does a re-plan inside that brake as the
    window moves on (F6000 at 60 %: the next re-plan passed the cap below it braking
    through, `Brakes.dip_through`, at 59.997 mm/s and −2.2 m/s², ramped out to 53.8 and
    passed the next boundary at 56.23 for 60), and so does the shift's profile past such a
    cap at the event (F6000 at 40 % 5 ms earlier: a dip to 28.32 between 40 and 38.3)."""
    ch = dataclasses.replace(shipped(), look_ahead_blocks=look_ahead, cycle_time=1e-3)
    sched = Schedule(((at, override),), ())
    _, hard, slow, errors = check(Scenario(0, ch, fast_into_a_drop(drop), sched))
    assert (hard, slow, errors) == ([], [], 0), f"was {before} mm/s"


def _review_program(moves: list[tuple[float, float, int]]) -> str:
    """A cold review's program: 20 mm at F3000, then the moves (x, y, F)."""
    lines = ["G01 X0 Y0 F3000", "G01 X20 Y0"] + [f"G01 X{x} Y{y} F{f}" for x, y, f in moves]
    return "\n".join([*lines, "M30"]) + "\n"


REVIEW_932 = _review_program([
    (20.05, 0, 24000), (20.1, 0, 1200), (20.15, 0, 2400), (20.65, 0, 2400), (20.85, 0, 4800),
    (20.95, 0.00017, 2400), (21.14987, 0.0075, 4800), (21.19983, 0.00942, 9000),
    (21.69946, 0.02862, 24000), (21.89931, 0.03629, 4800), (22.19909, 0.04781, 1200),
    (22.24905, 0.04982, 6000), (22.54821, 0.07231, 60000), (22.59807, 0.07606, 2400),
    (23.09666, 0.11355, 2400), (23.2961, 0.12854, 9000), (23.2961, 2.12854, 3000),
])  # fmt: skip
REVIEW_391 = _review_program([
    (20.1, 0, 4800), (20.2, 0, 60000), (20.5, 0, 1200), (20.6, 0.00017, 24000),
    (20.65, 0.00026, 4800), (20.95, 0.00079, 24000), (21.15, 0.00113, 6000),
    (21.45, 0.00218, 60000), (21.94999, 0.00393, 2400), (22.14985, 0.0116, 24000),
    (22.3497, 0.01928, 60000), (22.64948, 0.0308, 3000), (23.14911, 0.04999, 60000),
    (23.44889, 0.06151, 60000), (23.74808, 0.08348, 2400), (23.74808, 2.08348, 3000),
])  # fmt: skip


@pytest.mark.parametrize(
    ("text", "look_ahead", "cycle", "at", "override"),
    [(REVIEW_932, 30, 2e-3, 0.4083174872110241, 0.8),
     (REVIEW_391, 8, 1e-3, 0.4138630528595175, 0.4)],
)  # fmt: skip
def test_the_brake_at_once_for_a_lost_cap_is_kept_to_its_end(
    text: str, look_ahead: int, cycle: float, at: float, override: float
) -> None:
    """A cold review's programs for the rule above: the event's brake at once toward a lost
    cap was re-planned in its last phase (crossing a boundary, or the window moving on),
    where v_p is the cap, so no brake at once was asked for any more: toward the cap itself
    ruckig refused (a tracker error, 11.78 mm/s for 16.0 and a dip to 3.56), or x1 from
    there (7.11 for 8.0, below the event's own x1). Inside that brake, no input changed, it
    goes on (`Shift.toward`)."""
    ch = dataclasses.replace(shipped(), look_ahead_blocks=look_ahead, cycle_time=cycle)
    _, hard, slow, errors = check(Scenario(0, ch, text, Schedule(((at, override),), ())))
    assert (hard, slow, errors) == ([], [], 0)
