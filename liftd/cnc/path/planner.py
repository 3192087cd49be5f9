"""Look-ahead velocity planning: a time-parametrised path motion s(t) over a window of segments.

A plan starts at a sampled path state (s, v, a) at an absolute time and covers the window of
segments up to the look-ahead size or the next stop, ending at rest (the CNC must always be able
to stop at the end of what it has seen). Boundary velocities come from a backward pass (reach
every later cap) and a forward pass from the current state (closed forms in `velocity`); each
zone is then one time-optimal ruckig profile from (s_k, b_k, a=0) to (s_k+1, b_k+1, a=0), built
only when sampled or asked for its end time. Remaining-time queries are sums of profile
durations, so a prediction made at constant override is the arrival time of the plan itself.

A hold plan (feed hold, override 0) brakes time-optimally to rest with the smallest limits of the
zones it may cross.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass

from ruckig import ControlInterface, InputParameter, Ruckig, RuckigError, Trajectory

from liftd.cnc.path.velocity import change_distance, lowest_reachable, reach_velocity

INF = float("inf")
MARGIN = 1e-9  # relative distance margin so ruckig never sees a boundary-infeasible target
FEASIBILITY_TOL = 1e-6  # relative: closed-form distances equal up to rounding are feasible


class PlanError(Exception):
    """Ruckig refused a profile (logged as an event; the interpolator falls back to a stop)."""


class Ruckig1:
    """One reusable 1-DoF ruckig calculator. Every call is wrapped: RuckigError → PlanError."""

    def __init__(self) -> None:
        self._r = Ruckig(1)
        self._inp = InputParameter(1)

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
    ) -> Trajectory:
        inp = self._inp
        inp.control_interface = ControlInterface.Position
        inp.current_position = [p0]
        inp.current_velocity = [v0]
        inp.current_acceleration = [a0]
        inp.target_position = [p1]
        inp.target_velocity = [v1]
        inp.target_acceleration = [0.0]
        inp.max_velocity = [v_max]
        inp.min_velocity = [0.0]  # the path never moves backwards
        inp.max_acceleration = [a_max]
        inp.max_jerk = [j_max]
        traj = Trajectory(1)
        try:
            self._r.calculate(inp, traj)
        except RuckigError as exc:
            raise PlanError(str(exc).splitlines()[0] if str(exc) else "ruckig error") from None
        return traj

    def brake(self, p0: float, v0: float, a0: float, a_max: float, j_max: float) -> Trajectory:
        inp = self._inp
        inp.control_interface = ControlInterface.Velocity
        inp.current_position = [p0]
        inp.current_velocity = [v0]
        inp.current_acceleration = [a0]
        inp.target_velocity = [0.0]
        inp.target_acceleration = [0.0]
        inp.max_velocity = [max(v0, 1e-9)]
        inp.min_velocity = None
        inp.max_acceleration = [max(a_max, abs(a0))]
        inp.max_jerk = [j_max]
        traj = Trajectory(1)
        try:
            self._r.calculate(inp, traj)
        except RuckigError as exc:
            raise PlanError(str(exc).splitlines()[0] if str(exc) else "ruckig error") from None
        finally:
            inp.control_interface = ControlInterface.Position
        return traj


@dataclass(frozen=True, slots=True)
class Zone:
    """One segment of the window as the planner sees it (all in SI units)."""

    s0: float
    s1: float
    v_cap: float  # min(feed × override, axis limit)
    a_max: float
    j_max: float
    entry_cap: float  # transition cap at s0 (0 at a stop)


@dataclass(slots=True)
class Piece:
    t0: float
    duration: float
    traj: Trajectory | None  # None: standing still at s_end
    s_end: float
    boundary: int  # window-relative boundary reached at the end, -1 for none
    v_end: float = 0.0  # path velocity at the end


class Plan:
    """Path motion from (t0, s0, v0, a0) through `zones` (the first zone contains s0)."""

    def __init__(
        self,
        calc: Ruckig1,
        t0: float,
        s0: float,
        v0: float,
        a0: float,
        zones: Sequence[Zone],
        hold: bool = False,
        witness: float | None = None,
    ) -> None:
        self.calc = calc
        self.t0 = t0
        self.zones = list(zones)
        self.pieces: list[Piece] = []
        self.cursor = 0
        self.relaxed = False  # a cap had to be raised (override lowered faster than braking)
        self.failures = 0  # zone profiles ruckig refused
        self.stalled = False  # the plan stops early because of such a refusal
        self._state = (t0, s0, v0, a0)
        self.b: list[float] = []
        self._first: Trajectory | None = None
        # velocity the previous plan had at the end of the first zone (with zero acceleration):
        # always reachable from the current state, so the fallback when a new cap is not
        self.witness = witness
        if hold or not self.zones:
            self._hold(t0, s0, v0, a0)
            self.b = []
        else:
            self._passes(s0, v0, a0)

    # -- planning ------------------------------------------------------------------------------
    def _hold(self, t0: float, s0: float, v0: float, a0: float) -> None:
        """Stop as soon as the path allows: brake inside the zone if the stop fits there;
        otherwise reach the zone end at the lowest velocity the zone's limits permit (which
        never exceeds its transition cap, the previous plan being a witness) with zero path
        acceleration, as every transition needs, and go on zone by zone."""
        t, s, v, a = t0, s0, v0, a0
        for k, z in enumerate(self.zones):
            if abs(v) < 1e-12 and abs(a) < 1e-12:
                break
            brake = self.calc.brake(s, v, a, z.a_max, z.j_max)
            s_stop = brake.at_time(brake.duration)[0][0]
            if s_stop <= z.s1 + 1e-12:
                self.pieces.append(Piece(t, brake.duration, brake, s_stop, -1))
                t, s, v, a = t + brake.duration, s_stop, 0.0, 0.0
                break
            if k == 0:
                self.zones = [dataclasses.replace(z, v_cap=0.0) for z in self.zones]
                try:
                    low = self._first_target(s, v, a, 0.0)
                except PlanError:
                    self.failures += 1  # last resort: a plain brake (counted, never expected)
                    self.pieces.append(Piece(t, brake.duration, brake, s_stop, -1))
                    t, s = t + brake.duration, s_stop
                    break
                assert self._first is not None
                traj = self._first
            else:
                length = (z.s1 - z.s0) * (1.0 - MARGIN)
                low = max(lowest_reachable(v, length, z.a_max, z.j_max), 1e-9)
                try:
                    traj = self.calc.position(s, v, 0.0, z.s1, low, low, z.a_max, z.j_max)
                except PlanError:
                    # `low` is just below v on a very short zone: ruckig's brake pre-phase to
                    # v_max = low cannot also meet the position (lifting seed 1651); allowing
                    # the current velocity reaches the same end state a little later
                    try:
                        traj = self.calc.position(
                            s, v, 0.0, z.s1, low, max(v, low), z.a_max, z.j_max
                        )
                    except PlanError:
                        self.failures += 1  # last resort, as above
                        self.pieces.append(Piece(t, brake.duration, brake, s_stop, -1))
                        t, s = t + brake.duration, s_stop
                        break
            self.pieces.append(Piece(t, traj.duration, traj, z.s1, k + 1, low))
            t, s, v, a = t + traj.duration, z.s1, low, 0.0
        self.pieces.append(Piece(t, INF, None, s, -1))

    def _passes(self, s0: float, v0: float, a0: float) -> None:
        zones = self.zones
        n = len(zones)
        b = [0.0] * (n + 1)  # b[i]: velocity at the start of zone i; b[n] = 0 (window end)
        for i in range(1, n):
            b[i] = min(zones[i].entry_cap, zones[i - 1].v_cap, zones[i].v_cap)
        for i in range(n - 1, 0, -1):  # backward: every later cap must stay reachable
            z = zones[i]
            length = (z.s1 - z.s0) * (1.0 - MARGIN)
            b[i] = min(b[i], reach_velocity(b[i + 1], length, z.a_max, z.j_max))
        b[1] = self._first_target(s0, v0, a0, b[1])
        for i in range(1, n):  # forward: what is reachable from the previous boundary
            z = zones[i]
            length = (z.s1 - z.s0) * (1.0 - MARGIN)
            b[i + 1] = min(b[i + 1], reach_velocity(b[i], length, z.a_max, z.j_max))
            if b[i + 1] < b[i] and change_distance(b[i], b[i + 1], z.a_max, z.j_max) > length * (
                1.0 + FEASIBILITY_TOL
            ):  # only after an earlier relaxation: b[i] is above what the backward pass allowed
                b[i + 1] = lowest_reachable(b[i], length, z.a_max, z.j_max)
                self.relaxed = True
        b[0] = v0
        self.b = b

    def _feasible(
        self, s0: float, v0: float, a0: float, target: float, cap: float | None = None
    ) -> Trajectory | None:
        z = self.zones[0]
        v_max = max(z.v_cap if cap is None else cap, target)
        try:
            return self.calc.position(s0, v0, a0, z.s1, target, v_max, z.a_max, z.j_max)
        except PlanError:
            return None

    def _first_target(self, s0: float, v0: float, a0: float, wanted: float) -> float:
        """The velocity at the end of the current zone: `wanted` if reachable from the current
        state, else the nearest reachable value (found by bisection on ruckig feasibility)."""
        traj = self._feasible(s0, v0, a0, wanted)
        if traj is not None:
            self._first = traj
            return wanted
        if self.witness is not None:  # feasible under the previous plan's cap (≥ v0)
            traj = self._feasible(s0, v0, a0, self.witness, max(self.zones[0].v_cap, v0))
            if traj is not None:
                self._first = traj
                self.relaxed = self.relaxed or self.witness > wanted
                return self.witness
        z = self.zones[0]
        brake = self.calc.brake(s0, v0, a0, z.a_max, z.j_max)
        s_brake = brake.at_time(brake.duration)[0][0]
        too_low = s_brake > z.s1  # cannot slow down to `wanted` in time
        lo, hi = (wanted, max(v0, wanted) + 1.0) if too_low else (0.0, wanted)
        best: Trajectory | None = None
        best_v = lo if not too_low else hi
        for _ in range(40):
            mid = 0.5 * (lo + hi)
            traj = self._feasible(s0, v0, a0, mid)
            if traj is not None:
                best, best_v = traj, mid
                if too_low:
                    hi = mid
                else:
                    lo = mid
            elif too_low:
                lo = mid
            else:
                hi = mid
        if best is None:
            raise PlanError(f"no feasible velocity at s = {z.s1:.6f} m from v = {v0:.6f} m/s")
        self.relaxed = self.relaxed or too_low
        self._first = best
        return best_v

    # -- pieces ----------------------------------------------------------------------------------
    def _piece(self, i: int) -> Piece:
        """Build piece i (zone i of the window) on demand."""
        while len(self.pieces) <= i:
            k = len(self.pieces)
            if not self.b:  # hold plan: all pieces exist
                return self.pieces[-1]
            if k >= len(self.zones) or self.stalled:
                last = self.pieces[-1] if self.pieces else None
                t_end = last.t0 + last.duration if last else self.t0
                s_end = self.zones[-1].s1
                self.pieces.append(Piece(t_end, INF, None, s_end, -1))
                continue
            z = self.zones[k]
            if k == 0:
                assert self._first is not None
                traj = self._first
            else:
                traj = self._zone_profile(k)
            t_start = self.t0 if k == 0 else self.pieces[-1].t0 + self.pieces[-1].duration
            if traj is None:  # ruckig refused: stop on the spot, the interpolator re-plans
                brake = self.calc.brake(z.s0, self.b[k], 0.0, z.a_max, z.j_max)
                p_end = brake.at_time(brake.duration)[0][0]
                self.pieces.append(Piece(t_start, brake.duration, brake, p_end, -1))
                self.pieces.append(Piece(t_start + brake.duration, INF, None, p_end, -1))
                self.zones = self.zones[:k]
                self.stalled = True
                continue
            self.pieces.append(Piece(t_start, traj.duration, traj, z.s1, k + 1, self.b[k + 1]))
        return self.pieces[i]

    def _zone_profile(self, k: int) -> Trajectory | None:
        """Profile of zone k from (s_k, b_k) to (s_k+1, b_k+1). The closed-form passes can put
        b_k+1 exactly on the edge of what is reachable; ruckig's own rounding (~1e-8 m/s) may
        then refuse it, so the target is nudged by a hair, lower first (never above a cap).
        None if ruckig still refuses: the plan ends there with a stop (counted)."""
        z = self.zones[k]
        b0, b1 = self.b[k], self.b[k + 1]
        for target in (b1, b1 * (1 - 1e-7) - 1e-9, min(b1 * (1 + 1e-7) + 1e-9, z.v_cap)):
            if target < 0.0:
                continue
            try:
                # max(…, b0): a zone entered above its soft cap (after a relaxation) slows down
                # within the zone as the passes planned, without a separate brake pre-phase
                traj = self.calc.position(
                    z.s0, b0, 0.0, z.s1, target, max(z.v_cap, target, b0), z.a_max, z.j_max
                )
            except PlanError:
                continue
            self.b[k + 1] = target
            return traj
        self.failures += 1
        return None

    def boundary_time(self, index: int) -> float:
        """Absolute time at which the path reaches window boundary `index` (1 = end of the
        first zone). Builds the pieces up to it."""
        if not self.b:  # hold plan: only boundaries the brake still passes are reached
            for piece in self.pieces:
                if piece.boundary == index:
                    return piece.t0 + piece.duration
            return INF
        piece = self._piece(index - 1)
        return piece.t0 + piece.duration

    @property
    def end_time(self) -> float:
        if not self.b:
            first = self.pieces[0]
            return first.t0 + first.duration if first.traj is not None else self.t0
        return self.boundary_time(len(self.zones))

    def sample(self, t: float) -> tuple[float, float, float, int]:
        """(s, v, a, index of the piece) at absolute time t ≥ t0."""
        i = self.cursor
        piece = self._piece(i)
        while t >= piece.t0 + piece.duration and piece.duration != INF:
            i += 1
            piece = self._piece(i)
        self.cursor = i
        if piece.traj is None:
            return piece.s_end, 0.0, 0.0, i
        p, v, a = piece.traj.at_time(t - piece.t0)
        return p[0], v[0], a[0], i

    def velocity_at_end_of(self, boundary: int, piece: int) -> float | None:
        """If piece `piece` (the one being followed) is the zone profile ending at window
        boundary `boundary`, its end velocity (with zero acceleration there), else None."""
        if piece < len(self.pieces) and self.pieces[piece].boundary == boundary:
            return self.pieces[piece].v_end
        return None

    def is_zone_piece(self, i: int) -> bool:
        return self._piece(i).boundary >= 0

    def passage(self, i: int, s: float, t_default: float) -> tuple[float, float, float]:
        """(absolute time, velocity, acceleration) when piece i first reaches position s."""
        piece = self._piece(i)
        if piece.traj is None:
            return t_default, 0.0, 0.0
        local = piece.traj.get_first_time_at_position(0, s)
        if local is None:
            return t_default, 0.0, 0.0
        _, v, a = piece.traj.at_time(local)
        return piece.t0 + local, v[0], a[0]

    def piece_end(self, i: int) -> tuple[float, int, float]:
        """(absolute end time, boundary reached, velocity there) of piece i."""
        piece = self._piece(i)
        return piece.t0 + piece.duration, piece.boundary, piece.v_end
