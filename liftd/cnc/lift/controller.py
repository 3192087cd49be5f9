"""Runs the lift ranges of a program in the GEO cycle: starts and ends lifts, the status flags
`lift_active` / `lift_suppressed`, waiting conditions inside a range, and the override limits
of Advanced Lifting. Path-based Lifting plugs in through the same interface: a range with a
z(s) plan from path preparation is *coupled* (Z follows the path position, `couple()`), every
other range runs the time-based generator (`step()`).

Rules (vendor text §2.1, §2.5, §2.6; DESIGN.md §4), with liftd's choices where it is silent:

* lift_active is TRUE from the LIFT_START point until Z is at POS at LIFT_END; a suppressed lift
  (path shorter than lift_min_dist) sets lift_suppressed, and also lift_active when POS differs
  from the start (both TRUE, vendor §2.6).
* A waiting condition inside a range (G04, M function with synchronisation, M00) is a stop of
  the path; Z plans to be at POS when the path stops there ("the lift axis moves on to target
  height", vendor §2.1.1) and lifts again for the rest of the range after the wait. A #FLUSH is
  none (§2.1.3 case 3): Z goes on across it, the path waits there only for Z (lift_ahead.py).
* Feed hold: T_rem is infinite, so Z keeps rising toward POS_LIMIT and holds; when the path
  resumes the override is limited so that Z still lands on time.
* Program error inside the range: Z rises to POS_LIMIT and stays (vendor §2.1.3 case 2, §2.4).
* Path-based Lifting sets only lift_suppressed for a suppressed lift (the double flag is an
  Advanced-Lifting special case, vendor §2.6); Z still goes to POS, coupled to the path.
"""

from __future__ import annotations

from liftd.cnc.lift.advanced import AdvancedLift, FirstRise, Refine
from liftd.cnc.lift.guard import GuardFinding, LiftGuard
from liftd.cnc.lift.motion import CoupledLift, LiftMotion, TimeBasedLift
from liftd.cnc.lift.path_based import RangePlan
from liftd.cnc.lift.profile import LiftProfiles, ProfileError
from liftd.cnc.lift.ranges import LiftRange
from liftd.cnc.params import AxisParams
from liftd.cnc.snapshot import LiftPhase

INF = float("inf")


class LiftRecord:
    """What the summary reports per lift (filled while the lift runs). A plain class: a
    dataclass's generated `__init__` is a Python function even in the compiled core (~6 µs
    of every lift start, cold)."""

    __slots__ = ("area", "arrival_error", "departure", "late", "nominal_time", "path_delay",
                 "peak", "premature", "range", "t_end", "t_start", "waits", "z_a_max_ratio",
                 "z_start")  # fmt: skip

    def __init__(self, rng: LiftRange, t_start: float, z_start: float) -> None:
        self.range = rng
        self.t_start = t_start
        self.z_start = z_start
        self.t_end = -1.0
        self.peak = 0.0
        self.area = 0.0  # ∫ (q − q_base) dt over the lift, for the mean clearance
        self.arrival_error = 0.0
        self.path_delay = 0.0
        self.nominal_time = 0.0  # path time without the lift's limits (for path_delay_s)
        self.departure: float | None = None  # the path leaves the range's start (after a wait)
        self.waits = 0.0  # time the path waited inside the range for other reasons than Z
        self.late = False  # the path passed LIFT_END with Z not at POS (arrival_error > 0)
        self.z_a_max_ratio = 0.0  # largest sampled |Z acceleration| / a_max during the lift
        self.premature = False  # path-based: look-ahead overflow, lifted early

    def __repr__(self) -> str:
        return (
            f"LiftRecord(line={self.range.start.line}, t_start={self.t_start}, "
            f"t_end={self.t_end}, peak={self.peak}, arrival_error={self.arrival_error})"
        )


