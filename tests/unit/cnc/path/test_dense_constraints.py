"""Issue 36, known deviation 1 of docs/geo-core.md: more constraints within the brake than the
tracker considers at once. The 24th counted as a stop, so 0.2 mm blocks with a feed drop at
every second one ran at 314 mm/s where the feed allows 500. A feed drop whose cap is at least
that of one before it cannot bind, and is no longer counted (`Constraints.collect`); after an
override drop, where the path passes feed caps above them, the tracker reads the list that
begins after each one it passes. The chain of run boundaries behind the first one is followed
farther where its 24th link lowers the cap (`Constraints._beyond`). Each run goes through the
per-cycle check (tests/support/motion_check.py) and the cycle checker (limits, tracker
errors)."""

from __future__ import annotations

import dataclasses
import random
import re

import pytest

from liftd.cnc.geo_task import GeoTask
from liftd.cnc.path.constraints import MAX_CANDIDATES
from liftd.cnc.path.table import build_table
from liftd.cnc.path.tracker import Tracker
from liftd.cnc.path.velocity import brake_reach
from liftd.cnc.plc import Schedule, parse_override_spec
from tests.support.cam_cases import cam_scenario
from tests.support.cam_runs import apart, check, core_time
from tests.support.channel import shipped
from tests.support.reference_bound import lower_bound_time
from tests.support.scenarios import Scenario, describe
from tests.unit.cnc.path.test_no_invented_stops import lowest_between, run


def program(blocks: int, step_mm: float, feeds: tuple[int, ...], m00_after: int = -1,
            corners: tuple[int, ...] = (), arcs: tuple[int, ...] = ()) -> str:  # fmt: skip
    """Collinear blocks of `step_mm` through `feeds` in turn (a Y block at each of `corners`,
    a tangent S-curve of two quarter circles of 5 blocks' radius at each of `arcs`), an M00
    after block `m00_after`."""
    lines = ["G01 X0 Y0 F600"]
    x = y = 0.0
    for i in range(blocks):
        if i in arcs:
            r = 5.0 * step_mm
            lines.append(f"G03 X{x + r:.4f} Y{y + r:.4f} I0 J{r:.4f}")
            lines.append(f"G02 X{x + 2 * r:.4f} Y{y + 2 * r:.4f} I{r:.4f} J0")
            x, y = x + 2 * r, y + 2 * r
        if i in corners:
            y += step_mm
            lines.append(f"G01 Y{y:.4f} F{feeds[i % len(feeds)]}")
        else:
            x += step_mm
            lines.append(f"G01 X{x:.4f} F{feeds[i % len(feeds)]}")
        if i == m00_after:
            lines.append("M00")
    return "\n".join([*lines, "M30"]) + "\n"


@pytest.mark.parametrize(
    ("look_ahead", "step_mm", "feeds"),
    # (look-ahead 60, 0.2 mm at F30000/F60000: boundary 54 at 324.6 for 343.2 mm/s while the
    # window's end rises ahead of the accelerating path, since the check of the fifth round's
    # part C; docs/geo-core.md known deviation 1, what remains)
    [(200, 0.2, (30000, 60000)), (120, 0.1, (60000, 45000, 36000, 24000))],
)  # fmt: skip
def test_dense_feed_drops_slow_the_path_only_where_a_rule_says_so(
    look_ahead: int, step_mm: float, feeds: tuple[int, ...]
) -> None:
    """400 blocks: each cycle explained by a rule (the path braked to 142 for 153 mm/s with
    look-ahead 200, where the 24th constraint was a stop)."""
    ch = dataclasses.replace(shipped(), look_ahead_blocks=look_ahead)
    assert run(program(400, step_mm, feeds), ch).check() == []


def test_dense_feed_drops_run_at_the_lowest_feed() -> None:
    """With look-ahead 200 (40 mm) the window's end does not bind: in the middle third the path
    runs at F30000, 500 mm/s (it ran at 314)."""
    ch = dataclasses.replace(shipped(), look_ahead_blocks=200)
    rec = run(program(400, 0.2, (30000, 60000)), ch)
    assert lowest_between(rec, 80.0 / 3, 160.0 / 3) >= 500.0 * 0.999


