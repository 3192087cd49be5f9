"""The one brake through a feed drop (`Aims`, a part of the tracker, `Tracker.aim`, that holds
the constraint queries, the path's state and the target profiles of `targets.py`). Inside a
run the path acceleration is continuous: where the candidate that binds is a feed drop whose
target a later cap of its run lowers, zero acceleration at the drop, below its cap, is no
rule of the CNC (known deviation 8 of docs/geo-core.md). The path brakes toward the later cap
at once, passing the drop below its cap (`Aims.through`), or passes the drop at its cap still
braking (`Aims._brake_state`, a target acceleration); so it does where the drop's own cap
lies in the jerk gap and the boundary after it wants the path slower still (`Aims.gap_state`).
Each guard is a program a version without it broke (tests/unit/cnc/path/test_run_brakes.py).
"""

from __future__ import annotations

import math

from liftd.cnc.path.constraints import (
    CAP_TOL,
    CHAIN_MARGIN,
    GATE_TOL,
    INF,
    SLACK_MARGIN,
    V_ROUND,
    Constraints,
)
from liftd.cnc.path.plan import PathState, Plan
from liftd.cnc.path.profiles import DIP_TOL, lowest_velocity
from liftd.cnc.path.targets import Targets, highest
from liftd.cnc.path.velocity import brake_crossing, brake_distance
from liftd.cnc.ruckig1 import ProfileError

AIMS = 4  # profiles `Aims.through` tries at most (one `Targets.settle` each)
GAP_STEPS = 10  # `Aims.gap_state`: its deceleration within 2^-10 of a_max (a solve each)
# `Aims._brake_state`, where ruckig refuses the drop at its cap: the velocities below the cap
# it tries there (a fraction below it; a solve each)
BELOW = (0.01, 0.03, 0.06, 0.1)


def hardest(v: float, e: float, a_max: float, j_max: float) -> float:
    """The deceleration at v whose ramp-out alone, at full jerk, ends at e (the shortest brake
    from v to e that ends with zero acceleration; a hair inside, 1e-9, for rounding)."""
    return -min(a_max, math.sqrt(2.0 * j_max * max(v - e, 0.0)) * (1.0 - 1e-9))


def _passes(
    v: float, a: float, e: float, room: float, mid: list[tuple[float, float]], a_max: float,
    j_max: float,
) -> bool:  # fmt: skip
    """The brake from (v, a) down to e with zero acceleration there ends within `room` and is
    below each cap of `mid` (distance from its start, cap) by then, with SLACK_MARGIN."""
    return brake_distance(v, a, e, a_max, j_max) <= room and all(
        c >= e and d - brake_crossing(v, a, e, c, a_max, j_max) >= SLACK_MARGIN for d, c in mid
    )


def least_brake(v: float, e: float, room: float, a_max: float, j_max: float) -> float | None:
    """The least deceleration at v from which the brake down to e ends within `room`
    (bisection within 2^-40 of a_max); None where not even the hardest does."""
    a_lo = hardest(v, e, a_max, j_max)
    if brake_distance(v, a_lo, e, a_max, j_max) > room:
        return None
    if brake_distance(v, 0.0, e, a_max, j_max) <= room:
        return 0.0
    return highest(a_lo, 0.0, 40, lambda x: brake_distance(v, x, e, a_max, j_max) <= room)


def _after(
    ext: list[tuple[int, float, float, bool]], j: int, k: int
) -> tuple[float, list[tuple[float, float]]]:
    """From drop j to candidate k: the room for the brake (to k, CHAIN_MARGIN left) and the
    caps between them (distance from j, cap)."""
    s_j = ext[j][1]
    return ext[k][1] - s_j - CHAIN_MARGIN, [(c[1] - s_j, c[2]) for c in ext[j + 1 : k]]


