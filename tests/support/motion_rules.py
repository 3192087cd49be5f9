"""What the rules of the CNC allow the path velocity to be (issue 36, item 2): the inputs of
the rules from the prepared program (ceilings, transition caps, stops, run boundaries, limits)
and what the constraints ahead allow at a boundary, in the check's own arithmetic (a
jerk-limited velocity change with zero acceleration at both ends, inverted by bisection), not
the tracker's closed forms: the check must not share the core's mistakes.
tests/support/motion_check.py walks a run's samples against them."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from liftd.cnc.path.program import PathProgram
from liftd.cnc.path.table import PathTable

CHAIN_SLACK = 5e-6  # m of path given up per link of a chain (the tracker keeps µm margins)
ABS_V = 1e-9  # m/s: a velocity this near a cap is at it
OPEN_GRID = 24  # end velocities a brake toward the window's end is read at (`least_brake`)
INF = math.inf


@dataclass(frozen=True, slots=True)
class Sample:
    """The path's state after one cycle and the inputs in effect in it."""

    t: float
    s: float
    v: float
    a: float
    seg: int
    stopped_at: int | None
    parked: bool
    override: float
    hold: bool
    lift_stops: frozenset[int]
    acked: frozenset[int]
    running: bool  # ACTIVE (not READY, HOLD after a PLC STOP, ERROR)


# -- a jerk-limited velocity change with zero acceleration at both ends ---------------------------
def change_distance(v0: float, v1: float, a_max: float, j_max: float) -> float:
    dv = abs(v1 - v0)
    if j_max == INF:
        t = dv / a_max
    elif dv * j_max <= a_max * a_max:
        t = 2.0 * math.sqrt(dv / j_max)
    else:
        t = dv / a_max + a_max / j_max
    return 0.5 * (v0 + v1) * t


def reach(v_end: float, length: float, a_max: float, j_max: float, top: float) -> float:
    """The highest velocity ≤ top from which v_end is reachable within `length` (equally: the
    highest reachable from v_end), by bisection on change_distance (increasing in the other
    end's velocity above v_end)."""
    if length <= 0.0 or top <= v_end:
        return min(v_end, top)
    return _highest(lambda v1: change_distance(v_end, v1, a_max, j_max), length, v_end, top)


def _highest(distance: Callable[[float], float], length: float, lo: float, top: float) -> float:
    """The highest end velocity in [lo, top] whose `distance` (increasing) is within `length`
    (lo's is), by 60 bisection steps."""
    if distance(top) <= length:
        return top
    return _edge(lambda v1: distance(v1) <= length, lo, top)


def reach_rising(v_end: float, length: float, a_max: float, j_max: float, top: float) -> float:
    """The highest velocity ≤ top from which every velocity ≥ v_end is reachable within
    `length`: the least `reach` over end velocities from v_end up. With a jerk limit `reach`
    falls from rest to a low end velocity and rises after it (braking to a third of a velocity
    takes longer than braking to rest), so a chain that ends at the window's end, whose rest
    becomes a cap as the window moves on, holds only what every higher end allows (the core's
    `reach_velocity_any_above`). A golden-section search where `reach` still falls at v_end."""
    r0 = reach(v_end, length, a_max, j_max, top)
    if r0 >= top or length <= 0.0:
        return r0
    step = max(v_end * 1e-4, 1e-9)
    if reach(v_end + step, length, a_max, j_max, top) >= r0:
        return r0
    g = (math.sqrt(5.0) - 1.0) / 2.0
    lo, hi = v_end, r0  # the least lies below r0: an end velocity is below its reach
    x1, x2 = hi - g * (hi - lo), lo + g * (hi - lo)
    f1, f2 = reach(x1, length, a_max, j_max, top), reach(x2, length, a_max, j_max, top)
    for _ in range(40):
        if f1 <= f2:
            hi, x2, f2 = x2, x1, f1
            x1 = hi - g * (hi - lo)
            f1 = reach(x1, length, a_max, j_max, top)
        else:
            lo, x1, f1 = x1, x2, f2
            x2 = lo + g * (hi - lo)
            f2 = reach(x2, length, a_max, j_max, top)
    return min(r0, f1, f2)