class LiftController:
    """The lift ranges of one program run: which range is open, the flags, the records; the
    lift axis's motion inside a range is a `LiftMotion` (time-based or coupled)."""

    def __init__(
        self,
        axes: tuple[AxisParams, ...],
        ranges: tuple[LiftRange, ...],
        cycle: float,
        plans: tuple[RangePlan | None, ...] = (),
        both_flags: bool = True,
        rises: tuple[FirstRise | None, ...] = (),
        lift_axes: tuple[str, ...] | None = None,
    ) -> None:
        self.axes = axes
        self.names = tuple(ax.name for ax in axes)
        self.ranges = ranges
        self.plans = plans or (None,) * len(ranges)
        self.rises = rises or (None,) * len(ranges)  # prepared first rises (time-based)
        self.both_flags = both_flags  # suppressed with a Z move: lift_active too (Advanced)
        self.cycle = cycle
        self._gens: dict[str, AdvancedLift] = {}
        self._guards: dict[str, LiftGuard] = {}
        self.motion: LiftMotion | None = None
        self.current: LiftRange | None = None
        self.axis_index = -1  # the axis of the current (or last) range
        self.record: LiftRecord | None = None
        self.records: list[LiftRecord] = []
        self.active = False
        self.suppressed = False
        self.ending = False  # LIFT_END passed while Z still moved: close when Z is there
        # an error or RESET in a coupled range while the path still moved: Z follows the path's
        # braking, then rises time-based from rest (`step`)
        self.error_pending = False
        self.counts = (0,) * len(axes)  # lifts started per axis since the program started
        self.findings: list[GuardFinding] = []  # consumed by the GEO task each cycle
        # built here, not at a range's start in a GEO cycle; per axis that lifts (the program
        # prepares them: a loop over its ranges at a repeat START cost ~50 µs on 500 parts)
        if lift_axes is None:
            lift_axes = tuple(dict.fromkeys(rng.start.axis for rng in ranges))
        for axis in lift_axes:
            self.generator(axis)
            self.guard(axis)

    def _axis(self, name: str) -> AxisParams:
        return self.axes[self.names.index(name)]

    def generator(self, axis: str) -> AdvancedLift:
        gen = self._gens.get(axis)
        if gen is None:
            ax = self._axis(axis)
            gen = self._gens[axis] = AdvancedLift(
                LiftProfiles(ax.v_max, ax.a_max, ax.j_max), self.cycle
            )
        return gen

    def guard(self, axis: str) -> LiftGuard:
        guard = self._guards.get(axis)
        if guard is None:
            guard = self._guards[axis] = LiftGuard(self._axis(axis))
        return guard

    # -- path-side limits -------------------------------------------------------------------------
    def z_time(self, z0: float, target: float, axis: str | None = None) -> float:
        """Time-optimal rest-to-rest move of the lift axis: the least path time a range takes."""
        if abs(target - z0) <= 1e-12:
            return 0.0
        gen = self.generator(axis or (self.current.start.axis if self.current else self.names[-1]))
        try:
            return float(gen.prof.to_rest(z0, 0.0, 0.0, target).duration)
        except ProfileError:
            return INF

    def prime(self, rng: LiftRange, dt: float) -> None:
        """Compute ahead the first rising cycle of `rng` (time-based, on its prepared rise),
        which will start `dt` before the end of its cycle (`AdvancedLift.prime`)."""
        rise = self.rises[rng.index]
        if rise is None or self.plans[rng.index] is not None or rng.direct:
            return
        spec = rng.start
        self.generator(spec.axis).prime(rise, spec.target, spec.pos_limit, spec.down, dt)

    # -- events -----------------------------------------------------------------------------------
    def start(self, rng: LiftRange, t: float, z: float, vz: float, az: float) -> None:
        spec = rng.start
        axis = spec.axis
        plan = self.plans[rng.index]
        guard = self.guard(axis)
        self.motion = (
            CoupledLift(plan, guard, rng, t, z, vz, az)
            if plan is not None
            else TimeBasedLift(
                self.generator(axis), guard, rng, t, z, vz, az, self.rises[rng.index]
            )
        )
        self.current = rng
        self.axis_index = self.names.index(axis)
        i = self.axis_index
        self.counts = (*self.counts[:i], self.counts[i] + 1, *self.counts[i + 1 :])
        self.suppressed = rng.suppressed
        moves = rng.moves_z or abs(z - spec.target) > 1e-12
        self.active = not rng.suppressed or (self.both_flags and moves)
        self.record = LiftRecord(rng, t, z)
        self.record.peak = z
        if plan is not None:
            self.record.premature = plan.premature

    def resume_in_range(self, t: float) -> None:
        """The path leaves a waiting point inside the range: lift again for the rest of it."""
        if self.motion is not None:
            self.motion.resume_in_range(t)

    def error_in_range(self, t: float) -> None:
        """Program error inside the range: Z rises to POS_LIMIT and stays (vendor §2.1.3 case 2,
        §2.4); a coupled range leaves the path and rises time-based from where Z is."""
        m, rng = self.motion, self.current
        if m is None or rng is None:
            return
        if not m.uses_time:
            if m.vz != 0.0 or m.az != 0.0:
                # Z follows the braking path to rest first: a time-based plan from Z's coupled
                # state (its acceleration up to a_max·(1 + P442/1000), beyond Z's own limit)
                # first had to bring that acceleration back within the jerk limit, and took
                # Z 24 mm down, toward the part, before it rose (bench_reset, path-based)
                self.error_pending = True
                return
            m = self.motion = TimeBasedLift(self.generator(rng.start.axis),
                                            self.guard(rng.start.axis), rng, max(m.t, t), m.z,
                                            0.0, 0.0)  # fmt: skip
        m.error_in_range(t)

    def finish(self, t: float) -> LiftRecord | None:
        """LIFT_END reached with Z at POS: close the range and the record."""
        rec = self.record
        if rec is not None:
            rec.t_end = t
            if not rec.late:  # else measured when the path passed LIFT_END
                rec.arrival_error = abs(self.z - rec.range.start.target)
            self.records.append(rec)
        self.abort()
        return rec

    def abort(self) -> None:
        """Close the range (`finish` after its record; a RESET inside the range without one,
        the lift axis at rest where its motion took it: it never reached LIFT_END)."""
        self.current = None
        self.motion = None
        self.record = None
        self.active = False
        self.suppressed = False
        self.ending = False
        self.error_pending = False

    # -- cycle ------------------------------------------------------------------------------------
    def step(self, t_new: float, s: float, v: float, a: float, t_rem: float,
             override: float, refine: Refine | None = None) -> None:  # fmt: skip
        """Move the lift axis to t_new: against the remaining path time t_rem (time-based) or
        to the path position s (coupled, path velocity v and acceleration a)."""
        m = self.motion
        if m is None:
            return
        t_old, z_old = m.t, m.z
        m.step(t_new, s, v, a, t_rem, override, refine)
        self.findings.extend(m.take_findings())
        if self.error_pending and m.vz == 0.0 and m.az == 0.0:  # the path has stopped Z
            self.error_pending = False
            self.error_in_range(t_new)
            if self.motion is None:
                return
            m = self.motion
        rec = self.record
        if rec is not None:
            z = m.z
            spec = rec.range.start
            base = min(rec.z_start, spec.target) if not spec.down else max(rec.z_start, spec.target)
            sign = -1.0 if spec.down else 1.0
            rec.area += 0.5 * sign * ((z_old - base) + (z - base)) * (m.t - t_old)
            rec.peak = max(rec.peak, z) if not spec.down else min(rec.peak, z)

    # -- state of the lift axis ------------------------------------------------------------------
    @property
    def z(self) -> float:
        return self.motion.z if self.motion is not None else 0.0

    @property
    def vz(self) -> float:
        return self.motion.vz if self.motion is not None else 0.0

    @property
    def az(self) -> float:
        return self.motion.az if self.motion is not None else 0.0

    @property
    def t(self) -> float:
        return self.motion.t if self.motion is not None else 0.0

    @property
    def landed(self) -> float:
        """Exact time Z reached POS."""
        return self.motion.landed if self.motion is not None else 0.0

    @property
    def z_done(self) -> bool:
        return self.motion is None or self.motion.done

    @property
    def phase(self) -> LiftPhase:
        return LiftPhase.NONE if self.motion is None else self.motion.phase

    def needed_time(self) -> float:
        """Time Z still needs to reach POS from its current state (time-optimal)."""
        return 0.0 if self.motion is None else self.motion.needed_time()