def free_brake(
    ext: list[tuple[int, float, float, bool]], j: int, k: int, e: float, a_max: float,
    j_max: float,
) -> float | None:  # fmt: skip
    """The least deceleration at drop j's cap from which the brake reaches e at k (the brake
    state's continuation), where that brake passes every cap between j and k below it; None
    where not. Where one of them binds instead, that brake crosses it too late, and a brake
    state at j that keeps it (a harder deceleration) is at its edge: only the brake at once
    from j keeps it, ruckig does not reach that drop at its cap from there, and the brake
    reaches e before k (feeds seed 726: 0.5 mm before an F8229 drop at 163.7 mm/s and −7.88
    m/s², every profile to it refused, the shift's dip went down to 61.3 mm/s four drops
    on; feeds seeds 776 and 936 the same, the brake at once from such a state went down to
    a corner's 7.2 mm/s early and dipped)."""
    c_j = ext[j][2]
    room, mid = _after(ext, j, k)
    if room <= 0.0 or c_j <= e:
        return None
    a_e = least_brake(c_j, e, room, a_max, j_max)
    if a_e is None or not _passes(c_j, a_e, e, room, mid, a_max, j_max):
        return None
    return a_e


def _keeps(
    held: Plan, ext: list[tuple[int, float, float, bool]], j: int, k: int, e: float,
    a_max: float, j_max: float,
) -> bool:  # fmt: skip
    """`held` is a brake state at drop j aimed at k (`Aims._brake_state`) whose state there
    still keeps e at k, passing the drops between below their caps."""
    b_j, _, c_j, _ = ext[j]
    if held.goal != b_j or held.aim != ext[k][0] or held.v_end > c_j or held.a_end >= 0.0:
        return False
    room, mid = _after(ext, j, k)
    if not mid and brake_distance(c_j, 0.0, e, a_max, j_max) <= room:
        return False  # zero acceleration at j keeps e now: no state needed (a cold review)
    return _passes(held.v_end, held.a_end, e, room, mid, a_max, j_max)


