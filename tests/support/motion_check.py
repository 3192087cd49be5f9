"""An independent check of the path velocity, cycle by cycle (issue 36, item 2): every slowdown
of the path is explained by a rule of the CNC, or the run fails.

The rules (docs/architecture.md, "Which rule decides a slowdown"):

* **Rest** only where a rule makes the path rest: a stop boundary of the program (program end,
  M00/M01, a synchronised M function, a dwell, #FLUSH, a lift range without path motion), a
  conditional stop (MVS_SNS) not acknowledged in time, a stop for a lift that cannot
  otherwise land, a feed hold or override 0 (and the end of its brake after the release, where
  ramping the deceleration out at full jerk already takes the velocity to 0: narrow seed 448),
  a PLC STOP, or the end of the look-ahead window (the window's last boundary, when nothing
  beyond it is known).
* **At a block boundary** the velocity reaches the lowest of: the two blocks' ceilings (F ×
  override within the axes' and the lift's caps), the transition cap, what the constraints
  ahead within the look-ahead window allow (a backward pass: each reachable from the one before
  with the run's acceleration and jerk, the window's end a stop), and what the path can have
  reached since the last point it was slower (a forward pass from there). Where the window's
  last move raised the cap, the path is held to the cap under the window before and to the
  higher one only as far as it can reach it from its state when the window moved.
* **Between two boundaries** it never goes below the lower of its velocities at the two.

After an input changes (override, feed hold, a stop for Z set or dropped, an acknowledge, a
resume) the path follows a new plan: the forward pass starts again from the state at that
cycle, and the interval it is in is not checked against its entry velocity.

The checker's arithmetic is its own (a jerk-limited velocity change with zero acceleration at
both ends, inverted by bisection), not the tracker's closed forms; it is lenient where the
tracker may legitimately be a little slower (zero acceleration assumed at every constraint,
`CHAIN_SLACK` of path given up per link of a chain, `REL_TOL`): the time-optimality of the
motion is measured against bench/reference_profile.py, not here.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

from liftd.cnc.geo_task import GeoTask
from liftd.cnc.path.program import PathProgram
from liftd.cnc.path.table import PathTable
from liftd.cnc.snapshot import ChannelState, GeoSnapshot

REL_TOL = 0.05  # a velocity this much below its expected value is still at it (slightly
# lower: the bounded cycle keeps µm margins and plans a limited number of constraints at once)
# plus, absolute, what the velocity can change within a cycle by the jerk alone (J·dt²): the
# samples are a cycle apart, the boundaries and turning points lie between them
ABS_TOL = 1e-6  # m/s
CHAIN_SLACK = 5e-6  # m of path given up per link of a chain (the tracker keeps µm margins)
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


@dataclass(slots=True)
class Recorder:
    """Samples a GeoTask's path after every step (one program run: a new run replaces the
    interpolator, and `program` is the last one's)."""

    task: GeoTask
    samples: list[Sample] = field(default_factory=list)

    def __call__(self, snap: GeoSnapshot) -> None:
        ip = self.task.interp
        self.samples.append(
            Sample(
                snap.t, ip.s, ip.v, ip.a, ip.segment, ip.stopped_at, ip.parked, ip.override,
                ip.hold, frozenset(ip.lift_stops), frozenset(ip.acked_conditional),
                snap.state is ChannelState.ACTIVE,
            )
        )  # fmt: skip

    @property
    def program(self) -> PathProgram:
        return self.task.interp.program

    @property
    def table(self) -> PathTable:
        return self.task.interp.table

    def check(self) -> list[str]:
        """`check_motion` over what was recorded."""
        ch = self.task.ch
        return check_motion(self.program, self.table, ch.look_ahead_blocks, ch.cycle_time,
                            self.samples)  # fmt: skip


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
    hi = top
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if distance(mid) <= length:
            lo = mid
        else:
            hi = mid
    return lo


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


