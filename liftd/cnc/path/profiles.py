"""The ruckig profiles the path tracker plans with and reads (`Profiles`, a part of
`targets.Targets`, `Targets.pf`, which the other parts reach through it): a target profile
toward a boundary, ruckig's velocity interface, where a profile passes a candidate, and the
repairs where ruckig's profile dips below its ends (known deviation 2 of docs/geo-core.md:
`mend`). Moved out of targets.py (issue 36, eighteenth round), which chooses the targets."""

from __future__ import annotations

from liftd.cnc.path.constraints import CAP_TOL, GATE_TOL, INF, V_ROUND, Constraints
from liftd.cnc.path.plan import BRAKE, EPS_S, PathState, Plan
from liftd.cnc.path.velocity import brake_distance
from liftd.cnc.ruckig1 import (
    Evaluator,
    Phases,
    ProfileError,
    Ruckig1,
    brake_pieces,
    highest_between,
)

DIP_TOL = 1e-4  # relative: a profile this much below the lower of its ends' velocities dips
REACH_ROUND = 1e-9  # relative: a target this much below the highest reachable one (`_unreach`)


def lowest_velocity(ph: Phases) -> float:
    """The lowest velocity of a ruckig profile: at a phase's ends, or inside a phase where its
    acceleration crosses zero under a positive jerk (v − a²/2j there)."""
    low = ph.v[7]
    start = 0.0
    for i in range(7):
        low = min(low, ph.v[i])
        a, j = ph.a[i], ph.j[i]
        end = ph.t_sum[i]
        if a < 0.0 < j and -a / j < end - start:
            low = min(low, ph.v[i] - a * a / (2.0 * j))
        start = end
    for _, dur, v, a, j in brake_pieces(ph):
        low = min(low, v)
        if a < 0.0 < j and -a / j < dur:
            low = min(low, v - a * a / (2.0 * j))
    return low


def lowest_rise(ph: Phases) -> float:
    """The lowest velocity from which the profile (after ruckig's brake into its limits)
    speeds up again: where its acceleration turns positive (under a positive jerk, v − a²/2j
    there, or a phase's start); INF where it never does."""
    low = INF
    for i in range(7):
        a, j = ph.a[i], ph.j[i]
        if ph.a[i + 1] <= GATE_TOL:
            continue  # not speeding up at the phase's end
        low = min(low, ph.v[i] if a > 0.0 or j <= 0.0 else ph.v[i] - a * a / (2.0 * j))
    return low


def only_brakes(ph: Phases) -> bool:
    """The profile's acceleration is nowhere positive (it is linear in each piece: its ends)."""
    return max(ph.a) <= GATE_TOL and all(p[3] <= GATE_TOL for p in brake_pieces(ph))