class Aims:
    """The aim through a feed drop, for the path state `st` under the constraints `con`, with
    the profiles of `tg`; `Tracker` holds it and tries it before the drop's own target."""

    def __init__(self, con: Constraints, st: PathState, tg: Targets) -> None:
        self.con = con
        self.st = st
        self.tg = tg

    def through(
        self, cands: list[tuple[int, float, float, bool]], i: int, v: float, a: float,
        v_p: float, ceiling: float, a_max: float, j_max: float, w: int, passed: Plan | None,
        held: Plan | None, event: bool,
    ) -> bool:  # fmt: skip
        """Candidate i, a feed drop (no run boundary), binds, but a later candidate of its run
        lowers its target (`Constraints.target_cap`): zero acceleration at i, below its
        own cap, is no rule of the CNC; one brake toward the later one passes i faster (known
        deviation 8 of docs/geo-core.md: start-up over 0.2 mm blocks at F60000 toward an
        F3000 block before a corner of 3.5 mm/s, a pause in the brake at the F3000 boundary
        held the boundary before it at 34.6 for 38.7 mm/s, feeds seed 125). Plans toward the
        candidate that lowers i's target (and on to the one that lowers that one's) and keeps
        that profile where it passes every candidate before it below its cap, braking at i
        (their feed caps are then the profile's, `Plan.soft_from`); where it passes one after
        i too fast, toward that one instead, at most AIMS profiles; where it passes i itself
        too fast, toward i's cap still braking (`_brake_state`). False, nothing changed,
        where none is kept, and where the aim's goal may rise or fall as the path moves on:
        there zero acceleration at i leaves the next plan its room."""
        # the list ends within the brake from the path's state (`Constraints.horizon`); the
        # aim's goal must keep what lies after it (the aim passed a feed drop at 72 where a
        # rest at the window's end 0.4 mm after its goal allowed 49 mm/s, feeds seed 950)
        ext = self.con.extend(cands, self.st.s, a_max, j_max, AIMS)
        k, e = i, self.con.target_cap(ext, i)
        while True:
            nk = self.con.binding(ext, k, e)
            if nk <= k:
                break
            k, e = nk, self.con.target_cap(ext, nk)
            if ext[k][3] or e >= ext[k][2] * (1.0 - CAP_TOL):
                break
        if k <= i or (k + 1 == len(ext) and not ext[k][3] and len(ext) > len(cands)):
            return False  # (what lies beyond the extended list may lower it still)
        if (
            ext[k][3]
            and e < self.con.own_cap(ext[k][0]) * (1.0 - CAP_TOL)
            and self.con.chain_open(ext)
        ):
            # a run's end lowered for the window's end (rest, or the floor its chain leaves):
            # it rises as the window moves, and a profile aimed at it has no room to reach the
            # higher end (rest at look-ahead 8 0.5 mm after a drop to F6000, then a corner of
            # 1.62 mm/s there, reachable only at rest: feeds seed 577)
            return False
        st = self.st
        errors, msg, soft, prev = st.errors, st.last_error, st.soft_from, st.plan
        for _ in range(AIMS):
            b, s_c, _, _ = ext[k]
            target = self.tg.boundary_target(ext, k, e, v, a, v_p, ceiling, a_max, j_max, w)
            if abs(target - e) > CAP_TOL * e + V_ROUND:
                break  # out of reach exactly (the jerk gap): i's own target keeps it
            v_max = max(ceiling, target, v_p) if v <= ceiling else max(ceiling, target, v, v_p)
            # the caps before k are the profile's (checked here, `below`): a step's check of
            # them with zero acceleration there would force a re-plan at each one passed
            # braking (feeds seed 921: a brake state toward one drop and toward the one before
            # it, in turns, then the shift passed the drop at 76.1 for 74.4 mm/s)
            st.soft_from = ext[0][0]
            self.tg.settle(st.s, v, a, v_p, s_c, target, e, v_max, a_max, j_max, b, w,
                           self.tg.hard(b, w), passed, held, event, ceiling)  # fmt: skip
            plan = st.plan
            if plan is None or plan.goal != b or st.errors != errors:
                break
            fast = self.tg.pf.passed_above(plan, ext[i:k], k - i)
            if fast == 0 and self._brake_state(ext, i, k, e, v_p, ceiling, a_max, j_max, w, held):
                return True
            if fast < 0:
                if plan.at(plan.time_at(ext[i][1], INF))[2] > -GATE_TOL or not self.below(
                    plan, ext[:k]
                ):
                    # zero acceleration at i after all (from inside the brake to its cap:
                    # ruckig's profile may rise after it, 92.4692 in a block of 92.4667 mm/s,
                    # feeds seed 940), or a cap before i passed too fast
                    break
                plan.aim = b
                return True
            k = i + fast  # passed too fast: toward that one (its target lowered for the later)
            if k <= i:
                break
            e = self.con.target_cap(ext, k)
        st.plan, st.errors, st.last_error, st.soft_from = prev, errors, msg, soft
        return False

    def _brake_state(
        self, ext: list[tuple[int, float, float, bool]], i: int, k: int, e: float, v_p: float,
        ceiling: float, a_max: float, j_max: float, w: int, held: Plan | None = None,
    ) -> bool:  # fmt: skip
        """The one brake toward k's target e passes feed drop i above its cap (or does not
        brake there), and zero acceleration at i at its cap loses e: the path passes i at its
        cap still braking, with the least deceleration from which e at k stays reachable
        (the block after i is capped at i's cap, so that is the fastest way through both;
        feeds seed 17: the F6000 boundary 1 mm before a corner of 0.41 mm/s held at zero
        acceleration at 69.5 mm/s, the boundary before it at 100.8 where the rules allow
        109.1). A plan toward i with that acceleration there (`Plan.a_end`); False where
        none, nothing changed. Where ruckig refuses the state from the profile in hand that
        leads to it (`held`, the window moved on: a re-plan on the way, 0.5 mm before an F9120
        drop at 171.1 mm/s and −1.88 m/s², refused the same state it had planned 3 ms before,
        and the fallback passed the drop at 152.9 for 152.0 mm/s, feeds seed 50), that one,
        where its state still keeps e."""
        st = self.st
        plan = None
        first = True
        for j in range(i, min(k, i + AIMS)):
            # with drops between i and k: anchored at the first drop from which the brake to e
            # passes the rest below their caps (`free_brake`), with the ones before it passed
            # below theirs by the profile to it (`_state_plan`); at most AIMS drops looked at
            # (each a bisection of the closed-form brake: over every drop up to k, a
            # falling-feeds cycle took 3.6 ms where main's took 0.4, `bench_step.py`)
            a_j = free_brake(ext, j, k, e, a_max, j_max)
            if a_j is None:
                continue
            plan = self._state_for(ext, j, k, e, a_j, v_p, ceiling, a_max, j_max, w, first)
            if plan is None and held is not None and _keeps(held, ext, j, k, e, a_max, j_max):
                plan = held
                plan.window = w
            if plan is not None:
                break
            first = False
        if plan is None:
            return False
        plan.soft_from = min(st.soft_from, ext[0][0])
        plan.aim = ext[k][0]
        st.plan = plan
        return True

    def _state_for(
        self, ext: list[tuple[int, float, float, bool]], i: int, k: int, e: float, a_i: float,
        v_p: float, ceiling: float, a_max: float, j_max: float, w: int, below: bool,
    ) -> Plan | None:  # fmt: skip
        """The brake state at drop i toward e at k (`_brake_state`), at i's cap with a_i
        (`free_brake`) or, where `below` (the first anchor tried: 4 solves more), a little
        below it (`_below_cap`); None where none. The drops between i and k are the brake's
        (`free_brake`; the steps read them so, `Constraints.violated` with `Plan.aim`: read with
        zero acceleration there, forced re-plans took turns with the shift, which passed a
        drop at 71.40 for 71.32 mm/s, feeds seed 394); with drops between, i's own target is
        lowered for them with zero acceleration at each, and the plan to i at its cap is kept
        also where it needs none at i (feeds seed 441: toward an F5182 drop one block before
        an F4295 drop and a rest chain, boundary 38 held at 89.4 for 97.7 mm/s)."""
        c_i = ext[i][2]
        room, mid = _after(ext, i, k)
        if not mid and brake_distance(c_i, 0.0, e, a_max, j_max) <= room:
            return None  # zero acceleration at i at its cap keeps e
        plan = self._state_at(ext, i, c_i, a_i, v_p, ceiling, a_max, j_max, w)
        if plan is None and below:
            plan = self._below_cap(ext, i, e, room, mid, v_p, ceiling, a_max, j_max, w)
        return plan

    def _below_cap(
        self, ext: list[tuple[int, float, float, bool]], i: int, e: float, room: float,
        mid: list[tuple[float, float]], v_p: float, ceiling: float, a_max: float,
        j_max: float, w: int,
    ) -> Plan | None:  # fmt: skip
        """Where ruckig refuses drop i at its cap braking (`_brake_state`), at the edge of what
        it reaches (its first step, with the velocity kept ≥ 0): i a little below its cap,
        still braking, with the least deceleration from there, BELOW (feeds seed 101: from a
        run boundary at 51.3 mm/s, 0.6 mm before an F1200 drop 0.2 mm before a corner of 0.51
        mm/s, 36 mm/s at the drop and every deceleration that keeps the corner refused; the
        shift's brake at once passed the drop at 14.3 mm/s; now 35.6). Not below i's target
        with zero acceleration there (`Constraints.target_cap`), the fallback's."""
        c_i = ext[i][2]
        floor = self.con.target_cap(ext, i)
        for f in BELOW:
            v_i = c_i * (1.0 - f)
            if v_i <= floor:
                return None
            a_i = least_brake(v_i, e, room, a_max, j_max)
            if a_i is None or not _passes(v_i, a_i, e, room, mid, a_max, j_max):
                continue
            plan = self._state_at(ext, i, v_i, a_i, v_p, ceiling, a_max, j_max, w)
            if plan is not None:
                return plan
        return None

    def _state_at(
        self, ext: list[tuple[int, float, float, bool]], i: int, v_i: float, a_i: float,
        v_p: float, ceiling: float, a_max: float, j_max: float, w: int,
    ) -> Plan | None:  # fmt: skip
        """The profile to candidate i at v_i (at most its cap) with a_i there, the least
        deceleration from which the later cap stays reachable and the caps between are
        passed (`least_brake`, `_passes`; `_state_plan`); None where none."""
        st = self.st
        v_max = max(ceiling, v_i, v_p) if st.v <= ceiling else max(ceiling, v_i, st.v, v_p)
        return self._state_plan(ext, i, a_i, v_max, min(st.v, v_i), a_max, j_max, w, v_i)

    def gap_state(
        self, cands: list[tuple[int, float, float, bool]], i: int, target: float, v_p: float,
        ceiling: float, a_max: float, j_max: float, w: int,
    ) -> bool:  # fmt: skip
        """Feed drop i's own cap lies in the jerk gap (`Targets.pick_target` took x1 below it:
        after an override change the path cannot reach the cap with zero acceleration
        there), and the candidate after it wants the path slower still: the path passes i
        at its cap still braking, with the least deceleration ruckig reaches from the
        path's state (bisection, GAP_STEPS solves at most), from which the next candidate's
        target stays reachable and is not undercut by the ramp-out alone. Feeds seed 249:
        override 30 → 200 % at 292.9 mm/s and −5.0 m/s², 6.2 mm before an F3000 drop of
        100 mm/s 2 mm before a corner of 0.14 mm/s: x1 = 50.0 there, where one brake passes
        the drop at 100. False, nothing changed, where none fits."""
        st = self.st
        b_i, s_i, c_i, _ = cands[i]
        if ceiling < c_i or v_p <= c_i or target >= c_i * (1.0 - CAP_TOL) - V_ROUND:
            return False
        # the boundary after i must want the path slower still, or the ramp-out after i dips
        # below its target (it may lie beyond the brake from here: feeds seed 247, a corner
        # of 0.41 mm/s 0.5 mm after an F1200 drop, override 100 → 150 % in the brake)
        nxt = self.con.collect(st.s, self.con.seg, self.con.tb.s[b_i + 1] - st.s, first=b_i + 1)
        if not nxt or nxt[0][0] != b_i + 1:
            return False
        nb, ns, _, ngate = nxt[0]
        e = self.con.target_cap(nxt, 0)
        room = ns - s_i - CHAIN_MARGIN
        v_max = max(ceiling, st.v, v_p)

        def plan_for(x: float) -> Plan | None:
            """The profile to (s_i, c_i, x) where it keeps everything it is checked for."""
            if (
                c_i + x * abs(x) / (2.0 * j_max) < e
                or (ngate and brake_distance(c_i, x, e, a_max, j_max) > room)
                or (not ngate and self.con.need(c_i, x, e, False, a_max, j_max) > room)
            ):
                return None  # the ramp-out undercuts the next target, or loses it
            return self._state_plan(cands, i, x, v_max, c_i, a_max, j_max, w)

        good, bad = hardest(c_i, e, a_max, j_max), 0.0
        best = plan_for(good)
        if best is None:
            return False
        for _ in range(GAP_STEPS):
            mid = 0.5 * (good + bad)
            found = plan_for(mid)
            if found is not None:
                good, best = mid, found
            else:
                bad = mid
        best.soft_from = min(st.soft_from, cands[0][0])
        best.aim = nb
        st.plan = best
        return True

    def _state_plan(
        self, cands: list[tuple[int, float, float, bool]], i: int, x: float, v_max: float,
        floor: float, a_max: float, j_max: float, w: int, v_i: float = INF,
    ) -> Plan | None:  # fmt: skip
        """The profile from the path's state to candidate i at its cap (or at v_i below it)
        with acceleration x there (`Plan.a_end`), where ruckig reaches it, it snaps to its
        goal, it does not dip below `floor` and it passes the candidates before i below their
        caps; else None."""
        st = self.st
        b_i, s_i, c_i, _ = cands[i]
        c_i = min(c_i, v_i)
        try:
            traj = self.tg.pf.calc.position(st.s, st.v, st.a, s_i, c_i, v_max, a_max, j_max, a1=x)
        except ProfileError:
            return None
        plan = Plan(traj, st.t, b_i, w, s_i, c_i)
        if plan.p_end != s_i or plan.v_end != c_i:
            # not snapped to its goal (ruckig's end more than 1 nm or 1 nm/s off): the step
            # would end it between boundaries, where a plan runs on with zero acceleration
            return None  # (a cold review: an acceleration jump of x there)
        plan.a_end = x
        plan.ev.prepare()
        ph = plan.ev.phases
        assert ph is not None
        if lowest_velocity(ph) < floor * (1.0 - DIP_TOL) or not self.below(plan, cands[:i]):
            return None
        return plan

    def below(self, plan: Plan, cands: list[tuple[int, float, float, bool]]) -> bool:
        """`plan` passes every one of `cands` at most at its cap and does not speed up again
        above the ceiling of the block after it (`rises_above`: a profile toward a feed drop
        two blocks on passed the one before it at its cap of 171.25 mm/s and rose to 171.30
        in its block, feeds seed 86)."""
        return all(
            plan.at(plan.time_at(c[1], INF))[1] <= c[2] * (1.0 + CAP_TOL) + V_ROUND
            and not self.tg.pf.rises_above(plan, c)
            for c in cands
        )
