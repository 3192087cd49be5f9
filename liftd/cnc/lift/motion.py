"""How the lift axis moves inside one lift range: two methods behind one protocol.

* `TimeBasedLift` (Advanced Lifting, and every range without path motion): the set-point
  generator of `advanced.py` planned against the path's remaining time, checked by the guard,
  with Advanced Lifting's override rules (vendor §2.5).
* `CoupledLift` (path-based Lifting): z = f(s) planned in path preparation (`path_based.py`),
  following the path position; no override rule of its own (the method's weakness: Z is
  overloaded instead, which the acceleration monitor reports).

The GEO task holds the active one; it never asks which kind it is.
"""

from __future__ import annotations

from abc import ABC, abstractmethod

from liftd.cnc.lift.advanced import (
    DIRECT,
    DONE,
    DOWN,
    HOLD_LIMIT,
    IDLE,
    UP,
    AdvancedLift,
    FirstRise,
    Refine,
)
from liftd.cnc.lift.guard import GuardFinding, LiftGuard
from liftd.cnc.lift.path_based import RangePlan
from liftd.cnc.lift.profile import ProfileError
from liftd.cnc.lift.ranges import LiftRange
from liftd.cnc.path.interpolator import Interpolator
from liftd.cnc.plc import MAX_OVERRIDE
from liftd.cnc.ruckig1 import Phases, travel_after
from liftd.cnc.snapshot import LiftPhase

INF = float("inf")
MIN_LIFT_OVERRIDE = 0.01  # below this, the path waits for Z at the lift's horizon instead
OVERRIDE_TRIALS = 6  # lower-bound evaluations to find the highest override Z still allows
# While a cut request stands, a higher grant is taken only this far (5 % of the programmed feed)
# above the override in effect: each grant is a re-plan of the path, and the verdict creeps up
# as the path advances (the demo, 200 % written while Z rises: 16 re-plans in 16 cycles for
# 145.5 → 148.9 %, then a `lift.override_limited` event in each of the next 100 cycles; with
# 1 % steps 7 re-plans for 145.8 → 152.7 %, with 5 % steps 2 for 145.8 → 150.8 %)
OVERRIDE_STEP = 0.05


class OverrideVerdict:
    """What the lift makes of a requested override (a plain class: native in the compiled
    core, where a dataclass's generated __init__ is a Python frame in every lift cycle)."""

    __slots__ = ("limited", "override", "override_max", "path_waits")

    def __init__(
        self, override: float, override_max: float, limited: bool = False, path_waits: bool = False
    ) -> None:
        self.override = override  # in effect
        self.override_max = override_max  # the highest the lift accepts now (for the display)
        self.limited = limited  # an increase was cut (event lift.override_limited)
        self.path_waits = path_waits  # not even a crawl gives Z the time: the path waits at k


class LiftMotion(ABC):
    """The lift axis inside one range (positions in m, times absolute), as `TimeBasedLift` and
    `CoupledLift` move it. An abstract base class, not a Protocol: the compiled core calls a
    Protocol's methods as generic Python calls with boxed floats, a base class's through its
    vtable (about ten calls in every lift cycle); mypyc compiles an `abc.ABCMeta` class as a
    native one (https://mypyc.readthedocs.io/en/latest/native_classes.html, "Metaclasses")."""

    @property
    @abstractmethod
    def z(self) -> float: ...

    @property
    @abstractmethod
    def vz(self) -> float: ...

    @property
    @abstractmethod
    def az(self) -> float: ...

    @property
    @abstractmethod
    def t(self) -> float: ...

    @property
    @abstractmethod
    def landed(self) -> float: ...

    @property
    @abstractmethod
    def done(self) -> bool: ...

    @property
    @abstractmethod
    def phase(self) -> LiftPhase: ...

    @property
    @abstractmethod
    def uses_time(self) -> bool:
        """Whether `step` needs the remaining path time (else the path position)."""

    @abstractmethod
    def step(
        self,
        t_new: float,
        s: float,
        v: float,
        a: float,
        t_rem: float,
        override: float,
        refine: Refine | None = None,
    ) -> None:
        """Move to t_new (`t_rem`: the path's remaining time to the horizon, time-based, or a
        lower bound of it that `refine()` makes exact when the decision needs it; s, v, a:
        the path's state, coupled; `override`: in effect)."""

    @abstractmethod
    def needed_time(self) -> float: ...

    @abstractmethod
    def landing_time(self) -> float:
        """Time Z needs from its state now to be at POS: the descent in hand, or, while it
        rises, the time-optimal one from here (`BoundaryActions.z_lets_go`)."""

    def travel_left(self) -> float:
        """An upper bound of how far Z still moves before it is at rest at POS (inf where it
        is not on its way there by a plan)."""
        return INF

    @abstractmethod
    def resume_in_range(self, t: float) -> None: ...

    @abstractmethod
    def error_in_range(self, t: float) -> None: ...

    @abstractmethod
    def limit_override(
        self, ov_req: float, ov_eff: float, was_holding: bool, k: int, path: Interpolator
    ) -> OverrideVerdict: ...

    @abstractmethod
    def take_findings(self) -> list[GuardFinding]: ...


