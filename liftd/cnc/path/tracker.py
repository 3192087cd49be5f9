"""The path motion generator: s(t) along a prepared path, jerk-limited, with continuous
acceleration inside a run, O(1) work per cycle away from constraints.

The motion is always the time-optimal ruckig profile (`liftd.cnc.ruckig1`) toward one goal:

* *cruise*: reach the ceiling of the current segment (velocity interface), or 0 under a hold;
* *target*: arrive at a constraint boundary ahead (position interface) with its effective cap
  and zero acceleration.

Each step proposes the state at the end of the step along the current profile and checks every
constraint within the braking horizon by its *slack* (`constraints.py`: the queries and the
effective caps). If a slack would become negative, the step is re-planned from its start toward
that constraint: the time-optimal profile then switches from accelerating or cruising to
braking at the exact instant inside the cycle. Steps are cut where the path reaches a boundary
that changes the ceiling or the run, or a constraint, or where a target profile ends; there the
profile is re-planned from the exact state.

The look-ahead window ends `look_ahead` segments after the current one with a stop the path must
be able to make; it moves with the path, so the path never actually stops there (except when
the window is a single block). While it can, the path also keeps the lowest cap the window's end
can have once the window moves on reachable there (`Constraints.window_floor`), so that it is
not braking to rest, too late to get down to that cap exactly, when it does.

Hard constraints (transition caps, axis caps, stops, zero acceleration at run boundaries) are
never violated; a feed ceiling (F × override) that a sudden override decrease makes unreachable
is approached as fast as the limits allow. Anything ruckig refuses is counted in `errors` and
answered with a brake (never expected; the closed-loop tests count them).
"""

from __future__ import annotations

from liftd.cnc.path.aims import Aims
from liftd.cnc.path.brakes import Brakes, rests_before
from liftd.cnc.path.constraints import (
    CAP_TOL,
    GATE_TOL,
    INF,
    SLACK_MARGIN,
    V_ROUND,
    Constraints,
)
from liftd.cnc.path.plan import CRUISE, EPS_S, SETTLE, Crossing, PathState, Plan, Primed
from liftd.cnc.path.shift import Replan, Shift
from liftd.cnc.path.table import PathTable
from liftd.cnc.path.targets import Targets
from liftd.cnc.path.velocity import (
    projected_velocity,
    ramp_crossing,
    ramp_distance,
)
from liftd.cnc.ruckig1 import Ruckig1


def _same(a: Plan, b: Plan | None) -> bool:
    """Two plans are the same profile toward the same goal (a re-plan from one state with one
    set of inputs is deterministic, to the bit)."""
    return (
        b is not None
        and a.goal == b.goal
        and a.t0 == b.t0
        and a.dur == b.dur
        and a.p_end == b.p_end
        and a.v_end == b.v_end
        and a.soft_from == b.soft_from
        and a.serves == b.serves
        and a.window == b.window
    )


