"""Which target the path tracker plans for (`tracker.py`), and the fallbacks where ruckig
refuses it: `Targets`, a part of the tracker (`Tracker.tg`) that holds the constraint queries
(`constraints.py`) and the path's state (`plan.PathState`), which `Tracker` moves.

A constraint's cap is a target, not only a bound (issue 36): the path reaches the lower of the
two blocks' ceilings and the transition cap at a block boundary, and does not dip below the
lower of the targets it moves between. (Ruckig's time-optimal profile to a low target velocity
brakes below it and comes back when the exact brake no longer fits: the constraints are kept
by that exact brake, `Constraints.need`, and a brake in hand is not re-planned where only a
ceiling rises, `Tracker._arrive`.)
Where a cap cannot be reached exactly (a cap that came into view with the look-ahead window,
an override drop), the path gets as near to it as it can below it, and above it only where it
cannot get below it any more (`nearest_reachable`); it rests at a boundary that is not a stop
only when nothing else is accepted.
"""

from __future__ import annotations

from collections.abc import Callable

from liftd.cnc.path.constraints import (
    CAP_TOL,
    CHAIN_MARGIN,
    INF,
    SLACK_TOL,
    V_ROUND,
    Constraints,
)
from liftd.cnc.path.plan import CRUISE, SETTLE, PathState, Plan
from liftd.cnc.path.profiles import Profiles
from liftd.cnc.path.velocity import (
    brake_distance,
    lowest_reachable_from,
    nearest_reachable,
    ramp_distance,
    reach_from,
    reach_velocity,
)
from liftd.cnc.ruckig1 import (
    ProfileError,
)

HOLD_TOP_GAIN = 1e-6  # s: `Targets._hold_top` takes the other profile where it is this shorter


def highest(good: float, bad: float, steps: int, fits: Callable[[float], bool]) -> float:
    """The highest value from `good` (one that fits) toward `bad` (one that does not) for
    which `fits` holds, within 2^-steps of the interval between them: bisection. `fits` is
    last called true for the value returned, where the search moved from `good` at all."""
    for _ in range(steps):
        mid = 0.5 * (good + bad)
        if fits(mid):
            good = mid
        else:
            bad = mid
    return good