def stop_margin(vz: float, az: float, a: float, j: float) -> float:
    """An upper bound of the distance Z moves on, either way, before it stands, from velocity
    vz and acceleration az, braking at a_max within the jerk limit: an acceleration that still
    drives it on is first ramped to 0; one against the motion (a deceleration under way)
    reverses it before the jerk limit takes it back, so that excursion counts too."""
    push = az if vz > 0.0 else -az if vz < 0.0 else abs(az)  # along the motion
    return max(_run_on(abs(vz), push, a, j), _run_on(0.0, abs(az), a, j))


def _run_on(u: float, push: float, a: float, j: float) -> float:
    """The distance from speed u with `push` acceleration along it: ramp that to 0 at jerk j,
    then brake at a within j."""
    d1 = 0.0
    if push > 0.0 and j != INF:
        t1 = push / j
        d1 = u * t1 + 0.5 * push * t1 * t1
        u += 0.5 * push * push / j
    return d1 + u * u / (2.0 * a) + (u * a / j if j != INF else 0.0)


class TimeBasedLift(LiftMotion):
    """Advanced Lifting's generator for one range (docs/reference/design.md §4,
    docs/reference/lift-algorithm.md §3)."""

    def __init__(
        self,
        gen: AdvancedLift,
        guard: LiftGuard,
        rng: LiftRange,
        t: float,
        z: float,
        vz: float,
        az: float,
        rise: FirstRise | None = None,
    ) -> None:
        self.gen = gen
        self.guard = guard
        self.rng = rng
        spec = rng.start
        beyond = rng.beyond_limit or ((z < spec.pos_limit) if spec.down else (z > spec.pos_limit))
        direct = rng.suppressed or beyond
        gen.start(t, z, vz, az, spec.target, spec.pos_limit, spec.down, direct, rise)
        margin = stop_margin(vz, az, guard.axis.a_max, guard.axis.j_max)
        guard.arm(z, spec.target, spec.pos_limit, spec.down, direct, margin)
        self.ov_at_descent: float | None = None
        self.cut_request = -1.0  # the request the last verdict cut (-1: none stands)
        self.findings: list[GuardFinding] = []

    @property
    def uses_time(self) -> bool:
        return True

    @property
    def z(self) -> float:
        return self.gen.z

    @property
    def vz(self) -> float:
        return self.gen.vz

    @property
    def az(self) -> float:
        return self.gen.az

    @property
    def t(self) -> float:
        return self.gen.t

    @property
    def landed(self) -> float:
        return self.gen.landed

    @property
    def done(self) -> bool:
        return self.gen.done

    @property
    def phase(self) -> LiftPhase:
        return self.gen.phase

    def step(
        self,
        t_new: float,
        s: float,
        v: float,
        a: float,
        t_rem: float,
        override: float,
        refine: Refine | None = None,
    ) -> None:
        gen = self.gen
        was_down = gen.phase is DOWN
        gen.step(t_new, t_rem, refine)
        z, findings = self.guard.check(gen.z, gen.fallbacks)
        if findings:
            self.findings.extend(findings)
            if z != gen.z:
                # never expected: stop at the bound and go straight (time-optimally) to POS
                spec = self.rng.start
                gen.start(t_new, z, 0.0, 0.0, spec.target, spec.pos_limit, spec.down, True)
        if gen.phase is DOWN and not was_down:
            self.ov_at_descent = override  # the descent clamps the override to this
        elif gen.phase is UP:
            self.ov_at_descent = None

    def needed_time(self) -> float:
        gen = self.gen
        if gen.done:
            return 0.0
        if gen.phase is UP:
            return gen.t_need
        plan = gen.plan
        return 0.0 if plan is None else max(0.0, gen.plan_t0 + plan.duration - gen.t)

    def travel_left(self) -> float:
        gen = self.gen
        if gen.done:
            return 0.0
        plan = gen.plan
        if (gen.phase is not DOWN and gen.phase is not DIRECT) or plan is None:
            return INF  # (a DIRECT plan also ends at rest at POS)
        ev = gen.plan_ev
        phases = ev.phases if ev.traj is plan and ev.phases is not None else Phases(plan)
        return travel_after(phases, gen.t - gen.plan_t0)

    def landing_time(self) -> float:
        gen = self.gen
        if gen.phase is not UP:
            return self.needed_time()
        try:
            return float(gen.prof.to_rest(gen.q, gen.v, gen.a, gen.target).duration)
        except ProfileError:
            return self.needed_time()  # the descent from the next state: a cycle on

    def resume_in_range(self, t: float) -> None:
        """The path leaves a waiting point inside the range: lift again for the rest of it."""
        if self.rng.direct:
            return
        spec = self.rng.start
        gen = self.gen  # its state (z, vz, az) belongs to gen.t: never rewind it
        gen.start(gen.t, gen.z, gen.vz, gen.az, spec.target, spec.pos_limit, spec.down, False)

    def error_in_range(self, t: float) -> None:
        gen, spec = self.gen, self.rng.start
        gen.rise_and_hold(t, spec.z_start)
        # the bounds of a lift from where Z is to where it holds: a suppressed (direct)
        # range's were only its start and POS, and clamped Z there at full speed (bench_reset)
        margin = stop_margin(gen.vz, gen.az, self.guard.axis.a_max, self.guard.axis.j_max)
        hold = gen.sign * gen.target  # where it holds, in axis coordinates (DOWN: mirrored)
        self.guard.arm(gen.z, hold, spec.pos_limit, spec.down, False, margin)

    def take_findings(self) -> list[GuardFinding]:
        out, self.findings = self.findings, []
        return out

    def limit_override(
        self, ov_req: float, ov_eff: float, was_holding: bool, k: int, path: Interpolator
    ) -> OverrideVerdict:
        """Advanced Lifting's override rules (vendor §2.5, docs/reference/design.md §4): while Z
        descends the override is clamped to its value at descent start; while Z rises (or goes
        straight to POS) an increase, or a restart after feed hold, is accepted only as far as Z
        still lands on time; a decrease is always accepted. "Lands on time" is decided against a
        lower bound of the path's arrival at the horizon k at the candidate override (bounded work):
        granting an override that passes it can never make Z late. While a request that was
        cut stands, the verdict is re-examined every cycle but granted higher only in steps of
        OVERRIDE_STEP, one bound evaluation a cycle while the next step does not fit."""
        phase = self.gen.phase
        at_descent = self.ov_at_descent if phase is DOWN else None
        if at_descent is not None:
            ov_req = min(ov_req, at_descent)
        if ov_req != self.cut_request:
            self.cut_request = -1.0  # a new request (also the same one again after another)
        if phase is DONE or phase is HOLD_LIMIT or phase is IDLE:
            return OverrideVerdict(ov_req, MAX_OVERRIDE)
        if at_descent is not None and ov_req <= ov_eff and not was_holding:
            return OverrideVerdict(ov_req, at_descent)
        # (an increase back toward the descent's override is granted only as far as Z still
        # lands on time, as while it rises: a descent stretched to the later arrival of a lower
        # override lands after the path's arrival at the descent's own; wide seed 181, 65 µs,
        # issue 36)
        if k < 0:
            return OverrideVerdict(ov_req, MAX_OVERRIDE)
        t0 = path.t_state
        need = self.needed_time()
        ov_max = MAX_OVERRIDE
        arrival = path.arrival(k)
        if arrival != INF and need > 0.0:  # the headroom, for the display (ov ∝ 1/time)
            ov_max = min(MAX_OVERRIDE, ov_eff * (arrival - t0) / need)
        changing = ov_req > ov_eff or was_holding
        if not changing or path.stopped_at is not None or need <= 0.0:
            return OverrideVerdict(ov_req, ov_max)
        floor = 0.0 if was_holding else ov_eff
        if not was_holding and ov_req == self.cut_request and ov_eff >= MIN_LIFT_OVERRIDE:
            # the cut request stands: T(ov) falls with ov, so if the next step does not fit,
            # nothing higher does, and the override in effect stays (as when nothing changes)
            step = min(ov_eff + OVERRIDE_STEP, ov_req)
            if path.lower_bound(k, step) - t0 < need:
                return OverrideVerdict(ov_eff, ov_eff, limited=True)
            floor = step  # known to fit: the search below only looks above it
        span = path.lower_bound(k, ov_req) - t0
        if span >= need:
            self.cut_request = -1.0
            return OverrideVerdict(ov_req, ov_max)
        # T(ov) falls about as 1/ov: aim at T = need, then bisect between the highest override
        # known to fit (or the floor) and the lowest known not to; the floor when none fits
        lo, hi = floor, ov_req
        candidate = ov_req * span / need if span > 0.0 else floor
        for _ in range(OVERRIDE_TRIALS):
            if not lo < candidate < hi:
                candidate = 0.5 * (lo + hi)
            if path.lower_bound(k, candidate) - t0 >= need:
                lo = candidate
            else:
                hi = candidate
            candidate = 0.5 * (lo + hi)
        granted = lo
        if granted < MIN_LIFT_OVERRIDE:
            # crawling would not do (e.g. a feed hold ended just before LIFT_END): the path
            # stops there and waits for Z, as it does for a lift without path motion
            self.cut_request = -1.0
            return OverrideVerdict(ov_req, MAX_OVERRIDE, path_waits=True)
        self.cut_request = ov_req if granted < ov_req else -1.0
        return OverrideVerdict(granted, granted, limited=granted < ov_req)


