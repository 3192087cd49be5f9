"""What the lift sees of the path ahead (`LiftAhead`, a part of `GeoTask`): the boundary it
plans for (its horizon), the remaining path time it plans against, and the next lift start's
work done in the cycles before it. Changes with how a lift looks ahead; the channel's cycle
stays in `geo_task.py`."""

from __future__ import annotations

import functools

from liftd.cnc.geo_program import GeoProgram
from liftd.cnc.lift.advanced import Refine
from liftd.cnc.lift.controller import LiftController
from liftd.cnc.lift.ranges import LiftRange
from liftd.cnc.path.interpolator import Interpolator

INF = float("inf")


class LiftAhead:
    """The lift's horizon and the priming of the next lift start, for the run loaded."""

    def __init__(self, cycle_time: float) -> None:
        self.dt = cycle_time
        self.lift_ranges: tuple[LiftRange, ...] = ()  # the run's (`GeoProgram.ranges`)
        self.prime_next = 0  # the range whose start `prime` prepares
        self._prime_stage = 0  # pieces of the next lift's start done
        self._prime_for = -1  # … for this range (`prime_next`)
        self._prime_restarts = -1  # … with the interpolator's restarts at this count

    def load(self, prog: GeoProgram, interp: Interpolator, lift: LiftController) -> None:
        """A run is loaded: its program, path and lift; its ranges, none primed yet."""
        self.prog = prog
        self.interp = interp
        self.lift = lift
        self.lift_ranges = prog.ranges
        self.prime_next = 0
        self._prime_stage = 0
        self._prime_for = -1
        self._prime_restarts = -1

    def horizon(self) -> int:
        """Boundary the lift plans for: LIFT_END, or an earlier waiting point of the range;
        -1 where the path's time to it is unknown: a #FLUSH / #FLUSH WAIT lies before it.

        A flush is no waiting point of the lift (vendor §2.1.3 case 3, written for Advanced
        Lifting: it "may stop the path if the lift axis can no longer reach the lift position
        in time; otherwise it has no influence on the lift profile"): Z neither lands there
        nor starts again after it. The channel is emptied at a flush, so the lift does not
        count on the blocks after it until the path is there: Z keeps rising toward POS_LIMIT
        as in a feed hold, and at the flush the path waits if Z could not make it from there
        (`BoundaryActions.z_lets_go`). liftd follows this passage where the general one
        (§2.4: "the programmed target position is reached briefly in the flush block")
        disagrees: the method-specific passage first, and it keeps Z up (issue 37 item 2)."""
        rng = self.lift.current
        if rng is None or rng.k_end < 0:
            return -1
        stopped = self.interp.stopped_at
        stops = self.prog.stops[rng.index]  # (stops_in: a Python frame every cycle)
        if stopped is not None and stopped in stops:
            return stopped  # waiting inside the range: Z goes to (and stays at) POS here
        return self._after(rng, self.interp.segment if stopped is None else stopped)

    def leaving_horizon(self) -> int:
        """Where the path rests inside the current range, at a waiting point of the program
        (G04, a synchronised M function, M00) or at a #FLUSH: the horizon Z plans for once the
        path leaves it; -1 where it rests elsewhere, or where that horizon is unknown."""
        rng = self.lift.current
        k = self.interp.stopped_at
        if rng is None or k is None or not rng.k_start <= k < rng.k_end:
            return -1
        i = rng.index
        if k == rng.k_start and k not in self.prog.stops[i] and k not in self.prog.flushes[i]:
            return -1  # a rest at LIFT_START with nothing to wait for after it
        return self._after(rng, k)

    def _after(self, rng: LiftRange, ahead: int) -> int:
        """The horizon of a path that has passed boundary `ahead` (or rests there)."""
        stops = self.prog.stops[rng.index]
        horizon = rng.k_end
        for k in stops:
            if k > ahead:
                horizon = k
                break
        for k in self.prog.flushes[rng.index]:
            if ahead < k < horizon:
                return -1  # the path has not left this flush yet: beyond it is unknown
        return horizon

    def at_flush(self) -> bool:
        """Whether the path rests at a #FLUSH inside the current lift range."""
        rng = self.lift.current
        k = self.interp.stopped_at
        return rng is not None and k is not None and k in self.prog.flushes[rng.index]

    def lift_time(self, t: float, t_z: float, ov_eff: float) -> tuple[float, Refine | None]:
        """The remaining path time a time-based lift plans against, from Z's time t_z: to its
        horizon, a lower bound that `refine` makes exact; inf where the horizon is unknown.
        Where the path rests at a flush, the least time it needs from there if it left now
        (at t): Z plans to land by then, the path waits until it can
        (`BoundaryActions.z_lets_go`)."""
        k = self.horizon()
        if k < 0:
            return INF, None
        ip = self.interp
        if self.at_flush():
            return t + ip.lower_bound(k, ov_eff) - ip.t_state - t_z, None
        # a bound that costs nothing while it still holds; exact on demand
        return ip.arrival_bound(k) - t_z, functools.partial(_remaining, ip, k, t_z)

    def prime(self, t_cycle: float) -> None:
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
        if t_at is None or t_at > t_cycle + 2.5 * self.dt:
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
            if not any(rng.k_start < f < horizon for f in self.prog.flushes[rng.index]):
                ip.arrival_bound(horizon)  # (beyond a flush the lift plans with no bound)


def _remaining(interp: Interpolator, k: int, t_z: float) -> float:
    """The path's remaining time to boundary k from the lift's time t_z (exact or its bound)."""
    return interp.arrival(k) - t_z
