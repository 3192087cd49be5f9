"""Runs the lift ranges of a program in the GEO cycle: starts and ends lifts, the status flags
`lift_active` / `lift_suppressed`, waiting conditions inside a range, and the override limits
of Advanced Lifting. Path-based Lifting plugs in through the same interface: a range with a
z(s) plan from path preparation is *coupled* (Z follows the path position, `couple()`), every
other range runs the time-based generator (`step()`).

Rules (vendor text §2.1, §2.5, §2.6; DESIGN.md §4), with liftd's choices where it is silent:

* lift_active is TRUE from the LIFT_START point until Z is at POS at LIFT_END; a suppressed lift
  (path shorter than lift_min_dist) sets lift_suppressed, and also lift_active when POS differs
  from the start (both TRUE, vendor §2.6).
* A waiting condition inside a range (G04, M function with synchronisation, M00, #FLUSH) is a
  stop of the path; Z plans to be at POS when the path stops there ("the lift axis moves on to
  target height", vendor §2.1.1) and lifts again for the rest of the range after the wait.
* Feed hold: T_rem is infinite, so Z keeps rising toward POS_LIMIT and holds; when the path
  resumes the override is limited so that Z still lands on time.
* Program error inside the range: Z rises to POS_LIMIT and stays (vendor §2.1.3 case 2, §2.4).
* Path-based Lifting sets only lift_suppressed for a suppressed lift (the double flag is an
  Advanced-Lifting special case, vendor §2.6); Z still goes to POS, coupled to the path.
"""

from __future__ import annotations

from dataclasses import dataclass

from liftd.cnc.lift.advanced import AdvancedLift, Phase
from liftd.cnc.lift.guard import GuardFinding, LiftGuard
from liftd.cnc.lift.path_based import RangePlan
from liftd.cnc.lift.profile import LiftProfiles, ProfileError
from liftd.cnc.lift.ranges import LiftRange
from liftd.cnc.params import AxisParams
from liftd.cnc.snapshot import LiftPhase

INF = float("inf")


@dataclass(slots=True)
class LiftRecord:
    """What the summary reports per lift (filled while the lift runs)."""

    range: LiftRange
    t_start: float
    z_start: float
    t_end: float = -1.0
    peak: float = 0.0
    area: float = 0.0  # ∫ (q − q_base) dt over the lift, for the mean clearance
    arrival_error: float = 0.0
    path_delay: float = 0.0
    nominal_time: float = 0.0  # path time without the lift's limits (for path_delay_s)
    departure: float | None = None  # the path leaves the range's start (after a wait there)
    waits: float = 0.0  # time the path waited inside the range for other reasons than Z
    late: bool = False  # the path passed LIFT_END with Z not at POS (arrival_error > 0)
    z_a_max_ratio: float = 0.0  # largest sampled |Z acceleration| / a_max during the lift
    premature: bool = False  # path-based: look-ahead overflow, lifted early