def _raise_distance(v: float, a: float, v1: float, a_max: float, j_max: float) -> float:
    """Distance from (v, a) to v1 ≥ v + a·|a|/2J with zero acceleration there, raising the
    acceleration at full jerk (up to a_max, held) and ramping it out: the largest acceleration
    at every velocity on the way, so the least distance (from a < 0 it ramps to 0 first)."""
    d = 0.0
    if a < 0.0:
        t0 = -a / j_max
        d = v * t0 + a * t0 * t0 / 2.0 + j_max * t0**3 / 6.0
        return d + change_distance(v - a * a / (2.0 * j_max), v1, a_max, j_max)
    peak = math.sqrt(j_max * (v1 - v) + a * a / 2.0)
    hold = 0.0
    if peak > a_max:
        peak = a_max
        hold = (v1 - v - (2.0 * a_max * a_max - a * a) / (2.0 * j_max)) / a_max
    t1, t3 = (peak - a) / j_max, peak / j_max
    d = v * t1 + a * t1 * t1 / 2.0 + j_max * t1**3 / 6.0
    u = v + a * t1 + j_max * t1 * t1 / 2.0
    d += u * hold + peak * hold * hold / 2.0
    u += peak * hold
    return d + u * t3 + peak * t3 * t3 / 2.0 - j_max * t3**3 / 6.0


Phase = tuple[float, float]  # (duration, jerk) of a motion's piece of constant jerk


def brake_distance(v: float, a: float, v1: float, a_max: float, j_max: float) -> float:
    """Least distance from (v, a) after which the path can be at v1 or below with zero
    acceleration, braking as hard as the limits allow (a positive acceleration ramped out
    first, the deceleration raised at full jerk up to a_max, held, ramped out); where ramping
    the acceleration out alone takes it there, that ramp's distance."""
    if j_max == INF:
        return max(v * v - v1 * v1, 0.0) / (2.0 * a_max)
    d = 0.0
    if a > 0.0:  # ramp the acceleration out first
        t0 = a / j_max
        d = v * t0 + a * t0 * t0 / 2.0 - j_max * t0**3 / 6.0
        v, a = v + a * a / (2.0 * j_max), 0.0
    dec = -a  # ≥ 0
    drop = v - v1
    if drop <= dec * dec / (2.0 * j_max):  # ramping out alone
        t3 = dec / j_max
        return d + v * t3 - dec * t3 * t3 / 2.0 + j_max * t3**3 / 6.0
    peak = math.sqrt(j_max * drop + dec * dec / 2.0)
    hold = 0.0
    if peak > a_max:
        peak = a_max
        hold = (drop - (2.0 * a_max * a_max - dec * dec) / (2.0 * j_max)) / a_max
    t1, t3 = max(peak - dec, 0.0) / j_max, peak / j_max
    d += v * t1 - dec * t1 * t1 / 2.0 - j_max * t1**3 / 6.0
    u = v - dec * t1 - j_max * t1 * t1 / 2.0
    d += u * hold - peak * hold * hold / 2.0
    u -= peak * hold
    return d + u * t3 - peak * t3 * t3 / 2.0 + j_max * t3**3 / 6.0


def brake_phases(v: float, a: float, v1: float, a_max: float, j_max: float) -> list[Phase]:
    """The brake from (v, a) to v1 with zero acceleration there, as hard as the limits allow
    (finite jerk): a positive acceleration ramped out first, the deceleration raised at full
    jerk up to a_max, held, ramped out; where ramping the deceleration out alone ends at or
    below v1, that ramp. The lowest velocity at every point on the way of any motion from
    (v, a) that keeps at or above v1: it loses velocity as fast as the limits allow until it
    must ramp the deceleration out."""
    out: list[Phase] = []
    if a > 0.0:  # ramp the acceleration out first
        out.append((a / j_max, -j_max))
        v, a = v + a * a / (2.0 * j_max), 0.0
    dec = -a  # ≥ 0
    drop = v - v1
    if drop <= dec * dec / (2.0 * j_max):  # ramping out alone
        return [*out, (dec / j_max, j_max)]
    if dec > a_max:  # above a_max (a lower limit ahead): down to it at full jerk first
        t0 = (dec - a_max) / j_max
        out.append((t0, j_max))
        v, dec = v - dec * t0 + j_max * t0 * t0 / 2.0, a_max
        drop = v - v1
    peak = math.sqrt(j_max * drop + dec * dec / 2.0)
    hold = 0.0
    if peak > a_max:
        peak = a_max
        hold = (drop - (2.0 * a_max * a_max - dec * dec) / (2.0 * j_max)) / a_max
    return [*out, (max(peak - dec, 0.0) / j_max, -j_max), (hold, 0.0), (peak / j_max, j_max)]


def travel(v: float, a: float, phases: list[Phase]) -> float:
    """The distance the phases cover from (v, a)."""
    d = 0.0
    for t, jk in phases:
        d += t * (v + t * (a / 2.0 + t * jk / 6.0))
        v, a = v + t * (a + t * jk / 2.0), a + jk * t
    return d