@pytest.mark.parametrize(("text", "cycle"), [
    # four feeds on 0.1 mm blocks under 150 → 40 → 200 %: at 360 mm/s after the drop, the
    # next cap 0.05 µm ahead, nearer than any target could be (390 tracker errors with the
    # lists' left-out caps in the shift, 0 on main before)
    (program(500, 0.1, (60000, 45000, 36000, 24000)), 1e-3),
    (program(500, 0.1, (60000, 45000, 36000, 24000)), 2e-3),
    # an M00 0.8 mm behind the goal the shift chose by its own feed cap: the stop was passed
    # at 188 mm/s
    (program(500, 0.2, (36000, 60000), m00_after=207, corners=(495, 244)), 1e-3),
])  # fmt: skip
def test_an_override_drop_on_dense_feed_drops_keeps_every_stop_and_limit(
    text: str, cycle: float
) -> None:
    """The 0.1 mm programs held ~360 mm/s for 22 ms after the drop to 40 % (ceilings 160–400
    mm/s) before they braked, and passed 60 boundaries above feed caps they could have got
    down to (known deviation 10 of docs/geo-core.md). They now brake at once
    (`Brakes.brake_first`, `brake_into`); what remains is the end of that brake: in the
    blocks of 400 mm/s between those of 160 the path is below its ceiling and the re-plans
    there ease the brake, so up to four boundaries whose 160 mm/s cap the brake from the drop
    reaches with 0.2 mm to spare are passed up to 1.8 % above it."""
    ch = dataclasses.replace(shipped(), look_ahead_blocks=120, cycle_time=cycle)
    sched = Schedule(tuple(parse_override_spec("0.05:150,0.12:40,0.2:200")), ())
    _, hard, slow, errors = check(Scenario(0, ch, text, sched))
    over, other = apart(hard)
    assert errors == 0 and other == [], hard
    assert len(over) <= 4, over
    for o in over:
        m = re.search(r"^overrun: boundary \d+ .* at ([0-9.]+) mm/s above its cap ([0-9.]+) "
                      r"\(t=([0-9.]+) s\)$", o)  # fmt: skip
        assert m is not None, o
        assert float(m.group(1)) <= float(m.group(2)) * 1.02 and 0.12 <= float(m.group(3)) < 0.2
    assert slow == []


@pytest.mark.parametrize("seed", [0, 30, 38, 162])
def test_a_polyline_s_rounding_kinks_beyond_the_24th_are_not_a_stop(seed: int) -> None:
    """CAM seeds whose polylines of 0.2 mm blocks have a rounding kink (a run boundary, known
    deviation 0) at every block: braking to rest through them takes ~17 mm from 100 mm/s, so
    a stop at the 24th (4.8 mm on) held the path below its caps (seed 162: 61.9 for 103.7
    mm/s at boundary 3; seed 0: 85.1 for 91.9)."""
    sc = cam_scenario(seed)
    _, hard, slow, errors = check(sc)
    assert hard == [] and errors == 0, (hard, describe(sc))
    assert slow == [], (slow, describe(sc))


def _dominated(every: list[tuple[int, float, float, bool]], keep: int) -> list[int]:
    """The boundaries `collect` keeps of a list with none left out: a candidate without zero
    acceleration only where its cap is below every one kept before it (or it is `keep`),
    the 24th counting as a stop."""
    kept: list[int] = []
    low = float("inf")
    for b, _, cap, gate in every:
        if not gate:
            if cap >= low and b != keep:
                continue
            low = min(low, cap)
        kept.append(b)
        if gate or len(kept) == MAX_CANDIDATES:
            break
    return kept


def test_the_leaps_over_caps_that_cannot_bind_find_every_one_that_can() -> None:
    """`collect` leaps along the chains of lower feeds and lower hard caps (`PathTable`); it
    keeps the same constraints as a scan of all of them would, with lift stops, a forced one
    and overrides in play."""
    rng = random.Random(361)
    compared = 0
    for _ in range(6):
        feeds = tuple(
            rng.choice((60000, 45000, 36000, 24000, 30000, 12000, 6000)) for _ in range(7)
        )
        corners = tuple(rng.sample(range(300), 4))
        arcs = tuple(rng.sample(range(300), 6))
        path = GeoTask(shipped(), program(300, rng.choice((0.1, 0.3)), feeds, 150, corners, arcs))
        # hard caps that fall inside a run too (an Advanced lift range's cap on some blocks)
        segs = tuple(
            sg.limited(sg.v_lift_ov, sg.a_max, sg.j_max, rng.choice((0.05, 0.1, 0.2, 0.4)))
            if rng.random() < 0.3 else sg
            for sg in path.prog.path.segments
        )  # fmt: skip
        tb = build_table(dataclasses.replace(path.prog.path, segments=segs))
        assert any(
            tb.constraint[b] and not tb.gate[b] and tb.cap[b] < tb.cap[b - 1]
            for b in range(1, tb.n)
        )
        for ov in (0.3, 1.0, 1.7):
            tr = Tracker(tb, rng.choice((30, 120, 200)), lift_stops={rng.randrange(1, 300)})
            tr.set_inputs(ov, False)
            for _ in range(20):
                seg = rng.randrange(0, tb.n - 1)
                tr.set_state(0.0, tb.s[seg], 0.3, 0.0, seg, None)
                every = tr.con.collect(tb.s[seg], seg, 1.0, every=True)
                # a forced re-plan's constraint is one of them
                keep = rng.choice([-1, *(c[0] for c in every if not c[3])])
                got = [c[0] for c in tr.con.collect(tb.s[seg], seg, 1.0, keep=keep)]
                want = _dominated(every, keep)
                assert got[: len(want)] == want, (seg, keep, ov)
                compared += 1
    assert compared == 360