class CoupledLift(LiftMotion):
    """Path-based Lifting for one range: Z at z(s) of the path position."""

    def __init__(
        self,
        plan: RangePlan,
        guard: LiftGuard,
        rng: LiftRange,
        t: float,
        z: float,
        vz: float,
        az: float,
    ) -> None:
        self.plan = plan
        self.guard = guard
        self.rng = rng
        spec = rng.start
        guard.arm(z, spec.target, spec.pos_limit, spec.down, rng.direct, 0.0)
        self._z, self._vz, self._az, self._t = z, vz, az, t
        self._landed = t
        self.findings: list[GuardFinding] = []

    @property
    def uses_time(self) -> bool:
        return False

    @property
    def z(self) -> float:
        return self._z

    @property
    def vz(self) -> float:
        return self._vz

    @property
    def az(self) -> float:
        return self._az

    @property
    def t(self) -> float:
        return self._t

    @property
    def landed(self) -> float:
        return self._landed

    @property
    def phase(self) -> LiftPhase:
        return LiftPhase.COUPLED

    @property
    def done(self) -> bool:
        return abs(self._z - self.rng.start.target) <= 1e-12 and self._vz == 0.0

    def step(
        self,
        t_new: float,
        s: float,
        v: float,
        a: float,
        t_rem: float,
        override: float,
        refine: Refine | None = None,
    ) -> None:
        z, dz, ddz = self.plan.state(s)
        self._t, self._vz, self._az = t_new, dz * v, ddz * v * v + dz * a
        self._z, findings = self.guard.check(z, 0)
        self.findings.extend(findings)
        if self.done:
            self._landed = t_new

    def needed_time(self) -> float:
        return 0.0

    def landing_time(self) -> float:
        return 0.0  # Z is where the path puts it

    def resume_in_range(self, t: float) -> None:
        return  # waiting conditions stop path and Z together

    def error_in_range(self, t: float) -> None:
        return  # replaced by a time-based motion (the controller does it)

    def take_findings(self) -> list[GuardFinding]:
        out, self.findings = self.findings, []
        return out

    def limit_override(
        self, ov_req: float, ov_eff: float, was_holding: bool, k: int, path: Interpolator
    ) -> OverrideVerdict:
        return OverrideVerdict(ov_req, MAX_OVERRIDE)  # Z follows the path, overloaded or not