class Tracker:
    """Path state (t, s, v, a, seg) over one table; drive with `advance(t, dt)`. It holds its
    parts: the constraint queries (`con`, which also holds the window's segment and the
    inputs), the motion state (`st`), the target profiles (`tg`), the brakes at once
    (`br`), the one brake through a feed drop (`aim`) and the re-plan toward the candidate
    that binds (`sh`); each part holds the ones it reads."""

    def __init__(
        self,
        table: PathTable,
        look_ahead: int,
        lift_stops: set[int] | None = None,
        acked: set[int] | None = None,
    ) -> None:
        self.con = Constraints(table, look_ahead, lift_stops, acked)
        self.st = PathState(table.s[0] if table.s else 0.0)
        self.tg = Targets(self.con, self.st)
        self.br = Brakes(self.con, self.st, self.tg)
        self.aim = Aims(self.con, self.st, self.tg)
        self.sh = Shift(self.con, self.st, self.tg, self.br)
        self.stopped_at: int | None = 0  # resting at this boundary until `resume`
        self.parked = False  # at rest under a hold, not at a stop
        self._passed: Plan | None = None  # the target plan of the boundary just passed
        self._event = True  # the next re-plan is an event's (`set_state`): `Profiles._unpin`

    # -- the state its users read -------------------------------------------------------------
    @property
    def t(self) -> float:
        return self.st.t

    @property
    def s(self) -> float:
        return self.st.s

    @property
    def v(self) -> float:
        return self.st.v

    @property
    def a(self) -> float:
        return self.st.a

    @property
    def plan(self) -> Plan | None:
        return self.st.plan

    @property
    def errors(self) -> int:
        return self.st.errors

    @property
    def last_error(self) -> str:
        return self.st.last_error

    @property
    def seg(self) -> int:
        return self.con.seg

    @property
    def ov(self) -> float:
        return self.con.ov

    @property
    def hold(self) -> bool:
        return self.con.hold

    @property
    def calc(self) -> Ruckig1:
        return self.tg.pf.calc  # its solves are counted (`Ruckig1.calls`)

    @property
    def tb(self) -> PathTable:
        return self.con.tb

    @property
    def look_ahead(self) -> int:
        return self.con.look_ahead

    @property
    def window_end(self) -> int:
        return self.con.window_end

    # -- control --------------------------------------------------------------------------------
    def set_state(
        self, t: float, s: float, v: float, a: float, seg: int, stopped_at: int | None
    ) -> None:
        self.st.t, self.st.s, self.st.v, self.st.a, self.con.seg = t, s, v, a, seg
        self.stopped_at = stopped_at
        self.con.recheck(stops=True)  # the stop sets may have changed
        self.parked = stopped_at is None and self.con.hold and v == 0.0 and a == 0.0
        self.st.plan = None
        self._passed = None  # planned for another state: not to be kept (`_replan`)
        self._event = True

    def set_inputs(self, ov: float, hold: bool) -> None:
        """Override (fraction) and feed hold. Override 0 acts as a hold; the caps keep the last
        override above 0 (a stopping path does not make every corner a stop)."""
        if self.con.set_inputs(ov, hold):
            self.st.plan = None
            self._passed = None  # planned under the old inputs: not to be kept
            # an event's re-plan (`Targets.settle`), also where no `set_state` follows: a
            # nominal run's tracker takes an override change as the path does (`nominal.py`)
            self._event = True
            if not self.con.hold:
                self.parked = False

    def resume(self, t: float) -> None:
        """Leave the stop where the path rests, at time t (its waiting actions are done)."""
        if self.stopped_at is None:
            return
        self.stopped_at = None
        self.st.t = max(self.st.t, t)
        self.st.plan = None

    def plan_leaving(self, dt: float) -> Primed | None:
        """While resting at a stop: the profile the path will leave it with, as `_replan`
        chooses it in the resume's cycle. From rest that choice depends on the state, the
        inputs and the stop sets, never on the time (the time only starts the profile:
        `take_leaving` sets it), so it can be made in a quiet cycle of the wait. None where
        the choice is not that pure function (a hold, the program's end, a kept profile of the
        boundary just passed, an error on the way): the resume then plans as before."""
        b = self.stopped_at
        if b is None or b >= self.con.n or self.con.hold or self.parked or self._passed is not None:
            return None
        errors, last, soft = self.st.errors, self.st.last_error, self.st.soft_from
        self.stopped_at = None
        self._event = True  # as the resume's re-plan (its `set_state`)
        self._replan(dt)
        plan = self.st.plan
        primed = None
        if plan is not None and self.st.errors == errors:
            primed = Primed(plan, self.st.soft_from, self.st.last_error)
        self.stopped_at, self.st.plan = b, None
        self.st.errors, self.st.last_error, self.st.soft_from = errors, last, soft
        return primed

    def take_leaving(self, primed: Primed) -> None:
        """Leave the stop (`resume` done) with the profile `plan_leaving` made for it."""
        plan = primed.plan
        plan.t0 = self.st.t
        self.st.plan = plan
        self._passed = None
        self._event = False  # the primed profile is the event's re-plan
        self.st.soft_from = primed.soft_from
        self.st.last_error = primed.last_error

    # -- planning -------------------------------------------------------------------------------
    def _replan(self, dt: float, force: int | None = None) -> None:
        self.con.recheck()
        event, self._event = self._event, False
        if event:  # the state an input changed at (`Targets.gap_rule`)
            self.st.changed = (self.st.s, self.st.v, self.st.a)
        forced = force is not None  # a step would lose `force` (`advance`)
        passed, self._passed = self._passed, None
        # the profile in hand, where only the window moved on (`Profiles._undip`)
        held = self.st.plan if force is None else None
        tb = self.con.tb
        s, v, a, seg = self.st.s, self.st.v, self.st.a, self.con.seg
        a_max, j_max = self.con.limits(seg)
        ceiling = 0.0 if self.con.hold else tb.ceiling(seg if seg < tb.n else tb.n - 1, self.con.ov)
        w = self.con.window_end
        v_p = projected_velocity(v, a, j_max)
        best: tuple[int, float, float, bool] | None = None
        best_slack = INF
        reach = INF if force is not None else self.con.horizon(v, a, a_max, j_max, dt)
        for aimed in (held, passed):
            if aimed is not None and aimed.aim > seg:
                # inside an aimed profile: as far as its aim, or the re-plan plans for the
                # drop it passes braking with zero acceleration there, out of reach from the
                # aim's state (a forced re-plan's aim 5.6 mm before an M00, the next re-plan
                # without it: 7.0 mm/s in the jerk gap for a cap of 75, feeds seed 713)
                reach = max(reach, tb.s[aimed.aim] - s)
        cands = self.con.collect(s, seg, reach, keep=-1 if force is None else force)
        if force is not None and all(c[0] != force for c in cands):
            force = None  # not a constraint from here: the most binding one
        best_i = -1
        top = ceiling
        skip = -1
        for c in cands:
            b, s_c, cap, gate = c
            if b == force and not gate and v_p <= cap + V_ROUND and v <= cap + V_ROUND:
                # a forced one (the step would have passed it too fast) that cannot bind from
                # here is kept by not accelerating beyond it (it may be too near for zero
                # acceleration there, which it does not need); the others as always (a lower
                # cap 0.2 mm after it was lost to a cruise at its cap: issue 36, wide seed 95)
                top, force, skip = min(top, cap), None, b
        for i, c in enumerate(cands):
            b, s_c, cap, gate = c
            if (force is not None and b != force) or b == skip:
                continue
            if not gate and v_p <= cap + V_ROUND and v <= cap + V_ROUND:
                continue  # cannot bind from here
            if (
                not gate
                and v_p <= cap + V_ROUND
                and ramp_distance(v, a, j_max) > s_c - s
                and ramp_crossing(v, a, cap, j_max) <= s_c - s - SLACK_MARGIN
            ):
                # nor can one the path passes below its cap braking, still ramping its
                # deceleration out there (the ramp-out, the highest velocity any profile has,
                # crosses the cap before b): no profile gets above the cap before b, and zero
                # acceleration at b, its target, is out of reach (a feed cap 0.2 mm ahead at
                # 41.4 mm/s and −2.6 m/s², ramped out at 32.8 after 0.24 mm: every target was
                # refused and the brake to rest at the window's end that moved on was kept,
                # the path stopped at the next boundary, drops seed 27)
                continue
            slack = s_c - s - self.con.need(v, a, cap, gate, a_max, j_max)
            if slack < best_slack:
                best, best_slack, best_i = c, slack, i
        if best is None:
            self.tg.cruise(top, a_max, j_max, w)
            return
        b, s_c, _, gate = best
        if self.con.hold and rests_before(cands, s, v, a, s_c, a_max, j_max):
            # a feed hold brakes as hard as it may (issue 36, wide seeds 181 and 285): a
            # profile to rest *at* b, time-optimal to b, reached b 5 ms before the plan without
            # the hold that braked to b's cap, and Z, which takes a hold for a later arrival,
            # landed late; the brake is behind every other profile at every moment
            self.tg.cruise(0.0, a_max, j_max, w)
            return
        if (
            force is None
            and not self.con.hold
            and (
                v_p > ceiling * (1.0 + CAP_TOL) + V_ROUND
                or (v > ceiling * (1.0 + CAP_TOL) + V_ROUND and v_p >= ceiling * (1.0 - CAP_TOL))
            )
            and (
                self.br.brake_first(cands, ceiling, a_max, j_max, w)
                or self.br.brake_down(cands, ceiling, a_max, j_max, w)
            )
        ):
            # an override drop: brake at once (known deviation 10 of docs/geo-core.md); also
            # from inside such a brake to a block's cap, re-planned at the block, v_p at the
            # cap (the target profile, with v_max = v there, braked below the cap and sped up
            # again: 9.4 mm/s in a block of 5.56 after an override drop to 10 %, feeds seed
            # 188), not where v_p is below it (from there a brake to the ceiling with zero
            # acceleration goes below it first and comes back: the target profile stays)
            return
        cap = self.con.target_cap(cands, best_i)
        if (
            not gate
            and not self.con.hold
            and skip < 0
            and cap < cands[best_i][2] * (1.0 - CAP_TOL)
            and self.aim.through(
                cands, best_i, v, a, v_p, ceiling, a_max, j_max, w, passed, held, event
            )
        ):
            return  # one brake through a feed drop a later cap lowers (known deviation 8)
        target = self.tg.boundary_target(
            cands, best_i, cap, v, a, v_p, ceiling, a_max, j_max, w,
            self.tg.gap_rule(b, cands[best_i][2]),
        )  # fmt: skip
        if (
            not gate
            and not self.con.hold
            and skip < 0
            and cap >= cands[best_i][2] * (1.0 - CAP_TOL)
            and self.aim.gap_state(cands, best_i, target, v_p, ceiling, a_max, j_max, w)
        ):
            return  # a feed drop's own cap in the jerk gap: passed at its cap, braking
        self.sh.toward(
            Replan(s, v, a, seg, v_p, a_max, j_max, ceiling, w, dt, forced, event, passed, held),
            cands, best_i, cap, target, skip, top,
        )  # fmt: skip

    # -- motion ---------------------------------------------------------------------------------
    def advance(self, t_new: float, dt: float) -> list[Crossing]:
        """Move to time t_new; the boundaries reached on the way that have actions, or where the
        path stops, with their exact times."""
        out: list[Crossing] = []
        tb = self.con.tb
        n = self.con.n
        forced = 0
        for _ in range(100_000):  # bounded: each pass ends the step, or at a boundary / plan end
            if self.stopped_at is not None or self.st.t >= t_new:
                return out
            if self.parked:
                self.st.t = t_new  # holding at rest: time goes on
                return out
            if self.con.hold and self.st.v == 0.0 and self.st.a == 0.0:
                self.parked = True
                self.st.t = t_new
                return out
            plan = self.st.plan
            if plan is None or (plan.goal >= 0 and plan.window != self.con.window_end):
                self._replan(dt)
                plan = self.st.plan
                assert plan is not None
            t_end = t_new
            if plan.goal != CRUISE and plan.t0 + plan.dur < t_end:
                t_end = plan.t0 + plan.dur  # the goal is reached inside this step
            s1, v1, a1 = plan.at(t_end)
            w = self.con.window_end
            cut = -1
            b = self.con.seg + 1
            while b <= n and s1 >= tb.s[b] - EPS_S:
                if b == plan.goal:  # reached when its profile ends, exactly in its goal state
                    if plan.t0 + plan.dur <= t_end:
                        cut = b
                    break
                if tb.replan[b] or b == w or b in self.con.lift_stops:
                    cut = b
                    break
                b += 1
            if cut >= 0 and cut == plan.goal:
                t_end = plan.t0 + plan.dur
                s1, v1, a1 = tb.s[cut], plan.v_end, plan.a_end
                seg1 = cut
            elif cut >= 0:
                t_end = min(max(plan.time_at(tb.s[cut], t_end), self.st.t), t_end)
                _, v1, a1 = plan.at(t_end)
                s1 = tb.s[cut]
                seg1 = cut
            else:
                seg1 = b - 1
                if b <= n and b == plan.goal and s1 > tb.s[b]:
                    s1 = tb.s[b]  # not there before the profile ends (rounding of its tail)
            v1 = max(v1, 0.0)
            if forced < 4:
                violated = None
                # the soft range as `violated` reads it: up to the boundary the plan keeps
                # (for a brake at once its `serves`: the caps a brake past lost caps passes,
                # read as hard at the cut, forced re-plans toward them, each refused, a
                # last-resort brake each: override 100 → 60 % at 172 mm/s 0.9 mm before a
                # feed drop, feeds seed 928)
                if (
                    cut >= 0
                    and cut != plan.serves
                    and not self.con.passable(cut, v1, a1, w, plan.soft_from <= cut < plan.keeps)
                ):
                    violated = cut  # the step ends on a constraint it does not keep
                if violated is None:
                    violated = self.con.violated(
                        s1, v1, a1, seg1, dt, plan.serves, plan.soft_from, plan.aim
                    )
                if violated is None and plan.goal >= 0:
                    violated = self.con.window_end_lost(
                        plan.goal, plan.v_end, self.st.s, self.st.v, self.st.a, s1, v1, a1, seg1
                    )
                if violated is not None:
                    forced += 1
                    # the window end seen from the end state lies beyond the one seen now
                    self._replan(dt, force=min(violated, self.con.window_end))
                    if forced >= 2 and _same(plan, self.st.plan):
                        # the profile the step just refused, again, from a forced re-plan
                        # whose inputs the next one shares (the kept profiles and the event
                        # were taken by the first): the next ones would repeat it, and the
                        # step takes it as after the fourth (feeds seed 5: four identical
                        # re-plans a step, twice in 25 ms after an override drop to 20 %)
                        forced = 4
                    continue
            self._commit(t_end, s1, v1, a1, seg1, cut, plan, out)
            forced = 0
            if cut >= 0:
                self._arrive(cut, out)
            elif plan.goal != CRUISE and self.st.t >= plan.t0 + plan.dur:
                self.st.plan = None  # a goal reached between boundaries: plan the next one
        self.tg.count("advance did not converge")
        return out

    def _commit(
        self, t: float, s: float, v: float, a: float, seg: int, cut: int, plan: Plan,
        out: list[Crossing],
    ) -> None:  # fmt: skip
        """Move the state to (t, s, v, a); report the boundaries with actions passed on the way
        (the boundary the step was cut at is reported by `_arrive`)."""
        tb = self.con.tb
        for b in range(self.con.seg + 1, seg + 1):
            if b != cut and tb.needs_time[b]:
                t_b = plan.time_at(tb.s[b], t)
                _, v_b, a_b = plan.at(t_b)
                out.append(Crossing(b, t_b, False, max(v_b, 0.0), a_b))
        self.st.t, self.st.s, self.st.v, self.st.a = t, s, v, a
        self.con.seg = max(self.con.seg, seg)

    def _arrive(self, b: int, out: list[Crossing]) -> None:
        """The step ended exactly at boundary b: stop there, or check it and go on."""
        tb = self.con.tb
        t, v, a = self.st.t, self.st.v, self.st.a
        w = self.con.window_end
        plan = self.st.plan
        # a plan that keeps a boundary beyond b (a target, a brake through): kept in case no
        # new profile from here is accepted (`_replan`, `Targets.settle`'s last resort)
        # (or a brake at once still braking: `Targets.settle`)
        self._passed = (
            plan
            if plan is not None
            and (plan.keeps > b or (plan.goal == SETTLE and t < plan.t0 + plan.dur))
            else None
        )
        self.st.plan = None
        if (
            plan is not None
            and (plan.goal > b or (plan.goal == SETTLE and plan.serves > b))
            and a < 0.0
            and not tb.gate[b]
            and not self.con.is_stop(b)
            and b != w
            and self.con.passable(b, v, a, w)
        ):
            # braking toward a goal beyond a boundary it keeps (a feed change, a higher
            # ceiling): the profile in hand is still the time-optimal one, and a new one from
            # inside its brake, which has no slack left, may find the exact brake a few 10 nm
            # too long and dip below the goal's velocity (ruckig brakes below it and comes
            # back: issue 36, 5 mm/s after a brake from 141 mm/s went down to 3). So is the
            # brake below a feed cap beyond b (`Brakes.dip_through`): dropped at a higher
            # feed drop before it, the re-plan from inside that brake was refused and the
            # path braked to rest (a review found: F24000 -> F7200 -> F2400 on 0.1 mm blocks)
            self.st.plan = plan
        if self.con.is_stop(b):
            if v > CAP_TOL:
                self.tg.count(f"passed the stop at boundary {b} at {v:.6g} m/s")
            else:
                self.st.v = self.st.a = 0.0
                self.con.seg = b if b < tb.n else tb.n
                self.stopped_at = b
                out.append(Crossing(b, t, True, 0.0, 0.0))
                return
        if b == w and v <= CAP_TOL:
            # the end of the look-ahead window: it moves on at once
            self.st.v = self.st.a = v = a = 0.0
        hard = min(tb.point_cap[b], tb.cap[b]) if b < tb.n else 0.0
        if v > hard * (1.0 + CAP_TOL) + 1e-12:
            self.tg.count(f"boundary {b} reached at {v:.9g} m/s above its cap {hard:.9g}")
        if tb.gate[b] and abs(a) > GATE_TOL:
            self.tg.count(f"run boundary {b} reached with acceleration {a:.3g} m/s²")
        elif tb.gate[b]:
            self.st.a = a = 0.0
        if tb.gate[b] and self.st.changed is not None:
            # after an input change, what lies beyond a run boundary is judged from there
            # (zero acceleration: `Targets.gap_rule`)
            self.st.changed = (self.st.s, v, 0.0)
        self.con.seg = b if b < tb.n else tb.n
        if tb.needs_time[b]:
            out.append(Crossing(b, t, False, v, a))
