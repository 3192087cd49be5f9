"""The one wrapper around ruckig (community edition) for 1-D jerk-limited profiles.

Path motion and the lift axis both use it. Every call is wrapped: ruckig's Python binding
raises `RuckigError` for invalid or infeasible input (docs/reference/lift-algorithm.md §1.1);
callers get `ProfileError` and fall back to a safe move. Community ruckig ignores position limits,
so callers check `position_range` where a bound matters.
"""

from __future__ import annotations

from ruckig import ControlInterface, InputParameter, Ruckig, RuckigError, Trajectory

INF = float("inf")


class ProfileError(Exception):
    """Ruckig refused a profile."""


def _refused(exc: RuckigError) -> ProfileError:
    """ruckig's reason: the first line of its message that says something (the message
    begins with a newline)."""
    for line in str(exc).splitlines():
        if line.strip():
            return ProfileError(line.strip())
    return ProfileError("ruckig refused the profile")


class Ruckig1:
    """One reusable 1-DoF calculator. Setting a field of ruckig's input costs ~0.3 µs (a list
    converted to a C++ array), so each interface keeps its own input object and only the
    fields that changed since the last call are set: about 2.5 µs instead of 5 per profile."""

    __slots__ = ("_last_pos", "_last_vel", "_pos", "_r", "_vel", "calls")

    def __init__(self) -> None:
        self._r = Ruckig(1)
        self._pos = InputParameter(1)
        self._pos.control_interface = ControlInterface.Position
        self._pos.target_acceleration = [0.0]
        self._vel = InputParameter(1)
        self._vel.control_interface = ControlInterface.Velocity
        self._vel.target_acceleration = [0.0]
        self._vel.min_velocity = None
        self._vel.minimum_duration = None
        # (target velocity, v_max, forward only, a_max, j_max, minimum duration, target
        # acceleration) last set
        self._last_pos: tuple[float, float, bool, float, float, float | None, float] | None = None
        self._last_vel: tuple[float, float, float] | None = None  # (v_max, a_max, j_max)
        self.calls = 0

    def position(
        self,
        p0: float,
        v0: float,
        a0: float,
        p1: float,
        v1: float,
        v_max: float,
        a_max: float,
        j_max: float,
        *,
        forward_only: bool = True,
        min_duration: float | None = None,
        into: Trajectory | None = None,
        a1: float = 0.0,
    ) -> Trajectory:
        """Time-optimal (or at least `min_duration` long) profile from (p0, v0, a0) to (p1, v1, a1)
        (a1 = 0 but for `Aims.through`'s brake state).
        `forward_only`: the velocity never becomes negative (a path never moves backwards).
        `into`: a trajectory to overwrite (a throwaway profile saves its allocation)."""
        if forward_only and v1 < 0.0:
            # ruckig refuses it in its input check (InputParameter::validate: the target
            # velocity undercuts the minimum velocity 0), but through a C++ exception whose
            # message formats the whole input: ~13 µs warm, 50-80 µs cold, where this is 1. A
            # target a rounding puts at -1e-17 m/s was 30 of the 32 refusals of a 500-part job
            # with override steps, the costliest cycles of its run.
            raise ProfileError(f"target velocity {v1} undercuts the minimum velocity 0")
        inp = self._pos
        inp.current_position = [p0]
        inp.current_velocity = [v0]
        inp.current_acceleration = [a0]
        inp.target_position = [p1]
        last = self._last_pos
        if last is None or last != (v1, v_max, forward_only, a_max, j_max, min_duration, a1):
            if last is None or last[0] != v1:
                inp.target_velocity = [v1]
            if last is None or last[1] != v_max:
                inp.max_velocity = [v_max]
            if last is None or last[2] != forward_only:
                inp.min_velocity = [0.0] if forward_only else None
            if last is None or last[3] != a_max:
                inp.max_acceleration = [a_max]
            if last is None or last[4] != j_max:
                inp.max_jerk = [j_max]
            if last is None or last[5] != min_duration:
                inp.minimum_duration = min_duration
            if last is None or last[6] != a1:
                inp.target_acceleration = [a1]
            self._last_pos = (v1, v_max, forward_only, a_max, j_max, min_duration, a1)
        return self._solve(inp, into)

    def velocity(
        self, p0: float, v0: float, a0: float, v1: float, a_max: float, j_max: float
    ) -> Trajectory:
        """Time-optimal change of velocity from (v0, a0) to (v1, 0); positions follow from p0."""
        inp = self._vel
        inp.current_position = [p0]
        inp.current_velocity = [v0]
        inp.current_acceleration = [a0]
        inp.target_velocity = [v1]
        limits = (max(abs(v0), abs(v1), 1e-12), max(a_max, abs(a0)), j_max)
        last = self._last_vel
        if last != limits:
            if last is None or last[0] != limits[0]:
                inp.max_velocity = [limits[0]]
            if last is None or last[1] != limits[1]:
                inp.max_acceleration = [limits[1]]
            if last is None or last[2] != limits[2]:
                inp.max_jerk = [limits[2]]
            self._last_vel = limits
        return self._solve(inp)

    def _solve(self, inp: InputParameter, into: Trajectory | None = None) -> Trajectory:
        traj = Trajectory(1) if into is None else into
        self.calls += 1
        try:
            self._r.calculate(inp, traj)
        except RuckigError as exc:
            raise _refused(exc) from None
        return traj


