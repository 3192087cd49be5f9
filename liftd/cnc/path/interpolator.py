"""Cyclic path interpolator: follows a plan, re-plans on override / feed hold / look-ahead
advance, and reports every boundary it passes with the exact (sub-cycle) time.

Override and feed hold act with the planned limits: a re-plan always starts from the sampled
state (s, v, a) of the current cycle, so the path velocity and acceleration stay continuous.
"""

from __future__ import annotations

from dataclasses import dataclass

from liftd.cnc.path.planner import Plan, PlanError, Ruckig1, Zone
from liftd.cnc.path.program import PathProgram

INF = float("inf")
EPS_S = 1e-12  # m


@dataclass(frozen=True, slots=True)
class Crossing:
    boundary: int  # absolute boundary index
    t: float  # absolute time the path reaches it
    at_rest: bool  # the path stops there (end of the plan)
    v: float  # path velocity there (m/s)
    a: float = 0.0  # path acceleration there (m/s²); zero at the end of a zone profile


class Interpolator:
    """Path state over one path program. Drive with `advance(t)`; never raises for plan
    trouble: a failed plan becomes a hold (brake to rest) and `plan_errors` counts it."""

    def __init__(self, program: PathProgram, look_ahead: int) -> None:
        self.program = program
        self.look_ahead = max(1, look_ahead)
        self.calc = Ruckig1()
        self.s = 0.0
        self.v = 0.0
        self.a = 0.0
        self.segment = 0  # segment containing s (boundary index behind the path)
        self.override = 1.0
        self.hold = False
        self.plan: Plan | None = None
        self.window_start = 0  # segment index of the plan's first zone
        self.window_end = 0  # boundary index of the plan's end
        self.piece = 0
        self.acked_conditional: set[int] = set()  # MVS_SNS boundaries acknowledged in time
        self.lift_stops: set[int] = set()  # boundaries where the path waits for Z
        self.plan_errors = 0
        self.last_plan_error = ""
        self.stopped_at: int | None = 0  # boundary where the path rests (waits), if any
        self.t_state = 0.0  # time of (s, v, a)

    # -- planning --------------------------------------------------------------------------------
    def _is_stop(self, k: int) -> bool:
        b = self.program.boundaries[k]
        return (
            b.stop
            or k in self.lift_stops
            or (b.conditional_stop and k not in self.acked_conditional)
        )

    def add_lift_stop(self, k: int) -> None:
        """The path must wait at boundary k for the lift axis (Z cannot make it in time)."""
        if k in self.lift_stops:
            return
        self.lift_stops.add(k)
        if self.stopped_at is None:
            self.replan(self.t_state)

    def drop_lift_stop(self, k: int) -> None:
        self.lift_stops.discard(k)

    def _window(self, override: float, nominal: bool = False) -> tuple[list[Zone], int]:
        segs = self.program.segments
        first = self.segment
        zones: list[Zone] = []
        k = first
        while k < len(segs):
            seg = segs[k]
            if nominal:
                cap = min(seg.feed * override, seg.v_phys)
            else:
                cap = min(min(seg.feed, seg.v_lift_ov) * override, seg.v_phys, seg.v_lift)
            entry = 0.0 if k > first and self._is_stop(k) else self.program.boundaries[k].v_cap
            zones.append(Zone(seg.s0, seg.s0 + seg.length, cap, seg.a_max, seg.j_max, entry))
            k += 1
            if self._is_stop(k) or len(zones) >= self.look_ahead:
                break
        return zones, k

    def replan(self, t: float) -> None:
        """New plan from the current state, which is taken to hold at absolute time t."""
        zones, end = self._window(self.override)
        hold = self.hold or self.override <= 0.0
        witness = self._witness()
        try:
            self.plan = Plan(self.calc, t, self.s, self.v, self.a, zones, hold, witness)
        except PlanError as exc:
            self.plan_errors += 1
            self.last_plan_error = str(exc)
            self.plan = Plan(self.calc, t, self.s, self.v, self.a, zones, True, witness)
        self.window_start = self.segment
        self.window_end = end
        self.piece = 0

    def _witness(self) -> float | None:
        """End velocity of the zone profile being followed (see Plan.witness)."""
        old = self.plan
        if old is None:
            return None
        return old.velocity_at_end_of(self.segment + 1 - self.window_start, self.piece)

    def set_inputs(self, override: float, hold: bool) -> None:
        """Apply override (fraction) and feed hold from the time of the current state on;
        re-plans only on a change."""
        if override == self.override and hold == self.hold and self.plan is not None:
            return
        self.override = override
        self.hold = hold
        if self.stopped_at is None:
            self.replan(self.t_state)

    def trial_time(self, k: int, override: float, nominal: bool = False) -> float:
        """Absolute arrival time at boundary k if the path were re-planned now with `override`
        (and, if `nominal`, without the lift caps); the current plan is left alone."""
        if self.stopped_at is not None and not nominal:
            return INF
        zones, end = self._window(override, nominal)
        try:
            plan = Plan(
                self.calc,
                self.t_state,
                self.s,
                self.v,
                self.a,
                zones,
                override <= 0.0,
                self._witness(),
            )
        except PlanError:
            return -INF  # cannot tell: callers must treat it as "not enough time"
        rel = min(k, end) - self.segment
        return plan.boundary_time(rel) if rel > 0 else self.t_state

    def resume(self, t: float) -> None:
        """Leave the boundary where the path waits (all its actions are done) at time t."""
        self.stopped_at = None
        self.t_state = t
        self.replan(t)

    def acknowledge_conditional(self, boundary: int) -> None:
        """An MVS_SNS M function was acknowledged before the path got there: drop the stop."""
        if boundary in self.acked_conditional:
            return
        self.acked_conditional.add(boundary)
        if self.stopped_at is None and self.window_start <= boundary <= self.window_end:
            self.replan(self.t_state)

    # -- motion ----------------------------------------------------------------------------------
    def advance(self, t: float) -> list[Crossing]:
        """Move to absolute time t; returns the boundaries passed or reached since the last call."""
        crossings: list[Crossing] = []
        if self.stopped_at is not None or self.plan is None:
            return crossings
        plan = self.plan
        retries = 0
        while True:
            s, v, a, piece = plan.sample(t)
            while self.piece < piece:
                t_end, rel, v_end = plan.piece_end(self.piece)
                self.piece += 1
                if rel < 0:
                    continue
                k = self.window_start + rel
                rest = k >= self.window_end and self._is_stop(k)
                crossings.append(Crossing(k, t_end, rest, 0.0 if rest else v_end))
                self.segment = min(k, len(self.program.segments) - 1) if not rest else k
                if rest:
                    self.s, self.v, self.a = self.program.boundaries[k].s, 0.0, 0.0
                    self.stopped_at = k
                    self.t_state = t_end
                    return crossings
            arrived = self._catch_up(plan, piece, s, t, crossings)
            if arrived is not None:  # arrived at a stop while braking
                k = arrived
                self.s, self.v, self.a = self.program.boundaries[k].s, 0.0, 0.0
                self.t_state = crossings[-1].t
                return crossings
            self.s, self.v, self.a = s, v, a
            self.t_state = t
            if plan.stalled and v == 0.0 and a == 0.0 and retries < 3:
                retries += 1  # a zone profile was refused: try again from rest
                self.plan_errors += 1
                self.last_plan_error = "zone profile refused by ruckig"
                self.replan(t)
                plan = self.plan
                assert plan is not None
                continue
            if self._needs_extension():
                self.replan(t)
                plan = self.plan
                assert plan is not None
                continue
            return crossings

    def _catch_up(
        self, plan: Plan, piece: int, s: float, t: float, out: list[Crossing]
    ) -> int | None:
        """Report boundaries passed inside a piece that is not a zone profile (a brake for feed
        hold or override 0, or the stop after a refused profile), with their exact times."""
        if plan.is_zone_piece(piece):
            return None  # zone profiles report their end boundary themselves (exact time)
        bounds = self.program.boundaries
        last = len(self.program.segments)
        while self.segment < last and s >= bounds[self.segment + 1].s - EPS_S:
            k = self.segment + 1
            t_k, v_k, a_k = plan.passage(piece, bounds[k].s, t)
            if self._is_stop(k):
                # A brake ends exactly on a stop (the plan was stopping there anyway): arrive.
                # It never passes one; if it ever does, that is counted as a plan error.
                if abs(v_k) > 1e-9:
                    self.plan_errors += 1
                    self.last_plan_error = f"passed the stop at boundary {k} while braking"
                out.append(Crossing(k, t_k, True, 0.0))
                self.segment = k
                self.stopped_at = k
                return k
            out.append(Crossing(k, t_k, False, v_k, a_k))
            self.segment = k if k < last else last - 1
            if k == last:
                break
        return None

    def _needs_extension(self) -> bool:
        """Re-plan when half the window is behind us and its end is not a real stop, so the
        stop the plan makes at the window end never becomes binding unless the look-ahead is
        really too short (as on the CNC)."""
        if self.hold or self.window_end >= len(self.program.segments):
            return False
        if self._is_stop(self.window_end):
            return False
        zones = self.window_end - self.window_start
        return self.segment - self.window_start >= max(1, zones // 2)

    # -- queries ---------------------------------------------------------------------------------
    def arrival(self, k: int) -> float:
        """Absolute time the path reaches boundary k under the current plan and override; the
        window end (a stop) stands in when k lies beyond the look-ahead (an earlier, safe time).
        The state time if the path is there already; inf while holding or waiting before k."""
        if self.stopped_at is not None:
            return self.t_state if self.stopped_at == k else INF
        if self.plan is None:
            return INF
        rel = min(k, self.window_end) - self.window_start
        if rel <= 0:
            return self.t_state
        return self.plan.boundary_time(rel)

    def position(self) -> tuple[float, ...]:
        """Command positions of all axes at the current path position."""
        segs = self.program.segments
        if not segs:
            return self.program.start_position
        seg = segs[min(self.segment, len(segs) - 1)]
        if self.segment >= len(segs):
            return self.program.end_position
        return seg.geom.position(min(max(self.s - seg.s0, 0.0), seg.length))
