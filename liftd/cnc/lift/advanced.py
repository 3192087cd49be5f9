"""Advanced Lifting (time-based, in the GEO cycle): the highest lift that still lands on time.

Design and measurements: reference/lift-algorithm.md §3. Each cycle, with the remaining path
time T_rem until LIFT_END:

* UP: rise time-optimally toward POS_LIMIT as long as the time-optimal descent from the *next*
  state still fits into T_rem − dt. When it no longer fits, the switch time τ ∈ [0, dt) is found
  inside the cycle (bisection on τ + t_min(state(τ) → POS) = T_rem): deciding only at cycle
  boundaries loses up to 12 % of the height on short lifts.
* DOWN: follow the descent plan; re-plan only when T_rem no longer matches the plan (re-planning
  a stretched profile every cycle is not time-consistent); go back to UP when T_rem grew by more
  than two cycles (override lowered).
* T_rem = inf (feed hold): UP never switches, so Z rises toward POS_LIMIT and holds there.

Coordinates are mirrored for DOWN (the lift goes toward the negative software limit): inside
this class q = sign·z, so "up" is always +q. POS_LIMIT is enforced by construction (targets are
never above it) and checked on every descent plan (community ruckig ignores position limits).
"""

from __future__ import annotations

import enum
from collections.abc import Callable
from typing import Final

from ruckig import Trajectory

from liftd.cnc.lift.profile import LiftProfiles, ProfileError, position_range, state_at
from liftd.cnc.ruckig1 import Evaluator, Phases

INF = float("inf")
# the exact remaining path time, when the generator was given a lower bound of it and its
# decision depends on the difference (the bound is enough while Z rises with time to spare)
Refine = Callable[[], float]
POS_TOL = 1e-7  # 0.1 µm: tolerance of the position checks
TIME_TOL = 1e-9  # s


class Phase(enum.IntEnum):
    IDLE = 0
    UP = 1
    DOWN = 2
    DONE = 3  # at the target, at rest
    DIRECT = 4  # time-optimal straight to the target (suppressed, or POS beyond POS_LIMIT)
    HOLD_LIMIT = 5  # program error inside the range: rise to POS_LIMIT and stay


# The members as C statics of the compiled module: `Phase.UP` is a dict and a type lookup
# (~80 ns), several a lift cycle.
IDLE: Final = Phase.IDLE
UP: Final = Phase.UP
DOWN: Final = Phase.DOWN
DONE: Final = Phase.DONE
DIRECT: Final = Phase.DIRECT
HOLD_LIMIT: Final = Phase.HOLD_LIMIT


class FirstRise:
    """A range's rise prepared before the run (`GeoProgram.rises`): the profile from q0 at
    rest toward max(POS_LIMIT, POS), in the generator's coordinates."""

    __slots__ = ("ev", "phases", "q0", "traj")

    def __init__(self, q0: float, traj: Trajectory) -> None:
        self.q0 = q0
        self.traj = traj
        # read here, in preparation: the cycles evaluate natively (its dur is traj.duration
        # without a binding call)
        self.phases = Phases(traj)
        self.ev = Evaluator(traj, self.phases)  # stateless given its phases: shared by runs


class FirstStep:
    """What a range's first rising cycle computes from its prepared rise, computed in a cycle
    before it (`AdvancedLift.prime`, once the path's crossing of LIFT_START is committed): the
    state the rise reaches after `dt` and whether the time-optimal descent from there fits.
    Its one ruckig solve was the costliest part of a lift start's cycle (38 µs of ~180 with
    cold caches, bench_step.py --cold)."""

    __slots__ = ("dt", "fits", "limit", "need", "nxt", "rise", "target")

    def __init__(self, rise: Trajectory, target: float, limit: float, dt: float,
                 nxt: tuple[float, float, float], need: float, fits: bool) -> None:  # fmt: skip
        self.rise = rise
        self.target = target
        self.limit = limit
        self.dt = dt
        self.nxt = nxt
        self.need = need
        self.fits = fits