class LiftController:
    def __init__(
        self,
        axis: AxisParams,
        ranges: tuple[LiftRange, ...],
        cycle: float,
        plans: tuple[RangePlan | None, ...] = (),
        both_flags: bool = True,
    ) -> None:
        self.axis = axis
        self.ranges = ranges
        self.plans = plans or (None,) * len(ranges)
        self.both_flags = both_flags  # suppressed with a Z move: lift_active too (Advanced)
        self.coupled: RangePlan | None = None
        self._cz = self._cvz = self._caz = self._ct = 0.0
        self.by_start = {r.k_start: r for r in ranges}
        self.cycle = cycle
        self.gen = AdvancedLift(LiftProfiles(axis.v_max, axis.a_max, axis.j_max), cycle)
        self.current: LiftRange | None = None
        self.record: LiftRecord | None = None
        self.records: list[LiftRecord] = []
        self.active = False
        self.suppressed = False
        self.ov_at_descent: float | None = None
        self.ending = False  # LIFT_END passed while Z still moved: close when Z is there
        self.guard = LiftGuard(axis)
        self.findings: list[GuardFinding] = []  # consumed by the GEO task each cycle

    # -- path-side limits -------------------------------------------------------------------------
    def z_time(self, z0: float, target: float) -> float:
        """Time-optimal rest-to-rest Z move: the least path time a lift range may take."""
        if abs(target - z0) <= 1e-12:
            return 0.0
        try:
            return float(self.gen.prof.to_rest(z0, 0.0, 0.0, target).duration)
        except ProfileError:
            return INF

    # -- events -----------------------------------------------------------------------------------
    def start(self, rng: LiftRange, t: float, z: float, vz: float, az: float) -> None:
        spec = rng.start
        beyond = rng.beyond_limit or ((z < spec.pos_limit) if spec.down else (z > spec.pos_limit))
        direct = rng.suppressed or beyond
        self.gen.start(t, z, vz, az, spec.target, spec.pos_limit, spec.down, direct)
        a, j = self.axis.a_max, self.axis.j_max
        margin = vz * vz / (2.0 * a) + (abs(vz) * a / j if j != INF else 0.0)
        self.guard.arm(z, spec.target, spec.pos_limit, spec.down, direct, margin)
        self.current = rng
        self.suppressed = rng.suppressed
        moves = rng.moves_z or abs(z - spec.target) > 1e-12
        self.active = not rng.suppressed or (self.both_flags and moves)
        self.ov_at_descent = None
        self.coupled = self.plans[rng.index]
        self.record = LiftRecord(rng, t, z)
        self.record.peak = z
        if self.coupled is not None:
            self.record.premature = self.coupled.premature
            self._cz, self._cvz, self._caz, self._ct = z, vz, az, t

    def resume_in_range(self, t: float) -> None:
        """The path leaves a waiting point inside the range: lift again for the rest of it."""
        if self.current is None or self.current.direct or self.coupled is not None:
            return
        spec = self.current.start
        t = self.gen.t  # the state (z, vz, az) belongs to this time; never rewind it
        self.gen.start(
            t, self.gen.z, self.gen.vz, self.gen.az, spec.target, spec.pos_limit, spec.down, False
        )

    def error_in_range(self, t: float) -> None:
        if self.current is None:
            return
        if self.coupled is not None:  # leave the path: rise time-based from where Z is
            spec = self.current.start
            self.gen.start(t, self._cz, self._cvz, self._caz, spec.target, spec.pos_limit,
                           spec.down, False)  # fmt: skip
            self.coupled = None
        self.gen.rise_and_hold(t)

    def finish(self, t: float) -> LiftRecord | None:
        """LIFT_END reached with Z at POS: close the range and the record."""
        rec = self.record
        if rec is not None:
            rec.t_end = t
            if not rec.late:  # else measured when the path passed LIFT_END
                rec.arrival_error = abs(self.z - rec.range.start.target)
            self.records.append(rec)
        self.current = None
        self.record = None
        self.active = False
        self.suppressed = False
        self.ov_at_descent = None
        self.ending = False
        self.coupled = None
        return rec

    # -- cycle ------------------------------------------------------------------------------------
    def step(self, t_new: float, t_rem: float, override: float) -> None:
        """Time-based: move Z to t_new, the path reaching the horizon t_rem later."""
        if self.current is None or self.coupled is not None:
            return
        was_down = self.gen.phase is Phase.DOWN
        t_old = self.gen.t
        z_old = self.gen.z
        self.gen.step(t_new, t_rem)
        self._guard(t_new)
        if self.gen.phase is Phase.DOWN and not was_down:
            self.ov_at_descent = override
        elif self.gen.phase is Phase.UP:
            self.ov_at_descent = None
        self._account(t_old, z_old)

    def couple(self, t_new: float, s: float, v: float, a: float) -> None:
        """Path-based: Z at the path position s (path velocity v, acceleration a) at t_new."""
        plan = self.coupled
        if self.current is None or plan is None:
            return
        t_old, z_old = self._ct, self._cz
        z, dz, ddz = plan.state(s)
        self._ct, self._cvz, self._caz = t_new, dz * v, ddz * v * v + dz * a
        self._cz, findings = self.guard.check(z, 0)
        self.findings.extend(findings)
        self._account(t_old, z_old)

    def _account(self, t_old: float, z_old: float) -> None:
        rec = self.record
        if rec is not None:
            z = self.z
            spec = rec.range.start
            base = min(rec.z_start, spec.target) if not spec.down else max(rec.z_start, spec.target)
            sign = -1.0 if spec.down else 1.0
            rec.area += 0.5 * sign * ((z_old - base) + (z - base)) * (self.t - t_old)
            rec.peak = max(rec.peak, z) if not spec.down else min(rec.peak, z)

    def _guard(self, t: float) -> None:
        z, findings = self.guard.check(self.gen.z, self.gen.fallbacks)
        if not findings:
            return
        self.findings.extend(findings)
        if z != self.gen.z and self.current is not None:
            # never expected: stop at the bound and go straight (time-optimally) to POS
            spec = self.current.start
            self.gen.start(t, z, 0.0, 0.0, spec.target, spec.pos_limit, spec.down, True)

    # -- state of the lift axis ------------------------------------------------------------------
    @property
    def z(self) -> float:
        return self._cz if self.coupled is not None else self.gen.z

    @property
    def vz(self) -> float:
        return self._cvz if self.coupled is not None else self.gen.vz

    @property
    def az(self) -> float:
        return self._caz if self.coupled is not None else self.gen.az

    @property
    def t(self) -> float:
        """Time the lift axis state belongs to."""
        return self._ct if self.coupled is not None else self.gen.t

    @property
    def landed(self) -> float:
        """Exact time Z reached POS (time-based ranges)."""
        return self._ct if self.coupled is not None else self.gen.landed

    @property
    def z_done(self) -> bool:
        if self.current is None:
            return True
        if self.coupled is not None:
            return abs(self._cz - self.current.start.target) <= 1e-12 and self._cvz == 0.0
        return self.gen.done

    @property
    def phase(self) -> LiftPhase:
        if self.current is None:
            return LiftPhase.NONE
        if self.coupled is not None:
            return LiftPhase.COUPLED
        return LiftPhase(int(self.gen.phase))

    def needed_time(self) -> float:
        """Time Z still needs to reach POS from its current state (time-optimal)."""
        if self.current is None or self.coupled is not None or self.gen.done:
            return 0.0
        if self.gen.phase is Phase.UP:
            return self.gen.t_need
        plan = self.gen.plan
        return 0.0 if plan is None else max(0.0, self.gen.plan_t0 + plan.duration - self.gen.t)