def velocity_at(v: float, a: float, phases: list[Phase], d: float) -> float:
    """The velocity `d` ahead of (v, a) along the phases (constant after the last one): the
    phase that passes d, and the time in it by bisection."""
    for t, jk in phases:
        step = t * (v + t * (a / 2.0 + t * jk / 6.0))
        if d <= step:
            lo, hi = 0.0, t
            for _ in range(40):
                tau = 0.5 * (lo + hi)
                if tau * (v + tau * (a / 2.0 + tau * jk / 6.0)) < d:
                    lo = tau
                else:
                    hi = tau
            return v + hi * (a + hi * jk / 2.0)
        d -= step
        v, a = v + t * (a + t * jk / 2.0), a + jk * t
    return v


def crossing_velocity(last: Sample, smp: Sample, s_b: float) -> float:
    """The velocity where the path passed s_b between two samples: the quintic through both
    samples' position, velocity and acceleration (the time found by bisection). Constant jerk
    from the first sample, which leaves the second's position and velocity out, read 25.047
    mm/s for 24.781 at a run boundary between two samples at −0.071 m/s² whose velocities
    differ by 0.40 mm/s (a brake between them: drops seed 1444), and the jerk gap after it
    from there (x2 the nearer side where from 24.781 x1 is)."""
    dt = smp.t - last.t
    if dt <= 0.0 or smp.s <= last.s:
        return smp.v
    d_s = smp.s - last.s - dt * (last.v + dt * last.a / 2.0)
    d_v = (smp.v - last.v - dt * last.a) * dt
    d_a = (smp.a - last.a) * dt * dt
    c3 = (20.0 * d_s - 8.0 * d_v + d_a) / (2.0 * dt**3)
    c4 = (-30.0 * d_s + 14.0 * d_v - 2.0 * d_a) / (2.0 * dt**4)
    c5 = (12.0 * d_s - 6.0 * d_v + d_a) / (2.0 * dt**5)
    lo, hi = 0.0, dt
    for _ in range(50):
        tau = 0.5 * (lo + hi)
        s = last.s + tau * (last.v + tau * (last.a / 2.0 + tau * (c3 + tau * (c4 + tau * c5))))
        if s < s_b:
            lo = tau
        else:
            hi = tau
    tau = 0.5 * (lo + hi)
    v = last.v + tau * (last.a + tau * (3.0 * c3 + tau * (4.0 * c4 + tau * 5.0 * c5)))
    return max(v, 0.0)


def jerk_gap(
    v: float, a: float, length: float, v1: float, a_max: float, j_max: float
) -> tuple[float, float] | None:
    """Where v1 lies in the jerk gap `length` ahead of (v, a): the path must brake to have v1
    there (v1 below the velocity ramping the acceleration out alone gives) and no brake has
    it there with zero acceleration (`brake_distance` longer than `length`). Then the nearest
    velocities it can have there with zero acceleration, (x1, x2): x1 below v1, x2 above it,
    by bisection (`brake_distance` rises from v1 = 0 to about a third of v and falls after
    it, so the velocities within `length` are [0, x1] and [x2, v + a·|a|/2J]; x2 is inf
    where not even ramping the acceleration out fits, x1 is −1 where not even rest is within
    `length`). Else None."""
    if j_max == INF or length <= 0.0:
        return None
    v_p = v + a * abs(a) / (2.0 * j_max)
    if v1 >= v_p or brake_distance(v, a, v1, a_max, j_max) <= length:
        return None

    def fits(x: float) -> bool:
        return brake_distance(v, a, x, a_max, j_max) <= length

    x1 = _edge(fits, 0.0, v1) if fits(0.0) else -1.0  # -1: not even rest is within length
    if not fits(v_p):
        return x1, INF  # not even the ramp-out alone fits: nothing above v1
    return x1, _edge(fits, v_p, v1)  # the ramp-out alone fits: x2 between it and v1


def _edge(fits: Callable[[float], bool], good: float, bad: float) -> float:
    """The value from `good` (one that fits) toward `bad` (one that does not) nearest `bad`
    for which `fits` holds, by 60 bisection steps."""
    for _ in range(60):
        mid = 0.5 * (good + bad)
        if fits(mid):
            good = mid
        else:
            bad = mid
    return good


