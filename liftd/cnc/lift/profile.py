"""1-D jerk-limited profiles for the lift axis (ruckig, community edition), every call wrapped.

Ruckig raises RuckigError for invalid or infeasible input (reference/lift-algorithm.md §1.1);
callers get LiftProfileError instead and fall back to a safe move. Position limits are not
enforced by community ruckig, so callers check `position_range`.
"""

from __future__ import annotations

from ruckig import InputParameter, Ruckig, RuckigError, Trajectory

from liftd.cnc.params import PLANNING_MARGIN


class LiftProfileError(Exception):
    pass


class LiftProfiles:
    """One reusable calculator for rest-to-target profiles of one axis."""

    def __init__(self, v_max: float, a_max: float, j_max: float) -> None:
        self.v_max = v_max
        self.a_max = a_max
        self.j_max = j_max
        self._r = Ruckig(1)
        self._inp = InputParameter(1)
        keep = 1.0 - PLANNING_MARGIN
        self._inp.max_velocity = [v_max * keep]
        self._inp.max_acceleration = [a_max * keep]
        self._inp.max_jerk = [j_max * keep]
        self._inp.target_velocity = [0.0]
        self._inp.target_acceleration = [0.0]
        self.calls = 0

    def to_rest(
        self, p: float, v: float, a: float, target: float, min_duration: float | None = None
    ) -> Trajectory:
        """Time-optimal (or at least `min_duration` long) profile from (p, v, a) to target."""
        inp = self._inp
        inp.current_position = [p]
        inp.current_velocity = [v]
        inp.current_acceleration = [a]
        inp.target_position = [target]
        inp.minimum_duration = min_duration
        traj = Trajectory(1)
        self.calls += 1
        try:
            self._r.calculate(inp, traj)
        except RuckigError as exc:
            raise LiftProfileError(str(exc).splitlines()[0] if str(exc) else "ruckig") from None
        return traj


def state_at(traj: Trajectory, t: float) -> tuple[float, float, float]:
    """(p, v, a) of a 1-D trajectory at time t (clamped to [0, duration])."""
    if t >= traj.duration:
        t = traj.duration
    elif t < 0.0:
        t = 0.0
    p, v, a = traj.at_time(t)
    return p[0], v[0], a[0]


def position_range(traj: Trajectory) -> tuple[float, float]:
    bound = traj.position_extrema[0]
    return bound.min, bound.max