class _Path:
    """The rules' inputs from the prepared program: ceilings, caps, stops, run boundaries
    (where the path acceleration is zero), limits."""

    def __init__(self, prog: PathProgram, table: PathTable, look_ahead: int) -> None:
        self.segs = prog.segments
        self.bounds = prog.boundaries
        self.gate = table.gate
        self.n = len(self.segs)
        self.look_ahead = max(1, look_ahead)
        self.v_top = max((seg.v_phys for seg in self.segs), default=0.0)
        self.a_low = min((seg.a_max for seg in self.segs), default=INF)
        self.j_low = min((seg.j_max for seg in self.segs), default=INF)

    def ceiling(self, k: int, ov: float) -> float:
        seg = self.segs[k]
        return min(min(seg.feed, seg.v_lift_ov) * ov, seg.v_phys, seg.v_lift)

    def target(self, b: int, ov: float) -> float:
        """The velocity at boundary b by its own rule: the lower ceiling, the transition cap."""
        if b <= 0 or b >= self.n:
            return 0.0
        return min(self.ceiling(b - 1, ov), self.ceiling(b, ov), self.bounds[b].v_cap)

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
        """What the boundaries after b up to `window_end` allow at b: a backward pass over
        those that can bind (a stop, the window's end, a target below the ceiling before it, a
        run boundary) within the distance the path needs to stop from the program's highest
        velocity."""
        ov = sample.override
        w = min(window_end, self.n)
        if w <= b:
            return 0.0
        s_b = self.bounds[b].s
        reach_d = 2.0 * change_distance(self.v_top, 0.0, self.a_low, self.j_low)
        nodes: list[tuple[int, float]] = []
        is_open = False  # the pass ends at the window's end: its rest may become a cap
        for k in range(b + 1, w + 1):
            if self.bounds[k].s - s_b > reach_d:
                break
            if k == w or self.is_stop(k, sample):
                nodes.append((k, 0.0))
                is_open = not self.is_stop(k, sample)
                break
            cap = self.target(k, ov)
            if cap < self.ceiling(k - 1, ov) or self.gate[k]:
                nodes.append((k, cap))
        e = INF
        for i in range(len(nodes) - 1, -1, -1):
            k, cap = nodes[i]
            prev = nodes[i - 1][0] if i > 0 else b
            a, j = self.limits(prev, k)
            length = self.bounds[k].s - self.bounds[prev].s - CHAIN_SLACK
            if is_open:
                e = reach_rising(min(e, cap), length, a, j, self.v_top)
            else:
                e = reach(min(e, cap), length, a, j, self.v_top)
        return e

    def slack(self, b: int, dt: float) -> float:
        """What the velocity may differ from its value at boundary b a cycle away: J·dt²."""
        _, j = self.limits(max(b - 1, 0), min(b + 1, self.n))
        return ABS_TOL + (j * dt * dt if j != INF else 0.0)


def _at(last: Sample, smp: Sample, s_b: float) -> float:
    """The velocity where the path passed s_b between two samples: constant jerk between them
    (the cycle's profile up to its phase changes), the time found by bisection."""
    dt = smp.t - last.t
    if dt <= 0.0 or smp.s <= last.s:
        return smp.v
    j = (smp.a - last.a) / dt
    lo, hi = 0.0, dt
    for _ in range(50):
        tau = 0.5 * (lo + hi)
        s = last.s + tau * (last.v + tau * (last.a / 2.0 + tau * j / 6.0))
        if s < s_b:
            lo = tau
        else:
            hi = tau
    tau = 0.5 * (lo + hi)
    return max(last.v + tau * (last.a + tau * j / 2.0), 0.0)