class Profiles:
    """The profiles for the path state `st` under the constraints `con`: ruckig's solves
    (`calc`) and what is read off them."""

    def __init__(self, con: Constraints, st: PathState) -> None:
        self.con = con
        self.st = st
        self.calc = Ruckig1()

    def try_target(
        self, s: float, v: float, a: float, s_c: float, tgt: float, v_max: float,
        a_max: float, j_max: float, b: int, w: int,
    ) -> bool:  # fmt: skip
        try:
            traj = self.calc.position(s, v, a, s_c, tgt, max(v_max, tgt), a_max, j_max)
        except ProfileError as exc:
            self.st.last_error = str(exc)
            return False
        plan = self.st.plan = Plan(traj, self.st.t, b, w, s_c, tgt)
        plan.soft_from = min(self.st.soft_from, b)
        return True

    def mend(
        self, s: float, v: float, a: float, v_p: float, s_c: float, target: float, v_max: float,
        a_max: float, j_max: float, b: int, w: int, passed: Plan | None, held: Plan | None,
        event: bool,
    ) -> None:  # fmt: skip
        """The target profile just chosen (`settle`), where it dips below its ends: a low
        target's (below half the path's velocity) replaced by the profile in hand
        (`_undip`), the same with v_max a rounding higher (`_unpin`) or the exact brake
        (`_exact_brake`); a speed-up after a brake's ramp-out by the target a rounding lower
        (`_unreach`)."""
        floor = min(v, v_p, target)
        if (
            target < 0.5 * max(v, v_p)
            and self.dips(floor)
            and not self._undip(target, b, w, (passed, held))
        ):
            if event:  # a lift planned with the times before it (wide seed 767)
                self._exact_brake(s, v, a, s_c, target, a_max, j_max, b, w)
            else:
                self._unpin(s, v, a, s_c, target, v_max, a_max, j_max, b, w, floor)
                if self.dips(floor):
                    # the exact brake where it reaches b: from a cruise at 73.0 mm/s to
                    # x1 = 2.19 1 mm on (override 10 %), ruckig's profile went down to
                    # 1.40 (feeds seed 381; `_unpin` found none)
                    self._exact_brake(s, v, a, s_c, target, a_max, j_max, b, w)
        elif a < 0.0 and v_p < target and self.dips(v_p):
            self._unreach(s, v, a, s_c, target, v_max, a_max, j_max, b, w, v_p)

    def dips(self, floor: float) -> bool:
        """The profile just chosen goes below `floor` (the lower of the velocity it starts
        from and its target) on the way. Its pieces are read for it, and kept for its cycles."""
        plan = self.st.plan
        assert plan is not None
        ph = Phases(plan.traj)
        plan.ev = Evaluator(plan.traj, ph)
        return lowest_velocity(ph) < floor * (1.0 - DIP_TOL) - V_ROUND

    def _unpin(
        self, s: float, v: float, a: float, s_c: float, target: float, v_max: float,
        a_max: float, j_max: float, b: int, w: int, floor: float,
    ) -> None:  # fmt: skip
        """The profile just chosen dips and none is kept (`_undip`): where the path's velocity,
        its acceleration ramped out, is v_max itself (a cruise at the ceiling that the step
        ended with a last bit of acceleration), ruckig misses the profile that holds v_max and
        brakes late, and returns one that brakes below the target and comes back, and takes
        longer (wide seed 54: from 75 mm/s, v_p = v_max, toward 9.485 mm/s 1.012 mm on, a
        profile through 8.236 in 26.86 ms; with v_max 1e-15 m/s higher, 23.72 ms and no dip).
        The same target with v_max a rounding higher (`V_ROUND`, a velocity that close above a
        cap is at it) is taken where it does not dip; else the dip stays (one ruckig call)."""
        dipping = self.st.plan
        top = v_max + V_ROUND
        if not self.try_target(s, v, a, s_c, target, top, a_max, j_max, b, w) or self.dips(floor):
            self.st.plan = dipping

    def _unreach(
        self, s: float, v: float, a: float, s_c: float, target: float, v_max: float,
        a_max: float, j_max: float, b: int, w: int, floor: float,
    ) -> None:  # fmt: skip
        """The profile just chosen, from inside a brake toward a target above v_p (the ramp-out
        of the deceleration, then a speed-up), goes below v_p: ruckig at the edge of the
        reachable (`reach_from`: the target is the highest velocity the path can have at b)
        misses the profile that ramps out and speeds up at once and returns one that brakes
        on and comes back, and takes longer (`short_drop` from F3000, override 100 → 10 %
        1.7 mm before its 0.2 mm F6000 block, ramped out at that block's end to 10.0 mm/s,
        toward 18.11 mm/s 0.2 mm on: a profile through 3.61 in 20.4 ms; with the target
        `REACH_ROUND` lower, 14.9 ms and no dip).
        That one is taken where it does not dip; else the dip stays (one ruckig call). Tried
        wherever such a speed-up dips below v_p, at the edge or not."""
        dipping, error = self.st.plan, self.st.last_error
        lower = target * (1.0 - REACH_ROUND)
        if not self.try_target(s, v, a, s_c, lower, v_max, a_max, j_max, b, w) or self.dips(floor):
            self.st.plan, self.st.last_error = dipping, error

    def _exact_brake(
        self, s: float, v: float, a: float, s_c: float, target: float, a_max: float,
        j_max: float, b: int, w: int,
    ) -> None:  # fmt: skip
        """An event's re-plan (`Tracker.set_state`) chose a profile that dips and no profile
        is in hand (the producer's is the queue tail's, not the path's), or (elsewhere) one
        that `_unpin` could not replace. Where the path is
        on the exact brake to the target, the brake reaching b within EPS_S, that brake is
        planned: ruckig's velocity interface, time-optimal from (v, a) to the target, with b
        as its goal. It is the profile the path followed before the event (from a state
        inside it, the hardest brake that fits is the only one), so every arrival stays as a
        lift planned it; ruckig's position interface finds that brake a rounding too long
        and returns one that dips and arrives later (issue 36, narrow seed 635: override
        100 → 77 % while braking from 196 mm/s to 4.82 mm/s 3.663 mm on, the brake
        3e-17 m longer than the distance, a profile through 3.09 mm/s, 44.27 ms, where the
        brake takes 39.90; CAM seed 956: 46.3 → 2.68 mm/s, 1.15 mm/s and 21.65 against 17.61
        ms). Only the exact brake: a profile that leaves it (a lower target, tried) may reach
        a lift's boundary sooner than planned (wide seed 767, Z 0.2 ms late)."""
        if abs(s + brake_distance(v, a, target, a_max, j_max) - s_c) > EPS_S:
            return
        try:
            traj = self.calc.velocity(s, v, a, target, a_max, j_max)
        except ProfileError as exc:
            self.st.last_error = str(exc)
            return
        if abs(float(traj.at_time(traj.duration)[0][0]) - s_c) > EPS_S:
            return  # ruckig's brake is not the closed form's (never seen)
        plan = Plan(traj, self.st.t, b, w, s_c, target)
        plan.soft_from = min(self.st.soft_from, b)
        self.st.plan = plan

    def _undip(self, target: float, b: int, w: int, kept: tuple[Plan | None, Plan | None]) -> bool:
        """Ruckig's time-optimal profile to a low target brakes below it and comes back where
        the exact brake fits only just (from inside a brake that has no slack left, a re-plan
        for a window that moved on finds it a few 10 nm too long: issue 36, wide seed 35,
        33 → 1.94 mm/s went down to 0.90; known deviation 2). The CNC does not dip: the
        profile in hand, or the one that brought the path to the boundary it just passed, is
        kept if it ends at b with the same velocity (it is the exact brake, planned with
        slack). Else the dip stays (after an event no such profile is at hand). A lower target
        where the brake fits with room was tried: after an override drop it reached LIFT_END
        1.2 ms sooner than the dip, and Z, descending, landed 0.2 ms late (wide seed 767)."""
        for plan in kept:
            if (
                plan is not None
                and plan.goal == b
                and plan.t0 <= self.st.t
                and abs(plan.v_end - target) <= CAP_TOL * target + V_ROUND
            ):
                plan.window = w
                self.st.plan = plan
                return True
        return False

    def brake(self, a_max: float, j_max: float, w: int) -> None:
        """Last resort: brake to rest from the path's state (never expected; counted)."""
        traj = self.calc.velocity(self.st.s, self.st.v, self.st.a, 0.0, a_max, j_max)
        self.st.plan = Plan(traj, self.st.t, BRAKE, w, None, 0.0)

    def velocity_plan(self, e: float, goal: int, w: int, a_max: float, j_max: float) -> Plan | None:
        """Ruckig's velocity interface from the path's state to e (time-optimal, zero
        acceleration there) as a plan toward `goal` (CRUISE or SETTLE); None where refused."""
        try:
            traj = self.calc.velocity(self.st.s, self.st.v, self.st.a, e, a_max, j_max)
        except ProfileError:
            return None
        return Plan(traj, self.st.t, goal, w, None, e)

    @staticmethod
    def passed_above(plan: Plan, cands: list[tuple[int, float, float, bool]], k: int) -> int:
        """The first of candidates 0 … k − 1 that `plan` passes above its cap (or, the first,
        not braking: it could speed up after it), -1 where none."""
        for j in range(k):
            _, vj, aj = plan.at(plan.time_at(cands[j][1], INF))
            if cands[j][3] or vj > cands[j][2] * (1.0 + CAP_TOL) + V_ROUND:
                return j
            if j == 0 and aj > GATE_TOL:
                return j
        return -1

    def rises_above(self, plan: Plan, cand: tuple[int, float, float, bool]) -> bool:
        """`plan` speeds up again after `cand`'s boundary above the ceiling of its block
        before the block ends (`passed_above` reads the boundary alone): a profile toward a
        goal beyond it, with v_max at the velocity it had before it (`Shift.toward`'s
        shift), passed an F5548 boundary at its cap still braking and came back to 2.5 µm/s
        above it in the block (feeds seed 940)."""
        tb = self.con.tb
        b, s_b = cand[0], cand[1]
        if b >= tb.n:
            return False
        t_b = plan.time_at(s_b, INF)
        if t_b == INF:
            return False
        plan.ev.prepare()
        ph = plan.ev.phases
        assert ph is not None
        t_e = plan.time_at(tb.s[b + 1], plan.t0 + ph.dur)  # its end, or the profile's
        top = highest_between(ph, t_b - plan.t0, t_e - plan.t0)
        return top > tb.ceiling(b, self.con.ov) * (1.0 + CAP_TOL) + V_ROUND