class Phases:
    """A 1-D ruckig trajectory's pieces (brake pre-trajectory, seven jerk phases), read once
    through the binding; `at(t)` is then ruckig's own `Trajectory::at_time` arithmetic for
    one DoF and one section (include/ruckig/trajectory.hpp, state_to_integrate_from, and
    utils.hpp integrate), native in the compiled core: bit-identical, ~0.1 µs instead of the
    binding's ~1.2 µs. Reading the pieces costs ~3 µs, so a profile is read only once it is
    evaluated a second time (`Evaluator`)."""

    __slots__ = ("a", "b_a", "b_dur", "b_j", "b_p", "b_t0", "b_v", "dur", "j", "p", "t_sum", "v")

    def __init__(self, traj: Trajectory) -> None:
        prof = traj.profiles[0][0]
        self.dur: float = traj.duration
        t: list[float] = prof.t
        self.p: list[float] = prof.p
        self.v: list[float] = prof.v
        self.a: list[float] = prof.a
        self.j: list[float] = prof.j
        t_sum = [t[0]]
        for i in range(6):
            t_sum.append(t_sum[i] + t[i + 1])  # as Profile::check sums them
        self.t_sum = t_sum
        brake = prof.brake
        self.b_dur: float = brake.duration
        if self.b_dur > 0.0:
            self.b_t0: float = brake.t[0]
            self.b_p: list[float] = brake.p
            self.b_v: list[float] = brake.v
            self.b_a: list[float] = brake.a
            self.b_j: list[float] = brake.j
        else:
            self.b_t0 = 0.0
            self.b_p = self.b_v = self.b_a = self.b_j = []

    def at(self, time: float) -> tuple[float, float, float]:
        """(p, v, a) at `time` from the profile's start, as `traj.at_time(time)`."""
        t_sum = self.t_sum
        if time >= self.dur:  # keep constant acceleration
            return _integrate(time - (self.b_dur + t_sum[6]), self.p[7], self.v[7], self.a[7], 0.0)
        t = time
        if self.b_dur > 0.0:
            if t < self.b_dur:
                i = 0 if t < self.b_t0 else 1
                if i > 0:
                    t -= self.b_t0
                return _integrate(t, self.b_p[i], self.b_v[i], self.b_a[i], self.b_j[i])
            t -= self.b_dur
        if t >= t_sum[6]:
            return _integrate(t - t_sum[6], self.p[7], self.v[7], self.a[7], 0.0)
        i = 0
        while t_sum[i] <= t:  # std::upper_bound: the first phase ending after t
            i += 1
        if i > 0:
            t -= t_sum[i - 1]
        return _integrate(t, self.p[i], self.v[i], self.a[i], self.j[i])


def brake_pieces(ph: Phases) -> list[tuple[float, float, float, float, float]]:
    """(start, duration, v, a, j) of each piece of ruckig's brake into its limits that lasts:
    a brake of one piece leaves its second unwritten (all zeros, ruckig's BrakeProfile),
    which read as a velocity of 0 made the tracker refuse profiles that do not dip (a review
    found, issue 36)."""
    if ph.b_dur <= 0.0:
        return []
    starts, durs = (0.0, ph.b_t0), (ph.b_t0, ph.b_dur - ph.b_t0)
    return [
        (starts[i], durs[i], ph.b_v[i], ph.b_a[i], ph.b_j[i]) for i in range(2) if durs[i] > 0.0
    ]


def _pieces(ph: Phases) -> list[tuple[float, float, float, float, float]]:
    """(start, end, v, a, j) of each piece, from the profile's start: the brake's that last,
    then the seven phases."""
    pieces = [(t0, t0 + dur, v, a, j) for t0, dur, v, a, j in brake_pieces(ph)]
    t0 = ph.b_dur
    for i in range(7):
        t1 = ph.b_dur + ph.t_sum[i]
        pieces.append((t0, t1, ph.v[i], ph.a[i], ph.j[i]))
        t0 = t1
    return pieces


