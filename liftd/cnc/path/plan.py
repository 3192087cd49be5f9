"""The profile the path tracker follows (`Plan`) and the boundaries it reports (`Crossing`):
a ruckig profile from the moment it was planned, extended at constant velocity after its end,
its end snapped to the goal it was planned for. Its times and positions are what the
tracker's steps are cut at; how the tracker chooses a profile is `tracker.py`."""

from __future__ import annotations

from ruckig import Trajectory

from liftd.cnc.ruckig1 import Evaluator, first_time_at

EPS_S = 1e-12  # m: a boundary counts as reached within this distance
CRUISE = -1
BRAKE = -2  # the last resort: to rest (counted as an error)
SETTLE = -3  # a brake at once to a velocity below the ceiling, re-planned at its end


class Crossing:
    """A boundary the path reaches. A plain class: a dataclass's generated `__init__` is a
    Python frame even in the compiled core (~4 % of a re-plan cycle, 2026-12-01)."""

    __slots__ = ("a", "at_rest", "boundary", "t", "v")

    def __init__(self, boundary: int, t: float, at_rest: bool, v: float, a: float = 0.0) -> None:
        self.boundary = boundary
        self.t = t  # exact time the path reaches the boundary
        self.at_rest = at_rest  # the path stops there (a stop, or a refused plan)
        self.v = v  # path velocity there (m/s)
        self.a = a  # path acceleration there (m/s²)

    def __repr__(self) -> str:
        return f"Crossing({self.boundary}, t={self.t}, at_rest={self.at_rest}, v={self.v})"


class Plan:
    """A ruckig profile started at t0, extended at constant velocity after its end; its end
    snaps to the goal (target position, goal velocity) it was planned for."""

    __slots__ = (
        "a_end",
        "aim",
        "dur",
        "ev",
        "goal",
        "p_end",
        "serves",
        "soft_from",
        "t0",
        "traj",
        "v_end",
        "window",
    )

    def __init__(
        self,
        traj: Trajectory,
        t0: float,
        goal: int,
        window: int,
        p_goal: float | None,
        v_goal: float,
    ) -> None:
        self.traj = traj
        self.t0 = t0
        self.goal = goal  # CRUISE, BRAKE, SETTLE or the target boundary
        self.serves = goal  # the constraint boundary the profile keeps (-1 for none)
        # constraint boundaries from here up to the goal are passed above their feed caps (only
        # their hard caps are kept): a feed cap the path cannot get down to (an override drop)
        # where zero acceleration would lose the goal (`Tracker._replan`)
        self.soft_from = goal
        self.window = window  # window end when planned
        self.dur: float = float(traj.duration)
        self.ev = Evaluator(traj)  # the cycles' states, natively from the second on
        p, v, _ = traj.at_time(self.dur)
        p_end, v_end = float(p[0]), float(v[0])
        self.p_end = p_goal if p_goal is not None and abs(p_end - p_goal) <= 1e-9 else p_end
        self.v_end = v_goal if abs(v_end - v_goal) <= 1e-9 else max(v_end, 0.0)
        # the acceleration at the goal: 0 but for `Aims.through`'s brake state (read
        # where the step reaches the goal; after the end the plan runs on at v_end)
        self.a_end = 0.0
        # the candidate an aimed profile keeps beyond its goal (`Aims.through`; -1 for
        # none): a re-plan from inside it collects its candidates at least that far
        self.aim = -1

    @property
    def keeps(self) -> int:
        """The last boundary it keeps: its goal, or for a brake at once (a goal < 0) the cap
        it serves (`Brakes.brake_through`, `dip_through`; `Targets.settle`'s last resort
        keeps it past the boundaries before that one)."""
        return max(self.goal, self.serves)

    def at(self, t: float) -> tuple[float, float, float]:
        local = t - self.t0
        # ended also where t0 + dur rounds to t0 (the steps' end time): a profile of 1.8e-16 s,
        # 0.68 nm before its goal, was read at its start, never reached its goal and was
        # planned again without end (feeds seed 601, `Tracker.advance` did not converge)
        if local >= self.dur or t >= self.t0 + self.dur:
            return self.p_end + self.v_end * (local - self.dur), self.v_end, 0.0
        return self.ev.at(max(0.0, local))

    def time_at(self, s: float, t_default: float) -> float:
        """Absolute time the plan first reaches position s (t_default if it never does)."""
        if s >= self.p_end:
            if self.v_end > 0.0:
                return self.t0 + self.dur + (s - self.p_end) / self.v_end
            return self.t0 + self.dur if s <= self.p_end + EPS_S else t_default
        local = first_time_at(self.traj, s)
        return t_default if local is None else self.t0 + local


class PathState:
    """The path's motion state and the profile it follows, shared by the tracker's parts
    (`Targets`, `Brakes`, `Tracker`): each reads it, `Tracker` moves it along the plan. A
    plain class, as `Crossing`."""

    __slots__ = ("a", "changed", "errors", "last_error", "plan", "s", "soft_from", "t", "v")

    def __init__(self, s: float) -> None:
        self.t = 0.0
        self.s = s
        self.v = 0.0
        self.a = 0.0
        self.plan: Plan | None = None
        self.soft_from = -1  # the target's Plan.soft_from (`Tracker._replan`)
        self.errors = 0  # profiles ruckig refused, answered with a brake (never expected)
        self.last_error = ""
        # (s, v, a) where an input last changed (`Targets.gap_rule`), None before any
        self.changed: tuple[float, float, float] | None = None


class Primed:
    """The profile a resting path will leave its stop with (`Tracker.plan_leaving`) and what
    choosing it left behind in the tracker."""

    __slots__ = ("last_error", "plan", "soft_from")

    def __init__(self, plan: Plan, soft_from: int, last_error: str) -> None:
        self.plan = plan
        self.soft_from = soft_from
        self.last_error = last_error