class Targets:
    """The target choice and the profiles toward it, for the path state `st` under the
    constraints `con`; `Tracker` holds it and moves the path along them."""

    def __init__(self, con: Constraints, st: PathState) -> None:
        self.con = con
        self.st = st
        self.pf = Profiles(con, st)  # the profiles, and their repairs where they dip

    def gap_over(
        self, cands: list[tuple[int, float, float, bool]], i: int, top: float, w: int
    ) -> float:
        """How far above its cap candidate i (a run boundary) may be passed where its cap falls
        in the jerk gap (`Targets.pick_target`): where the cap is its own (not lowered for a
        later one), within its hard cap and what the later candidates allow; else 0."""
        if cands[i][2] > top * (1.0 + CAP_TOL):
            return 0.0
        b, s_c = cands[i][0], cands[i][1]
        if not self.con.tb.gate[b]:
            return 0.0  # a feed drop that stands for the ones after it (`collect`): no gap rule
        over = self.hard(b, w)
        if i + 1 < len(cands):
            nb, ns = cands[i + 1][0], cands[i + 1][1]
            la, lj = self.con.limits(nb - 1)
            later = reach_velocity(
                self.con.target_cap(cands, i + 1), max(ns - s_c - CHAIN_MARGIN, 0.0), la, lj
            )
            over = min(over, later)
        return over

    def gap_rule(self, b: int, cap: float) -> bool:
        """The jerk gap's rule (`Targets.gap_over`: a run boundary's feed cap in the jerk gap
        passed at x2 above it) is the rule of the brake after an input change, for a cap the
        path could no longer get down to from its state at the change or at the last run
        boundary it passed since (`PathState.changed`, set by `Tracker._replan` and
        `_arrive`; tests/support/motion_overrun.py); `cap` is b's own. Not
        before any input changed, nor for a cap within reach from that state: the window's
        move raised a run boundary's cap from 9.2 mm/s (its end 0.05 mm after it, look-ahead
        3) to 16, 50 ms after an override drop, and x2, 17.23, passed that F1200 block above
        its ceiling (drops seed 993); an override drop 0.55 mm before a cap of 8 mm/s, within
        reach, the forced re-plans aimed at rest at the window's end, and once the window
        moved on the shift took x2 at 32.2 (a cold review's `drop_scenario(411)` with its drop
        20 ms earlier). Under a hold: the hold's brake (`pick_target`)."""
        if self.con.hold:
            return True
        changed = self.st.changed
        if changed is None:
            return False
        s_e, v_e, a_e = changed
        a_max, j_max = self.con.limits(b - 1)
        return brake_distance(v_e, a_e, cap, a_max, j_max) > self.con.tb.s[b] - s_e + SLACK_TOL

    def keep_floor(
        self, floor: tuple[int, float, float, bool], v_max: float, a_max: float, j_max: float,
        w: int,
    ) -> None:  # fmt: skip
        """The plan just made aims at rest at the window's end w; `floor` is w's second
        candidate (`Constraints.window_floor`). Where that plan can no longer get down to the
        floor with zero acceleration at w once the window moves on (the path at the boundary
        after which w is no longer its end), and the profile to the floor keeps rest at w
        reachable up to there, the profile to the floor is taken. The time-optimal profile
        to rest brakes late and hard, so the floor, whose brake is shorter, can fall in its
        jerk gap: look-ahead 3, 0.5 mm blocks, F12000 at 15 %, the profile to rest went to
        58 mm/s, and the run boundary at w, its cap 30 mm/s, was passed at 36.9 once the
        window moved on (a review's program; the forced re-plans chose rest, the lower slack,
        four times a step). Where the floor lies in the jerk gap from the path's state, x1
        below it (`nearest_reachable`): look-ahead 3 at 50 mm/s, the window's end a run
        boundary 0.15 mm after the boundary where the window moves on, its floor in the gap;
        the plan to rest was kept and, the window moved on, only rest was reachable at its
        cap: 0.028 mm/s for 24.8 (`drop_scenario(723)`, before its override drop)."""
        rest = self.st.plan
        m = w - self.con.look_ahead + 1  # the window moves on where the path reaches m
        if rest is None or rest.goal != w or m <= self.con.seg or m >= w:
            return
        s_w, e = floor[1], floor[2]
        if self._keeps_at(rest, m, s_w, e):
            return
        last = self.st.last_error
        s, v, a = self.st.s, self.st.v, self.st.a
        for x1 in (False, True):
            # the floor, or where it lies in the jerk gap, x1 below it
            tgt = nearest_reachable(v, a, s_w - s, e, a_max, j_max, False) if x1 else e
            if (
                tgt > 0.0
                and self.pf.try_target(s, v, a, s_w, tgt, max(v_max, tgt), a_max, j_max, w, w)
                and self._keeps_at(self.st.plan, m, s_w, 0.0)
            ):
                return
        self.st.plan, self.st.last_error = rest, last  # (a refusal here is no error)

    def _keeps_at(self, plan: Plan | None, m: int, s_w: float, e: float) -> bool:
        """`plan` reaches boundary m with room left to get down to e at s_w with zero
        acceleration there."""
        if plan is None:
            return False
        s_m = self.con.tb.s[m]
        t_m = plan.time_at(s_m, INF)
        if t_m == INF:
            return False
        _, v_m, a_m = plan.at(t_m)
        return self.con.stays(s_m, v_m, a_m, m, s_w, e)

    def cruise(self, ceiling: float, a_max: float, j_max: float, w: int) -> None:
        """Ruckig's velocity interface from the path's state to `ceiling` (`CRUISE`); where it
        is refused, the last resort's brake (counted)."""
        try:
            traj = self.pf.calc.velocity(self.st.s, self.st.v, self.st.a, ceiling, a_max, j_max)
        except ProfileError as exc:
            self.count(f"cruise profile refused: {exc}")
            self.pf.brake(a_max, j_max, w)
            return
        self.st.plan = Plan(traj, self.st.t, CRUISE, w, None, ceiling)

    def hard(self, b: int, w: int) -> float:
        """Boundary b's own hard cap: 0 at a stop and the window's end, else its axis and
        transition cap (never scaled by the override)."""
        tb = self.con.tb
        return 0.0 if self.con.is_stop(b) or b == w else min(tb.point_cap[b], tb.cap[b])

    def count(self, what: str) -> None:
        self.st.errors += 1
        self.st.last_error = what

    def boundary_target(
        self, cands: list[tuple[int, float, float, bool]], i: int, cap: float, v: float, a: float,
        v_p: float, ceiling: float, a_max: float, j_max: float, w: int, gap: bool = True,
    ) -> float:  # fmt: skip
        """The target at candidate i (cap: its chain's, `Constraints.target_cap`) from the
        path's state (v, a; v_p after ramping a out): `pick_target`, a run boundary with the
        jerk gap's bound (`gap_over`) where `gap` (`Targets.gap_rule`),
        and x1 where the gap's x2 above the cap would lose a stop or a hard cap after it
        (`Constraints.hard_reach`; a cold review)."""
        b, s_c, _, gate = cands[i]
        d = s_c - self.st.s
        over = self.gap_over(cands, i, min(cap, ceiling), w) if gate and gap else 0.0
        hard_b = self.hard(b, w)
        if gate and ceiling < cap and v > ceiling:
            # above a ceiling an input lowered, its brake passes the run boundary above b's
            # own cap too, which the same input lowered (the ceiling of the block after it),
            # within b's axis and transition cap and, below, what lies after it: override
            # 100 → 15 % at 74 mm/s 0.96 mm before a kink of rising feeds, b's cap 12.0
            # mm/s, x2 above it and x1 2.2 mm/s, a near-stop (a review's program,
            # `test_jerk_gap.py`). Where x2 would lose what lies after it, `pick_target`
            # without `over` keeps the x2 within b's own cap, as before
            over = max(over, hard_b)
        if v > ceiling and b > self.con.seg + 1:
            # above a lowered ceiling whose block ends before b: b's target is held to the
            # lowest ceiling of the blocks from the next one to b, not to that one (an
            # override drop to 10 % at 31.1 mm/s 0.09 mm before the end of a block of 4 mm/s,
            # a run boundary of 8.87 0.2 mm after it: passed at 4.0, drops seed 3507); the
            # blocks between are read here, not only as caps of the list, which leaves out
            # one at the ceiling itself (the next block at the same feed: a target of 45.7
            # mm/s beyond it held 50 above a ceiling of 10, `drop_scenario(981)` 20 ms early)
            tb = self.con.tb
            between = min(tb.ceiling(k, self.con.ov) for k in range(self.con.seg + 1, b))
            ceiling = max(ceiling, min(cap, between))
        target = self.pick_target(v, a, v_p, d, cap, ceiling, a_max, j_max, hard_b, over)
        if (
            over > 0.0
            and target > min(cap, ceiling) * (1.0 + CAP_TOL) + V_ROUND
            and target > self.con.hard_reach(b, w)
        ):
            target = self.pick_target(v, a, v_p, d, cap, ceiling, a_max, j_max, hard_b)
        return target

    def pick_target(
        self, v: float, a: float, v_p: float, d: float, cap: float, ceiling: float,
        a_max: float, j_max: float, hard: float, over: float = 0.0,
    ) -> float:  # fmt: skip
        """The highest velocity ≤ cap the path can have, with zero acceleration, at distance d:
        after accelerating as far as d allows (`reach_from`), or the cap after a brake. Where
        the cap cannot be reached exactly: the nearest velocity that can, below it where the
        path can still get below it, else above it up to `hard` (the boundary's own axis and
        transition cap). Under a hold the lowest reachable one.

        `over` > the cap: the path may pass this cap above it up to `over` (a run boundary's own
        feed cap; `Targets.gap_over`). With a jerk limit the end velocities the path can have
        at d are [0, x1] ∪ [x2, v_p]; where a brake puts the cap between x1 and x2, as after an
        override drop (wide seed 641: 230 mm/s toward a cap of 100 at a 0.001° kink, x1 = 0.03
        mm/s, a near-stop), it takes x2, as slowly as it can above the cap, where x2 is within
        `over` and nearer the cap than x1 by ratio (x2 / cap < cap / x1). Above a lowered
        ceiling that ends before b, `over` is at least the cap itself."""
        if self.con.hold:
            return min(cap, lowest_reachable_from(v, a, d, a_max, j_max))
        top = min(cap, ceiling)  # the ceiling holds up to there
        fits = d + SLACK_TOL
        if v_p <= top:
            if ramp_distance(v, a, j_max) <= fits:
                # a path never moves backwards: a projected velocity a rounding puts below 0
                # (-1e-17 m/s) is rest (ruckig1 refuses a negative target). The velocity
                # reachable within d itself, not d + SLACK_TOL: ruckig accepts a goal 1 nm
                # beyond its reach and ends 1 nm past the boundary, the tracker snaps the path
                # back onto it, and that 1 nm step is 1 m/s³ of path jerk at a 1 ms cycle,
                # × dz/ds for a coupled Z (path-based wide seeds 76, 399, 410: Z at up to
                # 1.28 × j_max, crawling at 5 mm/s with dz/ds ≈ 39)
                return max(min(top, reach_from(v, a, d, a_max, j_max)), 0.0)
            if a < 0.0 and brake_distance(v, a, 0.0, a_max, j_max) <= d:
                # the deceleration cannot be ramped out before b (an override raise inside a
                # brake, 0.36 mm before a run boundary at 48.0 mm/s and −3.46 m/s²): zero
                # acceleration at b only after a harder brake, at x1. Toward v_p ruckig's
                # profile went down to 0.001 mm/s and came back to 9.1 (feeds seed 193)
                return nearest_reachable(v, a, d, max(v_p, 0.0), a_max, j_max, False)
            return min(top, max(v_p, 0.0))
        if brake_distance(v, a, top, a_max, j_max) <= fits:
            return top
        # below it if the path can get there (a cap that came into view with the look-ahead
        # window: braking to a low velocity can take longer than braking to rest), else, as
        # after a sudden override drop, as slowly as it can above it, but within the
        # boundary's own hard cap (`top` may be lower, for the candidates after it)
        if brake_distance(v, a, 0.0, a_max, j_max) <= fits:
            # within d itself: from x1 a rounding beyond it, ruckig's profile to b brakes
            # below x1 and comes back (feeds seed 48: 9.62 mm/s reached through 3.64)
            below = nearest_reachable(v, a, d, top, a_max, j_max, False)
            if ceiling < cap and v > ceiling:
                # above a lowered ceiling that ends before b: its brake, without a pause,
                # may pass b above that ceiling, within b's own cap (override 100 → 10 % at
                # 38.9 mm/s, 0.4 mm before a run boundary of 29.3 mm/s, the ceiling of
                # 10 mm/s ending 0.2 mm on: the path dipped to 0.75 mm/s and passed it at
                # 4.18, feeds seed 942; now 21.0, its brake at once); a run boundary's
                # `boundary_target` passes more
                over = max(over, cap)
            if over <= top:
                return below
            up = nearest_reachable(v, a, fits, top, a_max, j_max, True)
            ok = up <= over and brake_distance(v, a, up, a_max, j_max) <= fits
            # nearer by ratio, not by difference: x1 = 10.09 below a cap of 50 mm/s against
            # x2 = 90.0 above it, 0.1 mm/s apart by difference, was a near-stop after an
            # override drop, with a dip to 3.84 (feeds seed 676)
            return up if ok and up * below < top * top else below
        up = nearest_reachable(v, a, fits, top, a_max, j_max, True)
        if up <= hard or brake_distance(v, a, hard, a_max, j_max) > fits:
            return up
        return hard

    def settle(
        self, s: float, v: float, a: float, v_p: float, s_c: float, target: float, cap: float,
        v_max: float, a_max: float, j_max: float, b: int, w: int, hard: float, passed: Plan | None,
        held: Plan | None = None, event: bool = False, ceiling: float = 0.0,
    ) -> None:  # fmt: skip
        """The target profile toward boundary b, or, where ruckig refuses it (it decides at
        the edge of what is feasible), in this order: the value nearest to it toward v_p (the
        velocity after ramping the acceleration to 0) that ruckig accepts, within the
        boundary's hard cap; where rest is accepted, the highest velocity below the target
        that is (`_highest_below`); the cap, the hard cap; the profile that brought the path
        to the boundary it just passed; a brake (an error). A profile that dips below its ends
        is replaced where `_undip` or `_unpin` (at an event `_exact_brake`) finds one that does
        not."""
        if self.pf.try_target(s, v, a, s_c, target, v_max, a_max, j_max, b, w):
            if a > 0.0 and abs(v_p - v_max) <= V_ROUND and v_max <= ceiling + V_ROUND:
                self._hold_top(s, v, a, s_c, target, v_max, a_max, j_max, b, w)
            self.pf.mend(s, v, a, v_p, s_c, target, v_max, a_max, j_max, b, w, passed, held, event)
            return
        if v_p <= max(hard, target) and self.pf.try_target(
            s, v, a, s_c, v_p, max(v_max, v_p), a_max, j_max, b, w
        ):
            # from v_p toward the target while ruckig still accepts it
            self._bisect(v_p, target, s, v, a, s_c, v_max, a_max, j_max, b, w)
            return
        if target > 0.0 and self.pf.try_target(s, v, a, s_c, 0.0, v_max, a_max, j_max, b, w):
            # rest is accepted: the highest velocity below the target that is too (an exact
            # brake with no room left, refused at the edge: CAM seed 482, an override drop to
            # 18 % as the path began its brake to a 12.2 mm/s corner, passed it at rest)
            self._highest_below(s, v, a, s_c, target, v_max, a_max, j_max, b, w)
            return
        for tgt in (cap, hard):
            if self.pf.try_target(s, v, a, s_c, tgt, max(v_max, tgt), a_max, j_max, b, w):
                return
        kept = passed
        if kept is not None and kept.goal == b and kept.t0 <= self.st.t:
            # the step was cut at a boundary on the way to b (a feed change) and nothing new
            # from there is accepted, e.g. 1 µm before b while still ramping the acceleration
            # to 0 (stress seed 396, lifting): the profile that brought the path here keeps b
            # (a window that moved on only relaxes the constraints it was planned under)
            kept.window = w
            self.st.plan = kept
            return
        for kept in (passed, held):
            if (
                kept is not None
                and kept.keeps > b
                and kept.t0 <= self.st.t
                and not self.con.tb.gate[b]
                and self.pf.passed_above(kept, [(b, s_c, cap, False)], 1) < 0
            ):
                # the profile in hand, toward a goal beyond b, passes b below its cap, braking
                # (a re-plan from inside a brake at once, `brake_into`, 0.5 mm before a feed
                # drop at 116.6 mm/s and −3.3 m/s²: nothing toward b itself was accepted); so
                # does a brake through to a cap beyond b (`Plan.keeps`: falling feeds on 1 mm
                # blocks, the target profile 1 mm to the next drop refused from inside it,
                # the last-resort brake went to 0.04 mm/s, feeds seed 157)
                kept.window = w
                self.st.plan = kept
                return
        if (
            passed is not None
            and passed.goal == SETTLE
            and passed.t0 <= self.st.t < passed.t0 + passed.dur
            and not self.con.tb.gate[b]
            and self.pf.passed_above(passed, [(b, s_c, cap, False)], 1) < 0
        ):
            # the brake at once that brought the path to the boundary it just passed
            # (`Brakes.brake_first`, checked against the candidates ahead) goes on to its
            # end where it passes b below its cap: from inside it, zero acceleration at b,
            # a feed cap, came too near (a feed change 0.2 mm before a drop, 46.6 mm/s at
            # −1.9 m/s², the ramp to zero acceleration alone 0.209 mm: the last-resort brake
            # went to 32 mm/s for 43.5, feeds seed 971)
            passed.window = w
            self.st.plan = passed
            return
        if not self.con.hold:
            # under a feed hold the brake to rest from the path's state is the hold's own
            # motion, not a fallback (a hold that came inside a brake at once to a feed cap,
            # 0.18 mm before a boundary whose lowest reachable velocity ruckig refused at the
            # edge, a review's program); what it passes is checked on arrival (`_arrive`)
            self.count(f"target profile refused at boundary {b}")
        self.pf.brake(a_max, j_max, w)

    def _hold_top(
        self, s: float, v: float, a: float, s_c: float, target: float, v_max: float,
        a_max: float, j_max: float, b: int, w: int,
    ) -> None:  # fmt: skip
        """The profile just chosen starts where the path's acceleration ramps out onto v_max
        (v_p = v_max, not above `settle`'s ceiling: a cruise that ends at it): there ruckig
        may miss the profile that holds v_max and brakes late, and return one that brakes
        early (`_unpin`). A forced re-plan toward rest at the program's end, 7 mm ahead at
        157.8 mm/s under a ceiling of 160, took 85.4 ms where 64.4 fit, for states 1e-16
        apart, and braked from 160 to 115 mm/s where the path could hold 160
        (tests/unit/cnc/path/test_dense_constraints.py). The same target with v_max half a
        rounding higher (within `V_ROUND`: at the cap as the steps read it) is taken where it
        is shorter by more than HOLD_TOP_GAIN (one ruckig call). A gain of a rounding is the
        same profile: taken, its v_p a full rounding above a cap the shift's v_max stood for
        made the steps' forced re-plans take turns, and the path passed F3000 blocks at up to
        65.6 mm/s (feeds seeds 22, 23, 95, a first version). Above the ceiling (v_max = v_p
        after an override drop) the early brake is the brake at once: kept."""
        first = self.st.plan
        assert first is not None
        last = self.st.last_error
        top = v_max + 0.5 * V_ROUND
        if (
            not self.pf.try_target(s, v, a, s_c, target, top, a_max, j_max, b, w)
            or self.st.plan is None
            or self.st.plan.dur >= first.dur - HOLD_TOP_GAIN
        ):
            self.st.plan, self.st.last_error = first, last  # (a refusal here is no error)

    def _highest_below(
        self, s: float, v: float, a: float, s_c: float, target: float, v_max: float,
        a_max: float, j_max: float, b: int, w: int,
    ) -> None:  # fmt: skip
        """Ruckig refused `target` and accepted rest (the plan in hand): the highest velocity
        below the target it accepts, 1e-6 below it or else by 14 bisection steps (within
        6e-5 of it). Ruckig decides at the edge of what is feasible: where the exact brake to
        the target has no room left it refuses it and accepts one 1e-8 below (seed 482:
        12.2034 mm/s refused, 12.2034 · (1 − 1e-8) accepted, no dip)."""
        near = target * (1.0 - 1e-6)
        if not self.pf.try_target(s, v, a, s_c, near, max(v_max, near), a_max, j_max, b, w):
            self._bisect(0.0, near, s, v, a, s_c, v_max, a_max, j_max, b, w)

    def _bisect(
        self, good: float, bad: float, s: float, v: float, a: float, s_c: float, v_max: float,
        a_max: float, j_max: float, b: int, w: int,
    ) -> None:  # fmt: skip
        """From `good` (a target ruckig accepts) toward `bad` (one it refuses), 14 bisection
        steps; the last one accepted is planned."""

        def accepted(e: float) -> bool:
            return self.pf.try_target(s, v, a, s_c, e, max(v_max, e), a_max, j_max, b, w)

        accepted(highest(good, bad, 14, accepted))