def travel_after(ph: Phases, time: float) -> float:
    """An upper bound of the distance the profile moves from `time` (from its start) to its
    end: over each piece left, its largest |v| times the time left in it (v is quadratic in a
    piece: its extremes are at the ends or where a = 0)."""
    total = 0.0
    for start, end, v0, a0, j in _pieces(ph):
        if end <= time or end <= start:
            continue
        u = max(0.0, time - start)  # the piece's state from where it is still ahead
        v, a = v0 + u * (a0 + u * j / 2), a0 + u * j
        span = end - start - u
        top = max(abs(v), abs(v + span * (a + span * j / 2)))
        if j != 0.0 and 0.0 < -a / j < span:
            top = max(top, abs(v - a * a / (2 * j)))
        total += top * span
    return total


def highest_between(ph: Phases, t0: float, t1: float) -> float:
    """The highest velocity of the profile from t0 to t1 (from its start; after its end it
    keeps its final velocity): at a piece's ends within them, or where its acceleration
    crosses zero under a negative jerk (v − a²/2j there)."""
    top = ph.at(t0)[1]
    if t1 >= ph.dur:
        top = max(top, ph.v[7])
    for start, end, v0, a0, j in _pieces(ph):
        lo, hi = max(start, t0), min(end, t1)
        if hi <= lo:
            continue
        u = lo - start
        v, a = v0 + u * (a0 + u * j / 2), a0 + u * j
        span = hi - lo
        top = max(top, v, v + span * (a + span * j / 2))
        if j < 0.0 and 0.0 < -a / j < span:
            top = max(top, v - a * a / (2 * j))
    return top


def _integrate(t: float, p0: float, v0: float, a0: float, j: float) -> tuple[float, float, float]:
    return (
        p0 + t * (v0 + t * (a0 / 2 + t * j / 6)),
        v0 + t * (a0 + t * j / 2),
        a0 + t * j,
    )


class Evaluator:
    """A trajectory evaluated in many cycles (a plan the path or the lift follows): the
    first evaluation goes through the binding, from the second on through its `Phases`."""

    __slots__ = ("dur", "phases", "traj", "used")

    def __init__(self, traj: Trajectory, phases: Phases | None = None) -> None:
        self.traj = traj
        self.dur: float = traj.duration if phases is None else phases.dur
        self.phases = phases
        self.used = False

    def prepare(self) -> None:
        """Read the pieces now, ahead of the cycles that evaluate it (the binding's `at_time`
        was 16 % of an M acknowledge's cycle with cold caches): the same states either way."""
        if self.phases is None:
            self.phases = Phases(self.traj)

    def at(self, t: float) -> tuple[float, float, float]:
        """(p, v, a) at t, clamped to [0, duration] (as `state_at`)."""
        ph = self.phases
        if ph is None:
            if not self.used:
                self.used = True
                return state_at(self.traj, t)
            ph = self.phases = Phases(self.traj)
        if t >= ph.dur:
            t = ph.dur
        elif t < 0.0:
            t = 0.0
        return ph.at(t)


def state_at(traj: Trajectory, t: float) -> tuple[float, float, float]:
    """(p, v, a) of a 1-D trajectory at time t, clamped to [0, duration]."""
    if t >= traj.duration:
        t = traj.duration
    elif t < 0.0:
        t = 0.0
    p, v, a = traj.at_time(t)
    return p[0], v[0], a[0]


TIME_AT_TOL = 1e-12  # m: a time ruckig gives for a position is taken when it is this close


def first_time_at(traj: Trajectory, s: float) -> float | None:
    """First time (from the profile's start) a 1-D profile whose position never falls reaches
    s, None if it never does. Ruckig's own answer is checked on the profile: the Python
    binding's get_first_time_at_position is known to be off (pantor/ruckig issue 229; here 1e-7
    m ahead at 0.65 mm/s it said 1.82 ms where the profile is 1.6e-6 m on, and early answers
    too: stress seed 2306, a jerk of 4 × j_max where the tracker cut a step). When it is off,
    48 bisection steps on the profile itself (bounded)."""
    dur = float(traj.duration)
    found = traj.get_first_time_at_position(0, s)
    hi = dur if found is None else min(float(found), dur)
    p_hi = float(traj.at_time(hi)[0][0])
    if abs(p_hi - s) <= TIME_AT_TOL:
        return hi
    lo = 0.0
    if p_hi < s:
        if hi >= dur:
            return None
        lo, hi = hi, dur
    for _ in range(48):
        mid = 0.5 * (lo + hi)
        if float(traj.at_time(mid)[0][0]) < s:
            lo = mid
        else:
            hi = mid
    return hi


def position_range(traj: Trajectory) -> tuple[float, float]:
    bound = traj.position_extrema[0]
    return bound.min, bound.max
