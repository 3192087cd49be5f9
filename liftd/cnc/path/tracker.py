"""The path motion generator: s(t) along a prepared path, jerk-limited, with continuous
acceleration inside a run, O(1) work per cycle away from constraints.

The motion is always the time-optimal ruckig profile (`liftd.cnc.ruckig1`) toward one goal:

* *cruise*: reach the ceiling of the current segment (velocity interface), or 0 under a hold;
* *target*: arrive at a constraint boundary ahead (position interface) with its effective cap
  and zero acceleration.

Each step proposes the state at the end of the step along the current profile and checks every
constraint within the braking horizon: its *slack* = distance left − least distance the path
needs to get below its cap (closed forms in `velocity.py`). If a slack would become negative,
the step is re-planned from its start toward that constraint: the time-optimal profile then
switches from accelerating or cruising to braking at the exact instant inside the cycle. Steps
are cut where the path reaches a boundary that changes the ceiling or the run, or a constraint,
or where a target profile ends; there the profile is re-planned from the exact state.

Effective caps come from a backward pass over the constraints up to the next run boundary (and,
for that boundary, beyond it as far as they can matter): a cap that a later constraint makes
unreachable is lowered, so arriving at a constraint with zero acceleration below its effective
cap leaves every later one reachable. The look-ahead window ends `look_ahead` segments after the
current one with a stop the path must be able to make; it moves with the path, so the path
never actually stops there (except when the window is a single block).

Hard constraints (transition caps, axis caps, stops, zero acceleration at run boundaries) are
never violated; a feed ceiling (F × override) that a sudden override decrease makes unreachable
is approached as fast as the limits allow. Anything ruckig refuses is counted in `errors` and
answered with a brake (never expected; the closed-loop tests count them).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

from ruckig import Trajectory

from liftd.cnc.path.table import PathTable
from liftd.cnc.path.velocity import (
    brake_distance,
    lowest_reachable_from,
    projected_velocity,
    ramp_distance,
    reach_velocity,
)
from liftd.cnc.ruckig1 import ProfileError, Ruckig1

INF = float("inf")
EPS_S = 1e-12  # m: a boundary counts as reached within this distance
MAX_CANDIDATES = 24  # constraints considered at once; beyond, the last one counts as a stop
SLACK_TOL = 1e-9  # m
CAP_TOL = 1e-6  # relative: a crossing velocity within this of its cap is at the cap
GATE_TOL = 1e-6  # m/s²: zero acceleration at a run boundary, within ruckig's precision
CRUISE = -1
BRAKE = -2


@dataclass(frozen=True, slots=True)
class Crossing:
    boundary: int
    t: float  # exact time the path reaches the boundary
    at_rest: bool  # the path stops there (a stop, or a refused plan)
    v: float  # path velocity there (m/s)
    a: float = 0.0  # path acceleration there (m/s²)


class _Plan:
    """A ruckig profile started at t0, extended at constant velocity after its end; its end
    snaps to the goal (target position, goal velocity) it was planned for."""

    __slots__ = ("dur", "goal", "p_end", "t0", "traj", "v_end", "window")

    def __init__(
        self, traj: Trajectory, t0: float, goal: int, window: int, p_goal: float | None,
        v_goal: float,
    ) -> None:  # fmt: skip
        self.traj = traj
        self.t0 = t0
        self.goal = goal  # CRUISE, BRAKE or the target boundary
        self.window = window  # window end when planned
        self.dur: float = float(traj.duration)
        p, v, _ = traj.at_time(self.dur)
        p_end, v_end = float(p[0]), float(v[0])
        self.p_end = p_goal if p_goal is not None and abs(p_end - p_goal) <= 1e-9 else p_end
        self.v_end = v_goal if abs(v_end - v_goal) <= 1e-9 else max(v_end, 0.0)

    def at(self, t: float) -> tuple[float, float, float]:
        local = t - self.t0
        if local >= self.dur:
            return self.p_end + self.v_end * (local - self.dur), self.v_end, 0.0
        local = max(0.0, local)
        p, v, a = self.traj.at_time(local)
        return p[0], v[0], a[0]

    def time_at(self, s: float, t_default: float) -> float:
        """Absolute time the plan first reaches position s (t_default if it never does)."""
        if s >= self.p_end:
            if self.v_end > 0.0:
                return self.t0 + self.dur + (s - self.p_end) / self.v_end
            return self.t0 + self.dur if s <= self.p_end + EPS_S else t_default
        local = self.traj.get_first_time_at_position(0, s)
        return t_default if local is None else self.t0 + float(local)


class Tracker:
    """Path state (t, s, v, a, seg) over one table; drive with `advance(t, dt)`."""

    def __init__(
        self,
        table: PathTable,
        look_ahead: int,
        lift_stops: set[int] | None = None,
        acked: set[int] | None = None,
    ) -> None:
        self.tb = table
        self.look_ahead = max(1, look_ahead)
        self.calc = Ruckig1()
        self.t = 0.0
        self.s = table.s[0] if table.s else 0.0
        self.v = 0.0
        self.a = 0.0
        self.seg = 0  # segment containing s (its start boundary is behind the path)
        self.stopped_at: int | None = 0  # resting at this boundary until `resume`
        self.parked = False  # at rest under a hold, not at a stop
        self.ov = 1.0
        self.hold = False
        self.lift_stops = lift_stops if lift_stops is not None else set()
        self.acked = acked if acked is not None else set()
        self.plan: _Plan | None = None
        self.errors = 0
        self.last_error = ""

    # -- control --------------------------------------------------------------------------------
    def set_state(
        self, t: float, s: float, v: float, a: float, seg: int, stopped_at: int | None
    ) -> None:
        self.t, self.s, self.v, self.a, self.seg = t, s, v, a, seg
        self.stopped_at = stopped_at
        self.parked = stopped_at is None and self.hold and v == 0.0 and a == 0.0
        self.plan = None

    def set_inputs(self, ov: float, hold: bool) -> None:
        hold = hold or ov <= 0.0
        if ov != self.ov or hold != self.hold:
            self.ov, self.hold = ov, hold
            self.plan = None
            if not hold:
                self.parked = False

    def resume(self, t: float) -> None:
        """Leave the stop where the path rests, at time t (its waiting actions are done)."""
        if self.stopped_at is None:
            return
        self.stopped_at = None
        self.t = max(self.t, t)
        self.plan = None

    def is_stop(self, b: int) -> bool:
        tb = self.tb
        return (
            b >= tb.n
            or tb.stop[b]
            or b in self.lift_stops
            or (tb.conditional[b] and b not in self.acked)
        )

    @property
    def window_end(self) -> int:
        return min(self.seg + self.look_ahead, self.tb.n)

    # -- constraints ----------------------------------------------------------------------------
    def _limits(self, seg: int) -> tuple[float, float]:
        tb = self.tb
        r = tb.run[seg if seg < tb.n else tb.n - 1]
        return tb.run_a[r], tb.run_j[r]

    @staticmethod
    def _horizon(v: float, a: float, a_max: float, j_max: float, dt: float) -> float:
        """Distance beyond which no constraint can bind within the next step."""
        stop = 0.0
        if projected_velocity(v, a, j_max) > 0.0:
            stop = brake_distance(v, a, 0.0, a_max, j_max)
        return stop + 2.0 * dt * (v + a_max * dt) + 1e-9

    def _ahead(self, b: int, w: int) -> Iterator[int]:
        """Constraint boundaries from b on (static ones, lift stops, the window end w)."""
        tb = self.tb
        n = tb.n
        lifts = sorted(k for k in self.lift_stops if b <= k <= w) if self.lift_stops else []
        i = 0
        nxt = tb.next_constraint[b] if b <= n else n + 1
        while True:
            k = nxt
            if i < len(lifts) and lifts[i] < k:
                k = lifts[i]
            if k >= w:
                yield w
                return
            yield k
            if i < len(lifts) and lifts[i] == k:
                i += 1
            if nxt == k:
                nxt = tb.next_constraint[k + 1] if k + 1 <= n else n + 1

    def _cap(self, b: int, w: int) -> tuple[float, bool, bool]:
        """(cap, zero acceleration required, stop) of constraint boundary b."""
        if b == w or self.is_stop(b):
            return 0.0, True, True
        return self.tb.entry_cap(b, self.ov), self.tb.gate[b], False

    def _collect(self, s: float, seg: int, reach: float) -> list[tuple[int, float, float, bool]]:
        """Constraints within `reach` of (s, seg), up to and including the first run boundary or
        stop: (boundary, position, effective cap, zero acceleration required)."""
        tb = self.tb
        n = tb.n
        out: list[tuple[int, float, float, bool]] = []
        if seg >= n:
            return out
        w = min(seg + self.look_ahead, n)
        limit = s + reach
        for b in self._ahead(seg + 1, w):
            s_b = tb.s[b]
            if s_b > limit:
                break
            cap, gate, stop = self._cap(b, w)
            if len(out) == MAX_CANDIDATES - 1:  # too many at once: the last counts as a stop
                cap, gate, stop = 0.0, True, True
            if gate and not stop and cap > 0.0:
                cap = min(cap, self._beyond(b, cap, w))
            out.append((b, s_b, cap, gate))
            if gate:
                break
        # backward: arriving at each one at its cap leaves every later one reachable
        for i in range(len(out) - 2, -1, -1):
            bi, si, ci, gi = out[i]
            bn, sn, cn, _ = out[i + 1]
            a_max, j_max = self._limits(bn - 1)
            lim = reach_velocity(cn, sn - si, a_max, j_max)
            if lim < ci:
                out[i] = (bi, si, lim, gi)
        return out

    def _beyond(self, g: int, cap: float, w: int) -> float:
        """Velocity at run boundary g (zero acceleration) from which every constraint after it
        up to the window end stays reachable; only constraints within the stopping distance
        from `cap` can lower it below `cap`."""
        tb = self.tb
        s_g = tb.s[g]
        chain: list[tuple[float, float, int]] = []
        for b in self._ahead(g + 1, w):
            a_max, j_max = self._limits(b - 1)
            if tb.s[b] - s_g > reach_velocity_inverse(cap, a_max, j_max):
                break
            c, _, stop = self._cap(b, w)
            chain.append((tb.s[b], c, b))
            if stop or len(chain) == MAX_CANDIDATES:
                chain[-1] = (tb.s[b], 0.0, b)
                break
        e = INF
        for i in range(len(chain) - 1, -1, -1):
            s_i, c_i, b_i = chain[i]
            e = min(c_i, e)
            s_prev = chain[i - 1][0] if i > 0 else s_g
            a_max, j_max = self._limits(b_i - 1)
            e = reach_velocity(e, s_i - s_prev, a_max, j_max)
        return e

    @staticmethod
    def _need(v: float, a: float, cap: float, gate: bool, a_max: float, j_max: float) -> float:
        """Least distance after which the path can be below `cap` (with zero acceleration where
        `gate`)."""
        if projected_velocity(v, a, j_max) > cap:
            return brake_distance(v, a, cap, a_max, j_max)
        return ramp_distance(v, a, j_max) if gate else 0.0

    # -- planning -------------------------------------------------------------------------------
    def _replan(self, dt: float, force: int | None = None) -> None:
        tb = self.tb
        s, v, a, seg = self.s, self.v, self.a, self.seg
        a_max, j_max = self._limits(seg)
        ceiling = 0.0 if self.hold else tb.ceiling(seg if seg < tb.n else tb.n - 1, self.ov)
        w = self.window_end
        v_p = projected_velocity(v, a, j_max)
        best: tuple[int, float, float, bool] | None = None
        best_slack = INF
        reach = INF if force is not None else self._horizon(v, a, a_max, j_max, dt)
        cands = self._collect(s, seg, reach)
        if force is not None and all(c[0] != force for c in cands):
            force = None  # not a constraint from here: the most binding one
        for c in cands:
            b, s_c, cap, gate = c
            if force is not None and b != force:
                continue
            if not gate and v_p <= cap:
                continue  # cannot bind from here
            slack = s_c - s - self._need(v, a, cap, gate, a_max, j_max)
            if slack < best_slack:
                best, best_slack = c, slack
        if best is None:
            self._cruise(ceiling, a_max, j_max, w)
            return
        b, s_c, cap, gate = best
        d = s_c - s
        if self.hold or best_slack < -SLACK_TOL:
            target = min(cap, lowest_reachable_from(v, a, d, a_max, j_max))
        elif v_p > cap:
            target = cap
        else:  # only the zero acceleration binds: a velocity surely reachable at s_c
            ramp = ramp_distance(v, a, j_max)
            target = min(
                cap, max(ceiling, v_p), reach_velocity(v_p, max(d - ramp, 0.0), a_max, j_max)
            )
        v_max = max(v, target, 1e-12) if self.hold else max(ceiling, target, 1e-12)
        for tgt in (target, target * (1.0 + 1e-7) + 1e-10, target * (1.0 - 1e-7)):
            try:
                traj = self.calc.position(s, v, a, s_c, tgt, max(v_max, tgt), a_max, j_max)
            except ProfileError as exc:
                self.last_error = str(exc)
                continue
            self.plan = _Plan(traj, self.t, b, w, s_c, tgt)
            return
        self._count(f"target profile refused at boundary {b}")
        self._brake(a_max, j_max, w)

    def _cruise(self, ceiling: float, a_max: float, j_max: float, w: int) -> None:
        try:
            traj = self.calc.velocity(self.s, self.v, self.a, ceiling, a_max, j_max)
        except ProfileError as exc:
            self._count(f"cruise profile refused: {exc}")
            self._brake(a_max, j_max, w)
            return
        self.plan = _Plan(traj, self.t, CRUISE, w, None, ceiling)

    def _brake(self, a_max: float, j_max: float, w: int) -> None:
        """Last resort: brake to rest (never expected; counted)."""
        traj = self.calc.velocity(self.s, self.v, self.a, 0.0, a_max, j_max)
        self.plan = _Plan(traj, self.t, BRAKE, w, None, 0.0)

    def _count(self, what: str) -> None:
        self.errors += 1
        self.last_error = what

    # -- motion ---------------------------------------------------------------------------------
    def advance(self, t_new: float, dt: float) -> list[Crossing]:
        """Move to time t_new; the boundaries reached on the way that have actions, or where the
        path stops, with their exact times."""
        out: list[Crossing] = []
        tb = self.tb
        n = tb.n
        forced = 0
        for _ in range(100_000):  # bounded: each pass ends the step, or at a boundary / plan end
            if self.stopped_at is not None or self.t >= t_new:
                return out
            if self.parked:
                self.t = t_new  # holding at rest: time goes on
                return out
            if self.hold and self.v == 0.0 and self.a == 0.0:
                self.parked = True
                self.t = t_new
                return out
            plan = self.plan
            if plan is None or (plan.goal >= 0 and plan.window != self.window_end):
                self._replan(dt)
                plan = self.plan
                assert plan is not None
            t_end = t_new
            if plan.goal != CRUISE and plan.t0 + plan.dur < t_end:
                t_end = plan.t0 + plan.dur  # the goal is reached inside this step
            s1, v1, a1 = plan.at(t_end)
            w = self.window_end
            cut = -1
            b = self.seg + 1
            while b <= n and s1 >= tb.s[b] - EPS_S:
                if tb.replan[b] or b == w or b in self.lift_stops:
                    cut = b
                    break
                b += 1
            if cut >= 0:
                t_end = min(max(plan.time_at(tb.s[cut], t_end), self.t), t_end)
                _, v1, a1 = plan.at(t_end)
                s1 = tb.s[cut]
                seg1 = cut
            else:
                seg1 = b - 1
            v1 = max(v1, 0.0)
            if forced < 4:
                violated = self._violated(s1, v1, a1, seg1, dt, plan.goal)
                if violated is not None:
                    forced += 1
                    # the window end seen from the end state lies beyond the one seen now
                    self._replan(dt, force=min(violated, self.window_end))
                    continue
            self._commit(t_end, s1, v1, a1, seg1, cut, plan, out)
            forced = 0
            if cut >= 0:
                self._arrive(cut, out)
            elif plan.goal >= 0 and self.t >= plan.t0 + plan.dur:
                self.plan = None  # a target reached between boundaries: plan the next one
            elif plan.goal == BRAKE and self.v == 0.0:
                self.plan = None
        self._count("advance did not converge")
        return out

    def _violated(self, s: float, v: float, a: float, seg: int, dt: float, goal: int) -> int | None:
        """The first constraint that could no longer be kept from (s, v, a), if any."""
        a_max, j_max = self._limits(seg)
        if v == 0.0 and a <= 0.0:
            return None
        for b, s_c, cap, gate in self._collect(s, seg, self._horizon(v, a, a_max, j_max, dt)):
            if b == goal:
                continue
            slack = s_c - s - self._need(v, a, cap, gate, a_max, j_max)
            if slack < -SLACK_TOL * (1.0 + s_c - s):
                return b
        return None

    def _commit(
        self, t: float, s: float, v: float, a: float, seg: int, cut: int, plan: _Plan,
        out: list[Crossing],
    ) -> None:  # fmt: skip
        """Move the state to (t, s, v, a); report the boundaries with actions passed on the way
        (the boundary the step was cut at is reported by `_arrive`)."""
        tb = self.tb
        for b in range(self.seg + 1, seg + 1):
            if b != cut and tb.needs_time[b]:
                t_b = plan.time_at(tb.s[b], t)
                _, v_b, a_b = plan.at(t_b)
                out.append(Crossing(b, t_b, False, max(v_b, 0.0), a_b))
        self.t, self.s, self.v, self.a = t, s, v, a
        self.seg = max(self.seg, seg)

    def _arrive(self, b: int, out: list[Crossing]) -> None:
        """The step ended exactly at boundary b: stop there, or check it and go on."""
        tb = self.tb
        t, v, a = self.t, self.v, self.a
        w = self.window_end
        self.plan = None
        if self.is_stop(b):
            if v > CAP_TOL:
                self._count(f"passed the stop at boundary {b} at {v:.6g} m/s")
            else:
                self.v = self.a = 0.0
                self.seg = b if b < tb.n else tb.n
                self.stopped_at = b
                out.append(Crossing(b, t, True, 0.0, 0.0))
                return
        if b == w and v <= CAP_TOL:
            self.v = self.a = v = a = 0.0  # the end of the look-ahead window: it moves on at once
        hard = min(tb.point_cap[b], tb.cap[b]) if b < tb.n else 0.0
        if v > hard * (1.0 + CAP_TOL) + 1e-12:
            self._count(f"boundary {b} reached at {v:.9g} m/s above its cap {hard:.9g}")
        if tb.gate[b] and abs(a) > GATE_TOL:
            self._count(f"run boundary {b} reached with acceleration {a:.3g} m/s²")
        elif tb.gate[b]:
            self.a = a = 0.0
        self.seg = b if b < tb.n else tb.n
        if tb.needs_time[b]:
            out.append(Crossing(b, t, False, v, a))


def reach_velocity_inverse(v: float, a_max: float, j_max: float) -> float:
    """Distance needed to brake from v (zero acceleration) to rest: constraints farther away
    than this cannot lower the velocity allowed at a point where the path runs at v."""
    if v <= 0.0:
        return 0.0
    return brake_distance(v, 0.0, 0.0, a_max, j_max)
