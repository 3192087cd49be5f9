"""Rest-to-target profiles of the lift axis: its limits (with the planning margin) over the one
ruckig wrapper (`liftd.cnc.ruckig1`). Position limits are not enforced by community ruckig, so
callers check `position_range`."""

from __future__ import annotations

from ruckig import Trajectory

from liftd.cnc.params import PLANNING_MARGIN
from liftd.cnc.ruckig1 import ProfileError, Ruckig1, position_range, state_at

__all__ = ["LiftProfiles", "ProfileError", "position_range", "state_at"]


class LiftProfiles:
    """Time-optimal (or stretched) moves of one axis to a target at rest."""

    def __init__(self, v_max: float, a_max: float, j_max: float) -> None:
        keep = 1.0 - PLANNING_MARGIN
        self.v_max = v_max
        self.a_max = a_max
        self.j_max = j_max
        self._v, self._a, self._j = v_max * keep, a_max * keep, j_max * keep
        self._calc = Ruckig1()

    @property
    def calls(self) -> int:
        return self._calc.calls

    def to_rest(
        self,
        p: float,
        v: float,
        a: float,
        target: float,
        min_duration: float | None = None,
        into: Trajectory | None = None,
    ) -> Trajectory:
        """Time-optimal (or at least `min_duration` long) profile from (p, v, a) to target;
        `into`: a trajectory to overwrite (for a profile only asked for its duration)."""
        return self._calc.position(
            p,
            v,
            a,
            target,
            0.0,
            self._v,
            self._a,
            self._j,
            forward_only=False,
            min_duration=min_duration,
            into=into,
        )