class AdvancedLift:
    """The set-point generator of one lift range. Pure; times are absolute seconds."""

    def __init__(self, profiles: LiftProfiles, cycle: float) -> None:
        self.prof = profiles
        self.cycle = cycle
        self.phase = IDLE
        self.sign = 1.0
        self.t = 0.0
        self.q = self.v = self.a = 0.0
        self.target = 0.0  # POS in q coordinates
        self.limit = 0.0  # POS_LIMIT in q coordinates
        self.plan: Trajectory | None = None
        self.plan_t0 = 0.0
        self.t_need = 0.0  # time-optimal descent time from the last output state
        self.late = 0.0  # > 0: Z needs this much longer than the path gives it
        self.fallbacks = 0  # ruckig failures answered with the safe move
        self.peak = -INF  # highest q reached (for the summary)
        self.landed = 0.0  # exact time Z reached the target
        self.rise: Trajectory | None = None  # last rise profile (fallback)
        self.rise_ev = Evaluator(Trajectory(1))  # the rise's states, read natively
        self.plan_ev = Evaluator(Trajectory(1))  # the plan's (re-made when the plan changes)
        self.rise_t0 = 0.0
        self.rise_dur = 0.0
        # the state is the rise's at (t − rise_t0): the next cycle follows it without a new
        # profile (from a state on a time-optimal profile toward the same goal, ruckig would
        # plan its own remainder again; one ruckig call per rising cycle saved)
        self._on_rise = False
        # the descent from the next rising state is asked only for its duration and extent:
        # each rising cycle solves it into this one trajectory (no allocation per cycle)
        self._desc = Trajectory(1)
        self.first: FirstStep | None = None  # the next range's first rising cycle, primed
        self._first_desc = Trajectory(1)

    # -- lifecycle -------------------------------------------------------------------------------
    def start(
        self,
        t: float,
        z: float,
        vz: float,
        az: float,
        target: float,
        limit: float,
        down: bool,
        direct: bool,
        rise: FirstRise | None = None,
    ) -> None:
        """Start a range from (z, vz, az) at t. `rise`: the range's prepared rise, followed
        from here when Z starts exactly where and as it was prepared for (at rest)."""
        self.sign = -1.0 if down else 1.0
        s = self.sign
        self.t = t
        self.q, self.v, self.a = s * z, s * vz, s * az
        self.target = s * target
        self.limit = s * limit
        self.late = 0.0
        self.peak = self.q
        self.plan = None
        self._on_rise = False
        if direct:
            self._plan_direct(t)
            self.phase = DIRECT
        else:
            self.phase = UP
            if rise is not None and rise.q0 == self.q and self.v == 0.0 and self.a == 0.0:
                self.rise, self.rise_t0, self.rise_dur = rise.traj, t, rise.phases.dur
                self.rise_ev = rise.ev
                self._on_rise = True  # the state is the rise's at its start

    def prime(self, rise: FirstRise, target: float, limit: float, down: bool, dt: float) -> None:
        """Compute ahead the first rising cycle of a range that will start on `rise` (at rest at
        its start) `dt` before the end of its cycle, toward POS `target` under `limit` (z
        coordinates): that cycle then takes it from `first` instead of solving it. Pure with
        respect to the running lift: only `first` changes."""
        s = -1.0 if down else 1.0
        q_target, q_limit = s * target, s * limit
        goal = max(q_limit, q_target)
        nxt = _rise_next(rise.ev, 0.0, dt, rise.phases.dur, goal)
        desc = self.prof.to_rest(nxt[0], nxt[1], nxt[2], q_target, into=self._first_desc)
        fits = _fits(desc, nxt[0], q_limit, q_target)
        self.first = FirstStep(rise.traj, q_target, q_limit, dt, nxt, desc.duration, fits)

    def rise_and_hold(self, t: float, start: float) -> None:
        """Program error inside the range: go to the maximum lift height and stay there
        (vendor §2.1.3 case 2: "auf die max. Abhebehöhe positioniert"; §2.4: "bleibt an der
        angegebenen maximalen Abhebehöhe stehen"). That height is POS_LIMIT, raised to the
        start (`start`, axis coordinates) or POS where one lies beyond it (§2.1.1: the limit
        "wird ... auf das Maximum von Start und Zielposition erhöht"), or where Z already is
        if that is higher: an error never moves Z toward the part (issue 37 item 1: with POS
        above POS_LIMIT, Z came down from POS to POS_LIMIT).
        A moving Z's plan starts at its last output time, where its state is: from t (the
        path's stop before the erroneous block, up to a cycle away) it lost or gained that
        much motion in one cycle (40× its acceleration limit). A Z at rest starts at t."""
        top = max(self.limit, self.target)
        self.target = max(top, max(self.sign * start, self.q))  # noqa: PLW3301
        self._on_rise = False
        self._plan_direct(max(self.t, t) if self.v == 0.0 and self.a == 0.0 else self.t)
        self.phase = HOLD_LIMIT

    @property
    def z(self) -> float:
        return self.sign * self.q

    @property
    def vz(self) -> float:
        return self.sign * self.v

    @property
    def az(self) -> float:
        return self.sign * self.a

    def _at_target(self) -> bool:
        return self.q == self.target and self.v == 0.0 and self.a == 0.0

    @property
    def done(self) -> bool:
        return self.phase is DONE or (
            (self.phase is DIRECT or self.phase is HOLD_LIMIT)
            and self.plan is None
            and self._at_target()
        )

    # -- cycle ------------------------------------------------------------------------------------
    def step(self, t_new: float, t_rem: float, refine: Refine | None = None) -> None:
        """Advance from the last output time to t_new; t_rem is the remaining path time until
        LIFT_END measured at the last output time, or a lower bound of it that `refine()`
        makes exact: used as it is only to decide that Z may go on rising (if it may with
        less time, it may with more), refined for every other decision."""
        dt = t_new - self.t
        if dt <= 0.0:
            return
        on_rise, self._on_rise = self._on_rise, False
        if refine is not None and self.phase is not UP:
            t_rem, refine = refine(), None
        try:
            if self.phase is UP:
                self._up(dt, t_rem, on_rise, refine)
            elif self.phase is DOWN:
                self._down(dt, t_rem)
            elif self.phase is DIRECT or self.phase is HOLD_LIMIT:
                if self.plan is None and not self._at_target():
                    self._plan_direct(self.t)  # retry after a refused profile
                self._follow(t_new)
            elif self.phase is DONE and t_rem > 2.0 * self.cycle:
                self.phase = UP  # the path got slower after Z landed: rise again
                self._up(dt, t_rem)
        except ProfileError:
            self._fallback(t_new)
        self.t = t_new
        self.peak = max(self.peak, self.q)

    def _fallback(self, t_new: float) -> None:
        """Ruckig refused a profile: go time-optimally to the target; if even that is refused,
        keep following the last valid plan (a descent, or the rise toward POS_LIMIT, both within
        all limits) and try again next cycle. Counted in `fallbacks` (the guard reports it)."""
        self.fallbacks += 1
        try:
            self._plan_direct(self.t)
            self.phase = DIRECT
            self._follow(t_new)
            return
        except ProfileError:
            pass
        if self.plan is not None:
            self._follow(t_new)
        elif self.rise is not None:
            self._set(state_at(self.rise, t_new - self.rise_t0))
        self.phase = DIRECT if self.plan is None else self.phase

    def _set(self, state: tuple[float, float, float]) -> None:
        self.q, self.v, self.a = state

    def _plan_direct(self, t: float) -> None:
        if abs(self.q - self.target) <= 1e-12 and abs(self.v) < 1e-12 and abs(self.a) < 1e-12:
            self.q, self.v, self.a = self.target, 0.0, 0.0
            self.plan = None
            self.landed = t
            return
        self.plan = self.prof.to_rest(self.q, self.v, self.a, self.target)
        self.plan_t0 = t
        self.t_need = self.plan.duration

    def _follow(self, t_new: float) -> None:
        plan = self.plan
        if plan is None:
            return
        ev = self.plan_ev
        if ev.traj is not plan:
            ev = self.plan_ev = Evaluator(plan)
        local = t_new - self.plan_t0
        if local >= ev.dur - TIME_TOL:  # within 1 ns of the end: rounding of t
            self.q, self.v, self.a = self.target, 0.0, 0.0  # snap (ruckig #160 regime)
            self.landed = self.plan_t0 + ev.dur
            self.plan = None
            if self.phase is DOWN:
                self.phase = DONE
            return
        self._set(ev.at(local))

    def _descent_fits(self, traj: Trajectory, start_q: float) -> bool:
        return _fits(traj, start_q, self.limit, self.target)

    def _up(
        self, dt: float, t_rem: float, on_rise: bool = False, refine: Refine | None = None
    ) -> None:
        if on_rise and self.rise is not None:
            up = self.rise
        else:
            up = self.prof.to_rest(self.q, self.v, self.a, max(self.limit, self.target))
            self.rise, self.rise_t0, self.rise_dur = up, self.t, up.duration
            self.rise_ev = Evaluator(up)
        base = self.t - self.rise_t0  # the rise's local time of the current state
        first = self.first
        if (
            first is not None
            and base == 0.0
            and first.rise is up
            and first.dt == dt
            and first.target == self.target
            and first.limit == self.limit
        ):
            nxt, need, fits = first.nxt, first.need, first.fits  # primed: the same solve
        else:
            nxt = _rise_next(self.rise_ev, base, dt, self.rise_dur, max(self.limit, self.target))
            desc = self.prof.to_rest(nxt[0], nxt[1], nxt[2], self.target, into=self._desc)
            need, fits = desc.duration, t_rem != INF and self._descent_fits(desc, nxt[0])
        self.first = None
        self.t_need = need  # also while holding: the restart is limited by it
        if t_rem == INF:
            self._set(nxt)
            self._on_rise = True
            return
        if need <= t_rem - dt + TIME_TOL and fits:
            self._set(nxt)
            self._on_rise = True
            return
        if refine is not None:  # t_rem was a lower bound: decide on the exact time
            exact = refine()
            if exact != t_rem:
                t_rem = exact
                if t_rem == INF or (need <= t_rem - dt + TIME_TOL and fits):
                    self._set(nxt)
                    self._on_rise = True
                    return
        # The switch lies in this cycle (or is overdue): find τ ∈ [0, dt).
        now = self.prof.to_rest(self.q, self.v, self.a, self.target)
        if now.duration >= t_rem - TIME_TOL:
            tau, plan = 0.0, now  # overdue: descend time-optimally now
        elif fits:
            tau, plan = self._switch_time(up, base, now, need, dt, t_rem)
        else:  # the limit, not the time, ends the rise: bisection on both conditions
            lo, hi = 0.0, dt
            plan = now
            ev = self._rise_states(up)
            for _ in range(30):
                mid = 0.5 * (lo + hi)
                s = ev.at(base + mid)
                trial = self.prof.to_rest(s[0], s[1], s[2], self.target)
                if mid + trial.duration <= t_rem and self._descent_fits(trial, s[0]):
                    lo, plan = mid, trial
                else:
                    hi = mid
            tau = lo
        self.plan = plan
        self.plan_t0 = self.t + tau
        self.late = max(0.0, tau + plan.duration - t_rem)
        self.phase = DOWN
        self._follow(self.t + dt)

    def _rise_states(self, up: Trajectory) -> Evaluator:
        """The states of the rise `up` (the one the rising cycles evaluate natively already):
        the switch search reads ~5 of them, ~1 µs each through the binding."""
        ev = self.rise_ev
        return ev if ev.traj is up else Evaluator(up)

    def _switch_time(
        self, up: Trajectory, base: float, now: Trajectory, need: float, dt: float,
        t_rem: float,
    ) -> tuple[float, Trajectory]:  # fmt: skip
        """Root of f(τ) = τ + t_min(state(τ) → POS) − T_rem on [0, dt] by regula falsi (Illinois):
        f(0) < 0 < f(dt), f is smooth and increasing; ~5 ruckig calls instead of ~30 for
        bisection. Returns the last τ with f ≤ 0 (lands at most 1e-11 s early) and its plan.
        The rise's state at τ is `up` at base + τ; `need` is the descent time from τ = dt."""
        lo, f_lo, plan = 0.0, now.duration - t_rem, now
        hi, f_hi = dt, dt + need - t_rem
        side = 0
        ev = self._rise_states(up)
        for _ in range(40):
            if f_lo > -1e-11 or hi - lo < 1e-13:
                break
            mid = (lo * f_hi - hi * f_lo) / (f_hi - f_lo)
            if not lo < mid < hi:
                mid = 0.5 * (lo + hi)
            s = ev.at(base + mid)
            trial = self.prof.to_rest(s[0], s[1], s[2], self.target)
            f_mid = mid + trial.duration - t_rem
            if f_mid <= 0.0:
                lo, f_lo, plan = mid, f_mid, trial
                if side == -1:
                    f_hi *= 0.5
                side = -1
            else:
                hi, f_hi = mid, f_mid
                if side == 1:
                    f_lo *= 0.5
                side = 1
        return lo, plan

    def _down(self, dt: float, t_rem: float) -> None:
        assert self.plan is not None
        remaining = self.plan_t0 + self.plan.duration - self.t
        if t_rem == INF or t_rem > remaining + 2.0 * self.cycle:
            self.phase = UP  # more time than planned: use it to rise again
            self.plan = None
            self._up(dt, t_rem)
            return
        if abs(t_rem - remaining) > TIME_TOL:
            self._replan_down(t_rem, remaining)
        self._follow(self.t + dt)

    def _replan_down(self, t_rem: float, remaining: float) -> None:
        """T_rem changed while descending: stretch the descent to T_rem if that stays within
        [target, POS_LIMIT], else time-optimal (then `late` says how long the path must wait).
        With more time than the descent in hand needs, that descent is kept when no profile
        from here does better: near its end (Z nanometres from POS, still decelerating)
        ruckig's "time-optimal" one may take longer than the rest of the plan that got Z there
        (stress seed 174: 1.45 ms instead of 0.31 ms, 7 µs after the arrival time grew when
        the lower bound of an event's cycle became exact)."""
        best = self.prof.to_rest(self.q, self.v, self.a, self.target)
        if best.duration < t_rem - TIME_TOL:
            try:
                stretched = self.prof.to_rest(self.q, self.v, self.a, self.target, t_rem)
                if stretched.duration <= t_rem + TIME_TOL and self._descent_fits(stretched, self.q):
                    best = stretched
            except ProfileError:
                pass
        elif remaining <= t_rem + TIME_TOL and self.plan is not None:
            self.late = 0.0
            return  # the descent in hand lands in time; no new one would
        self.late = max(0.0, best.duration - t_rem)
        self.plan = best
        self.plan_t0 = self.t


def _rise_next(
    ev: Evaluator, base: float, dt: float, dur: float, goal: float
) -> tuple[float, float, float]:
    """The state a rise (evaluated by `ev`, `dur` long, toward `goal`) reaches at base + dt."""
    if base + dt >= dur - TIME_TOL:
        return (goal, 0.0, 0.0)  # at rest at the goal (ruckig's end may round a bit past it)
    nxt = ev.at(base + dt)
    if nxt[0] > goal:
        return (goal, nxt[1], nxt[2])
    return nxt


def _fits(traj: Trajectory, start_q: float, limit: float, target: float) -> bool:
    """Whether a descent from start_q stays within [min(start, target), limit]."""
    lo, hi = position_range(traj)
    return hi <= limit + POS_TOL and lo >= min(start_q, target) - POS_TOL