def poisoned() -> str:
    """A cold review's program: 23 falling feed drops on 0.1 mm blocks after a 100 mm lead-in,
    a shallow kink (a run boundary), an F60 block 0.05 mm on."""
    lines = ["G01 X0 Y0 F600", "G01 X100 F30000"]
    x = 100.0
    for i in range(23):
        x += 0.1
        lines.append(f"G01 X{x:.4f} F{29000 - 1000 * i}")
    lines += [f"G01 X{x + 0.05:.4f} Y0.0010 F6000", f"G01 X{x + 0.10:.4f} Y0.0020 F60",
              f"G01 X{x + 0.50:.4f} Y0.0100 F60", "M30"]  # fmt: skip
    return "\n".join(lines) + "\n"


def test_a_run_boundary_counted_as_the_24th_does_not_hide_the_feed_drops_behind_it() -> None:
    """`poisoned()`: as the 24th candidate the kink counts as a stop, and its chain asked for
    cap 0 (every feed drop behind it below that cap left out) was cached under the kink alone
    and read back for its entry cap: the F60 block ran at 19.3 mm/s for 1."""
    ch = dataclasses.replace(shipped(), look_ahead_blocks=200)
    rec = run(poisoned(), ch)
    s0, s1 = rec.program.boundaries[25].s, rec.program.boundaries[27].s
    inside = [x.v for x in rec.samples if s0 + 1e-9 < x.s < s1]
    assert inside and max(inside) <= 1e-3 * 1.0001  # F60: 1 mm/s


def falling(step_mm: float, f0: int, ratio: float, blocks: int) -> str:
    """A 100-block-long line at F`f0`, then `blocks` blocks of `step_mm` whose feed falls by
    `ratio` each (never below F60), then a corner."""
    x = 100 * step_mm
    lines = ["G01 X0 Y0 F600", f"G01 X{x:.4f} F{f0}"]
    f = float(f0)
    for _ in range(blocks):
        f *= ratio
        x += step_mm
        lines.append(f"G01 X{x:.4f} F{max(int(f), 60)}")
    return "\n".join([*lines, "G01 X40 Y1", "M30"]) + "\n"


@pytest.mark.parametrize(("step_mm", "f0", "ratio", "blocks", "over"), [
    (0.2, 30000, 0.97, 40, 1.06),  # 1.22 with the 24th a stop
    (0.2, 60000, 0.96, 60, 1.12),  # 1.28
])  # fmt: skip
def test_a_feed_falling_block_by_block_brakes_through_more_caps_than_a_step_plans(
    step_mm: float, f0: int, ratio: float, blocks: int, over: float
) -> None:
    """More than MAX_CANDIDATES falling feeds within one brake: the last candidate stands for
    those after it with zero acceleration there (`Constraints.collect`), not as a stop. The
    program time against the lower bound of tests/support/reference_bound.py (no motion within
    the rules is faster): 22 and 28 % above it with the stop, 5.0 and 10.9 % now (9.1 % on the
    second with no limit on candidates: the remainder is the target choice, known deviation 8
    of docs/geo-core.md); each cycle through the checks, no tracker error."""
    assert blocks > MAX_CANDIDATES
    ch = dataclasses.replace(shipped(), look_ahead_blocks=200)
    text = falling(step_mm, f0, ratio, blocks)
    task = GeoTask(ch, text)
    t_core, errors = core_time(task, 1.0)
    bound = lower_bound_time(task.prog.path, task.prog.table, 200, 1.0)
    assert errors == 0
    assert bound <= t_core <= over * bound
    _, hard, _, _ = check(Scenario(0, ch, text, Schedule()))
    assert hard == []


def test_the_candidate_that_stands_for_the_rest_passes_no_feed_cap_above() -> None:
    """The 24th of more falling caps within one brake is listed with zero acceleration there,
    as a run boundary is (`Constraints.collect`), but it is a feed drop: the jerk gap's rule
    that lets a run boundary's own cap be passed above after an override drop
    (`Targets.gap_over`) does not apply to it (a feed cap passed above is an overrun)."""
    task = GeoTask(shipped(), falling(0.2, 60000, 0.96, 60))
    tb = task.prog.table
    tr = Tracker(tb, 200)
    tr.con.ov = 0.4
    k = max(range(tb.n), key=lambda i: tb.s[i + 1] - tb.s[i])  # the 20 mm line
    v = tb.ceiling(k, 1.0)  # its feed before the drop to 40 %
    cands = tr.con.collect(tb.s[k + 1] - 1e-3, k, brake_reach(v, 0.0, 10.0, 500.0) + 0.05)
    assert len(cands) == MAX_CANDIDATES
    last, s_last, cap, gate = cands[-1]
    assert gate and not tb.gate[last]  # listed as a run boundary, a feed drop in the table
    assert tr.tg.gap_over(cands, len(cands) - 1, cap, tr.window_end) == 0.0
    run_end = next(b for b in range(last, tb.n) if tb.gate[b])
    real = [(run_end, tb.s[run_end], tb.entry_cap(run_end, 0.4), True)]
    assert (
        tr.tg.gap_over(real, 0, real[0][2], tr.window_end) > 0.0
    )  # a run boundary's: its hard cap
