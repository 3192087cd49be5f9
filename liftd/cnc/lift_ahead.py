"""What the lift sees of the path ahead (`LiftAhead`, between `BoundaryActions` and `GeoTask`):
the boundary it plans for (its horizon) and the next lift start's work done in the cycles
before it. Changes with how a lift looks ahead; the channel's cycle stays in `geo_task.py`."""

from __future__ import annotations

from liftd.cnc.actions import BoundaryActions
from liftd.cnc.lift.ranges import LiftRange


class LiftAhead(BoundaryActions):
    """The lift's horizon and the priming of the next lift start, on `GeoTask`'s state."""

    dt: float  # the cycle time
    t_cycle: float  # the time of the current cycle
    _prime_stage: int  # pieces of the next lift's start done (`_prime_lift`)
    _prime_for: int  # … for this range (`prime_next`)
    _prime_restarts: int  # … with the interpolator's restarts at this count

    def _reset_priming(self, ranges: tuple[LiftRange, ...]) -> None:
        """A run's ranges, none primed yet (the task loads a run)."""
        self.lift_ranges = ranges
        self.prime_next = 0
        self._prime_stage = 0
        self._prime_for = -1
        self._prime_restarts = -1

    def _horizon(self) -> int:
        """Boundary the lift plans for: LIFT_END, or an earlier waiting point of the range."""
        rng = self.lift.current
        if rng is None or rng.k_end < 0:
            return -1
        stopped = self.interp.stopped_at
        stops = self.prog.stops[rng.index]  # (stops_in: a Python frame every cycle)
        if stopped is not None and stopped in stops:
            return stopped  # waiting inside the range: Z goes to (and stays at) POS here
        ahead = self.interp.segment if stopped is None else stopped
        for k in stops:
            if k > ahead:
                return k
        return rng.k_end

    def _prime_lift(self) -> None:
        """Work of the next lift start's cycle done in the two quiet cycles before it, once
        the path's crossing of its LIFT_START is committed: the lift's first rising cycle
        (`AdvancedLift.prime`, a ruckig solve), then the lower bound of the path's arrival at
        the lift's horizon (`Interpolator.arrival_bound` keeps it while the committed future
        stands). One piece per cycle, each about what a lifting cycle costs; a start cycle
        with cold caches cost up to 250 µs without them. Both are memos of pure functions: the
        start cycle takes them where its inputs are the same ones, else computes them as it
        did before (an event that discarded the committed future primes again); the
        snapshots are the same either way (the core digests)."""
        ip = self.interp
        i = self.prime_next
        if ip.restarts != self._prime_restarts or i != self._prime_for:
            self._prime_restarts, self._prime_for, self._prime_stage = ip.restarts, i, 0
        stage = self._prime_stage
        if stage >= 2 or i >= len(self.lift_ranges):
            return
        rng = self.lift_ranges[i]
        t_at = ip.arrivals.get(rng.k_start)
        if t_at is None or t_at > self.t_cycle + 2.5 * self.dt:
            return
        found = ip.crossing_within(rng.k_start, 2)
        if found is None:
            return
        k, c = found
        self._prime_stage = stage + 1
        if stage == 0:
            u_z = self.prog.entry_dir[rng.index]
            if not c.at_rest and c.v * u_z == 0.0 and c.a * u_z == 0.0:
                self.lift.prime(rng, k * self.dt - c.t)  # the start cycle's t − its t_at
        elif rng.k_end > rng.k_start:
            horizon = rng.k_end
            for b in self.prog.stops[rng.index]:
                if b > rng.k_start:
                    horizon = b
                    break
            ip.arrival_bound(horizon)