def check_motion(
    prog: PathProgram, table: PathTable, look_ahead: int, dt: float, samples: list[Sample]
) -> list[str]:
    """Every slowdown of the path in `samples` (one per cycle of `dt`) that no rule explains,
    as text (empty: none)."""
    path = _Path(prog, table, look_ahead)
    out: list[str] = []
    # the forward pass: from where the path was last slower than it could have been (or the
    # state of a restart), at most what it can have reached since
    anchor_s, anchor_v, anchor_seg = 0.0, 0.0, 0
    entry_v = 0.0  # velocity at the last boundary crossed (the interval's entry)
    interval_min = INF
    fresh = True  # the interval began with a restart or a stop: no entry velocity to keep
    braking_from = 0  # the segment the path was in when it last began to brake
    # the earliest `braking_from` since the last boundary crossed: a brake the path ended just
    # before a boundary (a little acceleration into it) decided the velocity there with the
    # window as it stood when it began (wide seed 2: a brake begun in segment 105, window end
    # 113, ended 0.15 mm before 107 and crept on into it at 129 mm/s; the core's cap there with
    # that window 125.2 mm/s, the check's 124.9, but read with the window of segment 106 the
    # check expected 142)
    interval_from = 0
    brake_ends = -INF  # a hold's brake that its release cannot undo ends by then (at rest)
    # the last sample before the path entered segment k (since the last event): its state when
    # the window moved to k + look_ahead
    entered: dict[int, Sample] = {}
    ramp_ends = -INF  # path position where an event's deceleration is ramped out
    last: Sample | None = None
    for smp in samples:
        if last is None:
            last = smp
            continue
        event = (
            smp.override != last.override
            or smp.hold != last.hold
            or smp.lift_stops != last.lift_stops
            or smp.acked != last.acked
            or (last.stopped_at is not None and smp.stopped_at is None)
            or not smp.running
            or not last.running
        )
        if event:
            if (last.hold or last.override <= 0.0) and not (smp.hold or smp.override <= 0.0):
                # released while braking for the hold: where ramping the deceleration out
                # already takes the velocity to 0, the hold's brake still ends at rest
                _, j = path.limits(smp.seg, smp.seg + 1)
                if j != INF and smp.v + smp.a * abs(smp.a) / (2.0 * j) <= ABS_TOL:
                    brake_ends = smp.t + abs(smp.a) / j + 2.0 * dt
            anchor_s, anchor_v, anchor_seg = smp.s, max(smp.v, last.v), smp.seg
            _, j = path.limits(smp.seg, smp.seg + 1)
            if smp.a < 0.0 and j != INF:
                # the new plan starts braking (a hold's brake, released): whatever it does, the
                # jerk limit takes the velocity down to v + a·|a|/2J while the deceleration is
                # ramped out, over that ramp's distance (wide seed 119: released at 42.2 mm/s
                # and −5.93 m/s², 0.0098 mm/s at the ramp's end), and the fastest motion from
                # there starts at the ramp's end at that velocity
                t_r = -smp.a / j
                ramp_s = smp.s + t_r * (smp.v + t_r * (smp.a / 2.0 + t_r * j / 6.0))
                anchor_s, anchor_v = ramp_s, max(smp.v + smp.a * t_r / 2.0, 0.0)
            ramp_ends = anchor_s
            interval_min, fresh = INF, True
            entered.clear()
            last = smp
            continue
        held = smp.hold or smp.override <= 0.0 or smp.parked or last.parked
        if smp.stopped_at is not None and last.stopped_at is None:
            b = smp.stopped_at
            if not path.is_stop(b, smp):
                out.append(f"stopped at boundary {b} (line {path.bounds[b].line}), not a stop")
        elif smp.v == 0.0 and smp.stopped_at is None and not held and smp.t > brake_ends:
            b = smp.seg  # the window's end as seen before, or a stop
            at_boundary = b <= path.n and path.bounds[b].s == smp.s
            if not (at_boundary and (b == last.seg + path.look_ahead or path.is_stop(b, smp))):
                out.append(f"rest at s={smp.s * 1e3:.4f} mm, t={smp.t:.4f} s (no rule)")
        # boundaries crossed in this cycle
        for b in range(last.seg + 1, min(smp.seg, path.n - 1) + 1):
            s_b = path.bounds[b].s
            if held or path.is_stop(b, smp):
                anchor_s, anchor_v, anchor_seg = s_b, 0.0, b
                interval_min, fresh = INF, True
                continue
            v_b = _at(last, smp, s_b)
            if s_b < ramp_ends:
                # still ramping out an event's deceleration: the velocity here is the ramp's,
                # or lower where the path brakes harder for a constraint (CAM seed 687: to a
                # corner's 0.28 mm/s inside the ramp), from where the forward pass starts again
                if v_b < anchor_v:
                    anchor_s, anchor_v, anchor_seg = s_b, v_b, b
                continue
            tol = path.slack(b, dt)
            a, j = path.limits(anchor_seg, b)
            forward = reach(anchor_v, s_b - anchor_s, a, j, path.v_top)
            # the look-ahead window as it was when the path began braking toward b: its end was a
            # stop the path had to be able to make, and a cap that came into view later may lie
            # below what the path can still brake to exactly (jerk-limited, braking to a low
            # velocity can take longer than braking to rest)
            window = min(max(b, interval_from + path.look_ahead), b - 1 + path.look_ahead)
            backward = path.backward(b, smp, window)
            before = entered.get(window - path.look_ahead)
            if before is not None and window - 1 > b:
                # a cap that rose as the window moved to `window`: the path's state then came
                # from planning under the window before, whose cap it had to keep reachable;
                # it is held to that cap, and to the higher one only as far as it could still
                # reach it from that state (wide seed 74, boundary 7: 60.97 mm/s under the
                # window before, 69.66 under this one, 64.72 reachable from the state)
                a, j = path.limits(before.seg, b)
                gain = reach_from(before.v, before.a, s_b - before.s, a, j, path.v_top)
                if gain < backward:
                    backward = min(backward, max(gain, path.backward(b, smp, window - 1)))
            expect = min(path.target(b, smp.override), backward, forward)
            if v_b < expect * (1.0 - REL_TOL) - tol:
                out.append(
                    f"boundary {b} (line {path.bounds[b].line}) at {v_b * 1e3:.4f} mm/s, "
                    f"expected {expect * 1e3:.4f} (t={smp.t:.4f} s)"
                )
            low = min(entry_v, v_b)
            if not fresh and interval_min < low * (1.0 - REL_TOL) - tol:
                out.append(
                    f"dip to {interval_min * 1e3:.4f} mm/s before boundary {b} (line "
                    f"{path.bounds[b].line}) between {entry_v * 1e3:.4f} and {v_b * 1e3:.4f} "
                    f"(t={smp.t:.4f} s)"
                )
            # the forward pass starts again where the acceleration is zero (a run boundary) and
            # where the path was slower than it could have been
            if path.gate[b] or v_b < forward:
                anchor_s, anchor_v, anchor_seg = s_b, min(v_b, forward), b
            entry_v, interval_min, fresh = v_b, INF, False
        if smp.seg != last.seg:
            interval_from = braking_from
            for k in range(last.seg + 1, smp.seg + 1):
                entered[k] = last
        if not held and smp.s > ramp_ends:
            interval_min = min(interval_min, smp.v) if smp.seg == last.seg else smp.v
        if smp.a >= 0.0 or smp.v == 0.0:
            braking_from = smp.seg
        interval_from = min(interval_from, braking_from)
        last = smp
    return out
