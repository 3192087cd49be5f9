"""Guard on every lift-axis set-point: software limits and the lift's position bounds.

Community ruckig ignores position limits (docs/reference/lift-algorithm.md §1.1), so POS_LIMIT and
the software limits are enforced by construction in the generator; the guard checks each
set-point anyway and reports what it finds: a set-point outside the bounds (clamped into them,
never expected), and every ruckig refusal that made the generator fall back to a safe move.
"""

from __future__ import annotations

from dataclasses import dataclass

from liftd.cnc import events
from liftd.cnc.params import AxisParams

POS_TOL = 1e-7  # 0.1 µm


@dataclass(slots=True)
class GuardFinding:
    name: str  # events.LIFT_GUARD_CLAMPED or events.LIFT_FALLBACK
    value: float  # the offending position (m) or the number of fallbacks so far


class LiftGuard:
    def __init__(self, axis: AxisParams) -> None:
        self.axis = axis
        self.lo_sw = axis.sw_limit_neg
        self.hi_sw = axis.sw_limit_pos
        self.lo = self.lo_sw
        self.hi = self.hi_sw
        self.fallbacks_seen = 0
        self.clamped = 0

    def arm(
        self,
        z_start: float,
        target: float,
        pos_limit: float,
        down: bool,
        direct: bool,
        stop_margin: float,
    ) -> None:
        """Bounds for one lift: between the start/target and POS_LIMIT (the limit does not
        apply when POS or the start lies beyond it); stop_margin allows for Z entering the
        range with velocity (its stopping distance)."""
        # two-argument min/max only: with three the compiled core calls the builtin
        if direct:
            lo, hi = min(z_start, target), max(z_start, target)
        elif down:
            lo, hi = min(min(pos_limit, target), z_start), max(z_start, target)  # noqa: PLW3301
        else:
            lo, hi = min(z_start, target), max(max(pos_limit, target), z_start)  # noqa: PLW3301
        self.lo = max(self.lo_sw, lo - stop_margin - POS_TOL)
        self.hi = min(self.hi_sw, hi + stop_margin + POS_TOL)

    def check(self, z: float, fallbacks: int) -> tuple[float, list[GuardFinding]]:
        findings: list[GuardFinding] = []
        if fallbacks > self.fallbacks_seen:
            self.fallbacks_seen = fallbacks
            findings.append(GuardFinding(events.LIFT_FALLBACK, float(fallbacks)))
        if z < self.lo or z > self.hi:
            self.clamped += 1
            findings.append(GuardFinding(events.LIFT_GUARD_CLAMPED, z))
            z = min(max(z, self.lo), self.hi)
        return z, findings