def reach_from(v: float, a: float, length: float, a_max: float, j_max: float, top: float) -> float:
    """The highest velocity ≤ top the path can have with zero acceleration `length` ahead of
    (v, a) (bisection on `_raise_distance`, increasing in the end velocity); where ramping the
    acceleration out alone needs more, the velocity it ramps out to."""
    if j_max == INF:
        return reach(max(v, 0.0), length, a_max, j_max, top)
    v_p = v + a * abs(a) / (2.0 * j_max)
    if v_p >= top or _raise_distance(v, a, v_p, a_max, j_max) >= length:
        return min(v_p, top)
    return _highest(lambda v1: _raise_distance(v, a, v1, a_max, j_max), length, v_p, top)


class PathRules:
    """The rules' inputs from the prepared program: ceilings, caps, stops, run boundaries
    (where the path acceleration is zero), limits."""

    def __init__(self, prog: PathProgram, table: PathTable, look_ahead: int) -> None:
        self.segs = prog.segments
        self.bounds = prog.boundaries
        self.gate = table.gate
        self.run_j = tuple(table.run_j[r] for r in table.run)  # per segment: its run's jerk
        self.n = len(self.segs)
        self.look_ahead = max(1, look_ahead)
        self.v_top = max((seg.v_phys for seg in self.segs), default=0.0)
        self.a_low = min((seg.a_max for seg in self.segs), default=INF)
        self.j_low = min((seg.j_max for seg in self.segs), default=INF)

    def ceiling(self, k: int, ov: float) -> float:
        seg = self.segs[k]
        return min(min(seg.feed, seg.v_lift_ov) * ov, seg.v_phys, seg.v_lift)

    def hard(self, k: int) -> float:
        """The caps of segment k no override scales: the axes' and the lift's."""
        seg = self.segs[min(k, self.n - 1)]
        return min(seg.v_phys, seg.v_lift)

    def boundary_hard(self, b: int) -> float:
        """Boundary b's own caps no override scales: its transition cap and both segments'
        axis and lift caps."""
        return min(self.bounds[b].v_cap, self.hard(b - 1), self.hard(b))

    def run_jerk(self, k: int) -> float:
        """The jerk limit of segment k's run (the lowest of its segments')."""
        return self.run_j[min(k, self.n - 1)]

    def target(self, b: int, ov: float) -> float:
        """The velocity at boundary b by its own rule: the lower ceiling, the transition cap."""
        if b <= 0 or b >= self.n:
            return 0.0
        return min(self.ceiling(b - 1, ov), self.ceiling(b, ov), self.bounds[b].v_cap)

    def gate_within(self, b: int, length: float) -> bool:
        """A run boundary (zero acceleration there) or the program's end lies after boundary
        b within `length` of path."""
        s_b = self.bounds[b].s
        k = b + 1
        while k <= self.n and self.bounds[k].s - s_b < length:
            if k >= self.n or self.gate[k]:
                return True
            k += 1
        return False

    def is_stop(self, b: int, sample: Sample) -> bool:
        if b <= 0 or b >= self.n or self.bounds[b].stop or b in sample.lift_stops:
            return True
        return self.bounds[b].conditional_stop and b not in sample.acked

    def limits(self, lo: int, hi: int) -> tuple[float, float]:
        """The lowest acceleration and jerk limits of segments lo … hi − 1."""
        a = j = INF
        for k in range(max(lo, 0), min(max(hi, lo + 1), self.n)):
            a = min(a, self.segs[k].a_max)
            j = min(j, self.segs[k].j_max)
        return a, j

    def backward(self, b: int, sample: Sample, window_end: int) -> float:
        """What the boundaries after b up to `window_end` allow at b. Inside a run the path
        acceleration is continuous and one brake passes any number of caps; it is zero only at
        the run's end (a run boundary, a stop, the window's end). So b is held to the least,
        over the caps k of its run, of the velocity from which k's cap is reachable over
        s_k − s_b, and to the one from which the run's end is reachable with the value of its
        own chain (the same rule from there on; rest at a stop or the window's end). The caps
        that can bind are a stop, the window's end, a target below the ceiling before it and
        a run boundary, within the distance the path needs to stop from the program's highest
        velocity. Where the chain ends at the window's end, whose rest becomes a cap as the
        window moves, the run ends hold only what every higher end velocity allows
        (`reach_rising`); the caps inside a run do not depend on it."""
        ov = sample.override
        w = min(window_end, self.n)
        if w <= b:
            return 0.0
        s_b = self.bounds[b].s
        reach_d = 2.0 * change_distance(self.v_top, 0.0, self.a_low, self.j_low)
        nodes: list[tuple[int, float, bool]] = []  # (boundary, cap, ends a run)
        is_open = False  # the chain ends at the window's end: its rest may become a cap
        for k in range(b + 1, w + 1):
            if self.bounds[k].s - s_b > reach_d:
                break
            if k == w or self.is_stop(k, sample):
                nodes.append((k, 0.0, True))
                is_open = not self.is_stop(k, sample)
                break
            cap = self.target(k, ov)
            if self.gate[k] or cap < self.ceiling(k - 1, ov):
                nodes.append((k, cap, self.gate[k]))
        end: tuple[int, float] | None = None  # the next run end after the nodes walked: (k, e)
        inside: list[tuple[int, float]] = []  # the caps between the start and that run end
        for i in range(len(nodes) - 1, -2, -1):
            if i >= 0 and not nodes[i][2]:
                inside.append(nodes[i][:2])
                continue
            start = nodes[i][0] if i >= 0 else b
            e = self._run(start, inside, end, is_open)
            if i < 0:
                return e
            end, inside = (start, min(e, nodes[i][1])), []
        return INF  # not reached: the loop returns at i = −1

    def least_brake(
        self, b: int, v: float, a_floor: float, sample: Sample, window_end: int
    ) -> float:
        """The least deceleration (a ≤ 0, not below `a_floor`) with which the path can pass
        boundary b at v and still keep what lies after it up to `window_end`: each cap inside
        b's run at most at its target, and the run's end (a run boundary, a stop, the window's
        end) at its value with zero acceleration there (what the backward pass allows there;
        rest at a stop or the window's end). Read off the lowest motion from (v, a) that keeps
        at or above the lowest of those values (`brake_phases`, with the lowest limits up to
        the run's end): it passes each cap at or below it and reaches that value, with zero
        acceleration, before the run's end (where a cap inside the run is the lowest, that is
        more than the run's end needs, erring toward a harder brake). `a_floor` where not even
        it keeps them; else by bisection between the two. Where the run ends at the window's
        end, whose rest becomes a cap as the window moves, the run's end is also kept at
        every velocity below v (`OPEN_GRID` of them, as `reach_rising` does for the backward
        pass)."""
        ov = sample.override
        w = min(window_end, self.n)
        s_b = self.bounds[b].s
        reach_d = 2.0 * change_distance(self.v_top, 0.0, self.a_low, self.j_low)
        caps: list[tuple[float, float]] = []  # (distance, cap) below v inside the run
        end = INF  # the distance to the run's end
        is_open = False  # the run ends at the window's end: its rest may become any cap
        last = b + 1
        for k in range(b + 1, w + 1):
            d = self.bounds[k].s - s_b
            if d > reach_d:
                break
            last = k
            if k == w or self.is_stop(k, sample) or self.gate[k]:
                is_open = k == w and not self.is_stop(k, sample)
                cap = 0.0 if k == w or self.is_stop(k, sample) else self.backward(k, sample, w)
                caps.append((d, min(cap, self.target(k, ov))))
                end = d - CHAIN_SLACK  # as the backward pass leaves it (erring harder)
                break
            cap = self.target(k, ov)
            if cap < v and cap < self.ceiling(k - 1, ov):
                caps.append((d, cap))
        if not caps:
            return 0.0
        low = min(cap for _, cap in caps)
        a_max, j_max = self.limits(b, last)
        if j_max == INF:
            return a_floor

        def keeps(a: float) -> bool:
            phases = brake_phases(v, a, low, a_max, j_max)
            if end < INF and travel(v, a, phases) > end:
                return False
            if is_open and any(
                travel(v, a, brake_phases(v, a, v * i / OPEN_GRID, a_max, j_max)) > end
                for i in range(1, OPEN_GRID)
            ):
                return False  # the window's end may become a cap of any velocity
            return all(velocity_at(v, a, phases, d) <= cap + ABS_V for d, cap in caps)

        if keeps(0.0):
            return 0.0
        if a_floor >= 0.0 or not keeps(a_floor):
            return a_floor
        return _edge(keeps, a_floor, 0.0)

    def _run(
        self, start: int, inside: list[tuple[int, float]], end: tuple[int, float] | None,
        is_open: bool,
    ) -> float:  # fmt: skip
        """The highest velocity at boundary `start` (zero acceleration) from which each cap
        `inside` its run and the run's `end` value are reachable, each by a brake of its own."""
        s0 = self.bounds[start].s
        e = INF
        for k, cap in inside:
            a, j = self.limits(start, k)
            length = self.bounds[k].s - s0 - CHAIN_SLACK
            e = min(e, reach(cap, length, a, j, self.v_top))
        if end is not None:
            k, cap = end
            a, j = self.limits(start, k)
            length = self.bounds[k].s - s0 - CHAIN_SLACK
            rule = reach_rising if is_open else reach
            e = min(e, rule(cap, length, a, j, self.v_top))
        return e
