"""An independent check of the path velocity, cycle by cycle (issue 36, item 2): every slowdown
of the path is explained by a rule of the CNC, or the run fails.

The rules (docs/geo-core.md, "Which rule decides a slowdown", linked from docs/architecture.md):

* **Rest** only where a rule makes the path rest: a stop boundary of the program (program end,
  M00/M01, a synchronised M function, a dwell, #FLUSH, a lift range without path motion), a
  conditional stop (MVS_SNS) not acknowledged in time, a stop for a lift that cannot
  otherwise land, a feed hold or override 0 (and the end of its brake after the release, where
  ramping the deceleration out at full jerk already takes the velocity to 0: narrow seed 448),
  a PLC STOP, or the end of the look-ahead window (the window's last boundary, when nothing
  beyond it is known). A rest within STOP_TOL before a stop, in the cycle before the core
  registers that stop (`stopped_at`), is at it.
* **At a block boundary** the velocity reaches the lowest of: the two blocks' ceilings (F ×
  override within the axes' and the lift's caps), the transition cap, what the constraints
  ahead within the look-ahead window allow (a backward pass: one brake through the caps of a
  run, zero acceleration at its end, the window's end a stop), and what the path can have
  reached since a rule last held it lower (a forward pass from there, from a run boundary, or
  from where it was found too slow). The window is the one the brake toward the boundary
  began under, at least the one that ended a block after it. Where the window's last move
  raised the cap, the path is held to the cap under the window before and to the higher one
  only as far as it can reach it from its state when the window moved. At a run boundary
  (zero acceleration there) whose value lies in the jerk gap from the path's state at the
  last input change (no brake has it there with zero acceleration: the path passes at most
  at x1 below it or at least at x2 above it, `motion_rules.jerk_gap`), x1 where it is the
  nearer side by ratio or x2 lies above the boundary's transition or axis cap; from a run
  boundary passed at a side of such a gap (or where the gap has none), the gaps after it
  open from its state there.
* **Between two boundaries** it never goes below the lower of its velocities at the two.
* **Never faster** than the rules let it be (tests/support/motion_overrun.py): at most the
  ceiling of its block in every cycle, at most the transition cap and both blocks' ceilings at
  a boundary, but for the brake from above a ceiling an input lowered ("overrun" findings).

After an input changes (override, feed hold, a stop for Z set or dropped, an acknowledge, a
resume) the path follows a new plan: where it decelerates, that deceleration is ramped out at
full jerk first (a boundary inside that ramp is expected at the ramp's velocity there, or
lower where a cap needs it); the forward pass starts again where the ramp ends (or at the
event's state), and the interval goes on from there: no dip below the lower of the ramp's end
and the next boundary. The same where the brake from above a ceiling an input lowered passes
the end of that ceiling's block still decelerating into a higher ceiling (however little above
it, and credited no harder than a brake toward that ceiling is there, whose ramp-out ends at
the ceiling, or than the caps after it need, but wholly where that ramp-out would pass a run
boundary), and where a brake
for the look-ahead window's end passes a boundary, at what the rules expect there, whose
crossing moves the window on and releases it: the ramp-out after that boundary is the jerk
limit's, not a dip (its deceleration there read as the lowest the jerk limit allows from the
samples either side; after a window's release, at most what the caps after the boundary need
there under the window before, `PathRules.least_brake`).

What the rules allow is tests/support/motion_rules.py, in the checker's own arithmetic (a
jerk-limited velocity change with zero acceleration at both ends, inverted by bisection), not
the tracker's closed forms; it is lenient where the tracker may legitimately be a little
slower (zero acceleration assumed at the boundary checked, at each cap and where the forward
pass starts, `CHAIN_SLACK` of path given up per brake, `REL_TOL`): the time-optimality of the
motion is measured against bench/reference_profile.py, not here. It must not be lenient where
the tracker is slower by its own approximation (a chain composed with zero acceleration at
every link, the 24th constraint taken as a stop): those are the slowdowns it is there to find.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import NamedTuple

from liftd.cnc.geo_task import GeoTask
from liftd.cnc.path.program import PathProgram
from liftd.cnc.path.table import PathTable
from liftd.cnc.snapshot import ChannelState, GeoSnapshot
from tests.support.motion_overrun import OVER_ABS, OVER_REL, overruns
from tests.support.motion_rules import (
    INF,
    PathRules,
    Sample,
    crossing_velocity,
    jerk_gap,
    reach,
    reach_from,
    velocity_at,
)

# Sample and reach_from are the tests' too (the samples' type; the check's arithmetic)
__all__ = ["Expected", "Recorder", "Sample", "check_motion", "reach_from"]

REL_TOL = 0.05  # a velocity this much below its expected value is still at it (slightly
# lower: the bounded cycle keeps µm margins and plans a limited number of constraints at once)
# plus, absolute, what the velocity can change within a cycle by the jerk alone (J·dt²): the
# samples are a cycle apart, the boundaries and turning points lie between them
ABS_TOL = 1e-6  # m/s
STOP_TOL = 1e-9  # m: a rest this near before a stop is at it (rounding of its last brake)


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


def _slack(path: PathRules, b: int, dt: float) -> float:
    """What the velocity may differ from its value at boundary b a cycle away: J·dt²."""
    _, j = path.limits(max(b - 1, 0), min(b + 1, path.n))
    return ABS_TOL + (j * dt * dt if j != INF else 0.0)


def _before_stop(path: PathRules, smp: Sample) -> bool:
    """`smp` rests within STOP_TOL before the stop that ends its segment: a rest that ends a
    few ns after a cycle registers in the next (the core sets `stopped_at` there; the
    reviewer's generator, cases 4, 6 and 18: an M00 2.6e-18 m ahead at rest, t = 0.080 s)."""
    b = smp.seg + 1
    return b < path.n and path.is_stop(b, smp) and 0.0 <= path.bounds[b].s - smp.s <= STOP_TOL


class Expected(NamedTuple):
    """What the check expected at a boundary the path crossed (m/s): the path's velocity,
    the caps' rules (the boundary's target and what the constraints ahead allow), the forward
    pass and, inside an event's deceleration ramp, the ramp's velocity there (else inf); the
    look-ahead window's end it read the constraints up to."""

    b: int
    window: int
    v: float
    held_by: float
    forward: float
    ramp: float
    gap: float = INF  # x1, where the jerk gap after an input change explains a lower velocity


def _ramp_at(ramp: tuple[float, float, float, float], s_b: float) -> float:
    """The velocity where an event's deceleration ramp (from s, v, a < 0, ramped out at the
    jerk j) passes s_b, before its end (`motion_rules.velocity_at` on its one phase)."""
    s0, v0, a0, j = ramp
    return max(velocity_at(v0, a0, [(-a0 / j, j)], s_b - s0), 0.0)


def _gap(
    path: PathRules, changed: Sample | None, b: int, expect: float, v_b: float, tol: float,
    smp: Sample,
) -> tuple[float, Sample | None]:  # fmt: skip
    """At run boundary b, where the path has zero acceleration, and `expect` lies in the jerk
    gap from the state `changed` (the state the path re-planned from at the last input
    change, or where it last passed a run boundary at a side of a gap): (the velocity
    expected there instead, the state the next gaps open from); (inf, `changed`) where there
    is no gap. From that state no brake has `expect` at b with zero acceleration there
    (`jerk_gap`): the path passes b at most at x1, or at least at x2 (above the cap: the
    brake from above a ceiling an input lowered, tests/support/motion_overrun.py), or dips
    below x1 before it. Which side is the core's judgement (`Targets.pick_target`, known
    deviation 6 of docs/geo-core.md); the check holds it to the side nearer by ratio (x1
    where x2 / expect ≥ expect / x1 or x2 is above b's hard cap, else `expect`), so a core
    that takes x1 where x2 is nearer is still found (CAM seeds 74, 465, 629: x1 for a cap of
    43.4 mm/s where x2 is nearer). Where the path passed b at a side of the gap, as near the
    cap as it could (at x2: as slowly as it could above it), the next gaps open from b's
    state (feeds seed 383: override 100 → 10 % at 126.3 mm/s, 1.27 mm before run boundary
    16, passed at its x2 of 115.3, from which 16.6 mm/s at boundary 17 lies in the gap,
    x1 = 5.75); so they do from a run boundary without a gap passed at what the rules
    expect there."""
    if changed is None or changed.seg >= b:
        return INF, changed
    if not path.gate[b]:
        return INF, changed
    # the limits the path brakes toward b under: the segments before b (with b's own, lower
    # ones a gap appeared that the path does not have: a cold review's tangent arc of a
    # third of the line's jerk after it, a made-up path at 2.4 mm/s for a cap of 60.8)
    a_max, j_max = path.limits(changed.seg, b)
    gap = jerk_gap(changed.v, changed.a, path.bounds[b].s - changed.s, expect, a_max, j_max)
    if gap is None:
        # passed at what the rules expect there (zero acceleration): what lies after b is
        # reachable from b's state, not from the older one (CAM seed 619: override 35 → 122 %
        # braking at 392 mm/s, 18 mm before a run boundary passed at its cap of 1.29 mm/s,
        # two more after it; from the event's state the third one's cap of 70.7 lay in a gap
        # with x1 = 59.9, and the second's cap of 49.6 read as a dip)
        side = INF
        at_side = expect * (1.0 - REL_TOL) - tol <= v_b <= expect * (1.0 + 1e-3) + tol
    else:
        x1, x2 = gap
        side = x1
        # (b's transition cap too: a kink's 11.46 mm/s, x2 15.9 above it, was expected
        # at the cap, where only x1 = 2.0 keeps it, drops seed 2237 with its drop 20 ms early)
        if x1 < 0.0 or (x2 <= path.boundary_hard(b) and (x1 == 0.0 or x2 * x1 < expect * expect)):
            side = expect  # x2 is the nearer (or the only) side: the cap is expected
        # or no side at all (neither rest nor the ramp-out alone fits before b: the path
        # passes b where that ramp-out ends, at zero acceleration as at every run boundary
        # of the core's), then from b's state: an
        # override drop to 10 % 0.1 mm before run boundary 9 at 34.5 mm/s, its ramp-out
        # ending there at 32.76, boundary 10's 2 mm/s 0.3 mm on reachable only at x1 = 0.80
        # from there, expected from the drop's state (`drop_scenario(3667)`, drop 20 ms early)
        at_side = (
            abs(v_b - side) <= side * 1e-3 + tol
            or (x2 < INF and expect <= v_b <= x2 * 1.001 + tol)
            or (x1 < 0.0 and x2 == INF)
        )
    if at_side:
        changed = dataclasses.replace(smp, s=path.bounds[b].s, v=v_b, a=0.0, seg=b)
    return (side if side < expect else INF), changed


def _gap_dip(path: PathRules, b: int, x1: float, low: float, tol: float, smp: Sample) -> list[str]:
    """Where run boundary b is expected at x1 of a jerk gap (`_gap`): the brake to x1 goes no
    lower on the way, so a path that went lower before b (`low`: since the event or the
    boundary before b) and came back is found (feeds
    seed 193: down to 0.001 mm/s after an override raise, back to 9.1 at the boundary,
    where the brake to x1 passes it at 8.0; inside the event's ramp, which the interval's
    own dip rule does not read)."""
    if x1 == INF or low >= x1 * (1.0 - REL_TOL) - tol:
        return []
    return [
        f"dip to {low * 1e3:.4f} mm/s before boundary {b} (line {path.bounds[b].line}) in "
        f"the jerk gap, x1 {x1 * 1e3:.4f} (t={smp.t:.4f} s)"
    ]


def _brake_on(
    path: PathRules, b: int, last: Sample, smp: Sample, v_b: float, held_by: float,
    backward: float, forward: float, window: int, release: bool,
) -> tuple[float, float, tuple[float, float, float, float]] | None:  # fmt: skip
    """Where the path passes boundary b (at v_b, between `last` and `smp`) braking, and its
    deceleration is ramped out after b (the brake from above a lowered ceiling that ends at b;
    with `release`, a brake for the window's end that its move at b releases): that ramp's
    end (position, velocity) and the ramp (its start s, v, a and the jerk). None elsewhere."""
    s_b = path.bounds[b].s
    # the acceleration where the path passed b (linear between the samples)
    frac = (s_b - last.s) / (smp.s - last.s) if smp.s > last.s else 1.0
    a_b = last.a + (smp.a - last.a) * frac
    # the brake from above a lowered ceiling (after an input change: above it
    # otherwise, motion_overrun fails the run) that ends where the ceiling rises again;
    # however little above it (a brake at once from 32.2 mm/s toward 25 passed the
    # block's end at 25.55 and −0.66 m/s², ramped out to 25.0 and reached 28.6 mm/s
    # at the next run boundary, where REL_TOL above it was asked and 30.6 expected as
    # from zero acceleration: a `short_drop` program, test_motion_check.py)
    ceiling_before = path.ceiling(b - 1, smp.override)
    above = (
        v_b > ceiling_before * (1.0 + OVER_REL) + OVER_ABS
        and path.ceiling(b, smp.override) > ceiling_before
    )
    # or a brake for the window's end that the window's move at b releases (the path
    # enters b's segment: the window ends a block further on), passed above what zero
    # acceleration there allows, so braking as it must: its deceleration is ramped out
    # after b as well (feeds seed 46, look-ahead 3: 86.5 mm/s for 69.4 with zero
    # acceleration, −2.0 m/s² at an F3000 drop at 180 %, 81.5 at the ramp's end, 86.0
    # at the next boundary). Only the deceleration the caps after b need there under
    # the window before is credited (`PathRules.least_brake`), not a harder one: a
    # brake for nothing, ramped out, is a dip (seed 46 made up with its deceleration
    # doubled at b and 12 % slower after it: the ramp from the doubled one ends at
    # 66.5 mm/s and was taken for the jerk limit's). Not where zero acceleration at b
    # would do either (a cold review's made-up path at −4 m/s² through a boundary of
    # 43.6 mm/s)
    released = (
        release
        and v_b > held_by * (1.0 + REL_TOL)
        and backward == held_by < forward
        and path.backward(b, smp, b + path.look_ahead) > backward * (1.0 + REL_TOL)
    )
    if a_b < 0.0 and smp.a < 0.0 and (above or released):
        # its deceleration is ramped out at full jerk after b, as after an event
        # (feeds seed 931: override 200 → 20 % at 102 mm/s, a 1 mm block of 10 mm/s,
        # then 80; the ramp from 15.4 mm/s and −2.1 m/s² at its end went down to
        # 10.09), and the forward pass and the interval go on from its end: the higher
        # of the ramps from b and from the sample after it (a path that brakes on
        # after b is not credited with it, a cold review found)
        _, j = path.limits(b, b + 1)
        if j != INF:
            t_r = -smp.a / j
            ramp_s = smp.s + t_r * (smp.v + t_r * (smp.a / 2.0 + t_r * j / 6.0))
            # the deceleration at b: a linear reading between the samples misses a
            # peak between them; the jerk limit bounds it from either sample (feeds
            # seed 247: −2.33 and −2.45 m/s² a cycle apart, the peak −2.55 at b,
            # ramped out from there to 9.92 mm/s where the linear reading expected
            # 11.0)
            dt_s = smp.t - last.t
            a_b = min(a_b, max(last.a - j * frac * dt_s, smp.a - j * (1.0 - frac) * dt_s))
            ramp_v = max(smp.v + smp.a * t_r / 2.0, v_b - a_b * a_b / (2.0 * j), 0.0)
            ramp = (smp.s, smp.v, smp.a, j)
            need = path.least_brake(b, v_b, a_b, smp, window)
            if above:
                # or no harder than a brake toward that ceiling has there (its
                # ramp-out ends at the ceiling, not below it), where that is
                # harder; the whole deceleration where that brake's ramp-out would
                # pass a run boundary, which the path passes with zero acceleration
                # (0.05 mm after the ceiling's end, 13.29 mm/s at −2.57 m/s² over a
                # ceiling of 8: the ramp toward 8 ends 0.055 mm on, and the path
                # ramps out to x1 = 5.0 there; a cold review's program)
                toward = -math.sqrt(2.0 * j * (v_b - ceiling_before))
                t_t = -toward / j
                ramp_len = t_t * (v_b + t_t * (toward / 2.0 + t_t * j / 6.0))
                need = a_b if path.gate_within(b, ramp_len) else min(need, toward)
            if need > a_b:  # braking harder than the window's end needs: that much
                t_r = -need / j
                ramp_s = s_b + t_r * (v_b + t_r * (need / 2.0 + t_r * j / 6.0))
                ramp_v = max(v_b - need * need / (2.0 * j), 0.0)
                ramp = (s_b, v_b, need, j)
            return ramp_s, ramp_v, ramp
    return None


def check_motion(
    prog: PathProgram, table: PathTable, look_ahead: int, dt: float, samples: list[Sample],
    trace: list[Expected] | None = None,
) -> list[str]:  # fmt: skip
    """Every slowdown of the path in `samples` (one per cycle of `dt`) that no rule explains,
    as text (empty: none); with `trace`, what it expected at each boundary checked."""
    path = PathRules(prog, table, look_ahead)
    out: list[str] = []
    # the forward pass: from where the path was last slower than it could have been (or the
    # state of a restart), at most what it can have reached since
    anchor_s, anchor_v, anchor_seg = 0.0, 0.0, 0
    # the caps passed since the anchor (position, cap, boundary), each a start of its own for
    # the forward pass (as the backward pass takes each cap of a run as a brake of its own)
    passed: list[tuple[float, float, int]] = []
    passed_for = (0.0, 0.0)  # the anchor they were passed after
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
    ramp = (0.0, 0.0, 0.0, 0.0)  # that ramp: the state (s, v, a) it starts from, the jerk
    last: Sample | None = None
    pending: tuple[int, str] | None = None  # a rest just before a stop, and that stop
    changed: Sample | None = None  # the state the path re-planned from at the last event
    gap_low = INF  # the lowest velocity since the last event or boundary crossed
    for smp in samples:
        if last is None:
            last = smp
            continue
        if pending is not None:
            if smp.stopped_at != pending[0]:
                out.append(pending[1])
            pending = None
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
                ramp = (smp.s, smp.v, smp.a, j)
            ramp_ends = anchor_s
            # the interval goes on from the event, or from its ramp's end (its lowest point):
            # the path does not dip below the lower of that and the next boundary either (it
            # was not checked: a dip planned at an event passed unseen)
            entry_v, interval_min, fresh = min(smp.v, anchor_v), INF, False
            entered.clear()
            changed, gap_low = last, min(last.v, smp.v)
            for b in range(last.seg + 1, min(smp.seg, path.n - 1) + 1):
                if path.gate[b]:
                    # a run boundary the path passed in the event's cycle: zero acceleration
                    # there, and what lies after it is reachable from that state (3.5 µm
                    # after the state at an override drop to 20 % at 32.79 mm/s and −0.04
                    # m/s², the next run boundary's cap of 4 mm/s 0.3 mm on: x1 2.59 from
                    # the event's state, 0.83 from the boundary's, drops seed 827)
                    s_b = path.bounds[b].s
                    changed = dataclasses.replace(
                        smp, s=s_b, v=crossing_velocity(last, smp, s_b), a=0.0, seg=b
                    )
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
                rest = f"rest at s={smp.s * 1e3:.4f} mm, t={smp.t:.4f} s (no rule)"
                if _before_stop(path, smp):
                    pending = (smp.seg + 1, rest)  # read when the next cycle registers it
                else:
                    out.append(rest)
        # boundaries crossed in this cycle
        for b in range(last.seg + 1, min(smp.seg, path.n - 1) + 1):
            s_b = path.bounds[b].s
            if held or path.is_stop(b, smp):
                anchor_s, anchor_v, anchor_seg = s_b, 0.0, b
                interval_min, fresh, gap_low = INF, True, INF
                continue
            v_b = crossing_velocity(last, smp, s_b)
            low, gap_low = gap_low, v_b  # since the event or the boundary before
            tol = _slack(path, b, dt)
            # the look-ahead window as it was when the path began braking toward b: its end was a
            # stop the path had to be able to make, and a cap that came into view later may lie
            # below what the path can still brake to exactly (jerk-limited, braking to a low
            # velocity can take longer than braking to rest); at least the window that ended a
            # block after b: one that ended at b (a brake begun more than the window's length
            # before) made the check expect 0, and every boundary of a long brake passed
            window = min(max(b + 1, interval_from + path.look_ahead), b - 1 + path.look_ahead)
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
            held_by = min(path.target(b, smp.override), backward)  # the caps' rules
            if s_b < ramp_ends:
                # still ramping out an event's deceleration: the velocity here is the ramp's
                # (its highest), or lower where a cap needs it (CAM seed 687: to a corner's
                # 0.28 mm/s inside the ramp), from where the forward pass starts again. Not
                # checked before (every boundary inside the ramp passed)
                on_ramp = _ramp_at(ramp, s_b)
                expect = min(on_ramp, held_by)
                # a run boundary inside the ramp: zero acceleration there, its velocity in the
                # gap (feeds seed 193: override 40 → 200 % at 48.0 mm/s and −3.46 m/s², 0.36 mm
                # before run boundary 23, the ramp's 14.9 mm/s there: ramping out alone ends
                # beyond it, x1 = 9.18, no x2)
                x1, changed = _gap(path, changed, b, expect, v_b, tol, smp)
                out += _gap_dip(path, b, x1, low, tol, smp)
                expect = min(expect, x1)
                if trace is not None:
                    trace.append(Expected(b, window, v_b, held_by, INF, on_ramp, x1))
                if v_b < expect * (1.0 - REL_TOL) - tol:
                    out.append(
                        f"boundary {b} (line {path.bounds[b].line}) at {v_b * 1e3:.4f} mm/s, "
                        f"expected {expect * 1e3:.4f} in an event's ramp (t={smp.t:.4f} s)"
                    )
                if v_b < anchor_v:
                    anchor_s, anchor_v, anchor_seg = s_b, v_b, b
                brake_on = _brake_on(path, b, last, smp, v_b, held_by, backward, INF, window, False)
                if brake_on is not None and brake_on[1] < anchor_v:
                    # the brake toward a lowered ceiling whose block ends inside the event's
                    # ramp: its own ramp-out after b, as outside it (override 100 → 30 % at
                    # 49.9 mm/s, a 0.05 mm block of 12 mm/s 0.4 mm on passed at 21.5 and
                    # −2.7 m/s², ramped out to 12.6; the forward pass from 21.5 expected 23.5
                    # at the next boundary 0.1 mm on: drops seed 740)
                    anchor_s, anchor_v, ramp = brake_on
                    anchor_seg, ramp_ends = b, anchor_s
                entry_v, interval_min = anchor_v, INF  # the ramp's end, or lower for a cap
                continue
            a, j = path.limits(anchor_seg, b)
            forward = reach(anchor_v, s_b - anchor_s, a, j, path.v_top)
            if passed_for != (anchor_s, anchor_v):
                passed_for, passed = (anchor_s, anchor_v), []
            for s_k, cap_k, k in passed:
                a_k, j_k = path.limits(k, b)
                forward = min(forward, reach(cap_k, s_b - s_k, a_k, j_k, path.v_top))
            expect = min(held_by, forward)
            x1, changed = _gap(path, changed, b, expect, v_b, tol, smp)
            out += _gap_dip(path, b, x1, low, tol, smp)
            expect = min(expect, x1)
            slow = v_b < expect * (1.0 - REL_TOL) - tol
            if trace is not None:
                trace.append(Expected(b, window, v_b, held_by, forward, INF, x1))
            if slow:
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
            brake_on = _brake_on(path, b, last, smp, v_b, held_by, backward, forward, window, True)
            if brake_on is not None:
                ramp_s, ramp_v, ramp = brake_on
                ramp_ends = ramp_s
                anchor_s, anchor_v, anchor_seg = ramp_s, ramp_v, b
                entry_v, interval_min, fresh = min(v_b, ramp_v), INF, False
                continue
            # the forward pass starts again where the acceleration is zero (a run boundary),
            # where a cap held the path below it, and where the path was slower than the rules
            # allow (found above). Not where it is only a little below it, within REL_TOL:
            # restarted there with zero acceleration, the pass followed a path held at any
            # velocity below the rules' (a cruise at 314 mm/s where they allow 500 went
            # unseen after its first boundary)
            if path.gate[b] or (v_b < forward and (slow or held_by < forward)):
                anchor_s, anchor_v, anchor_seg = s_b, min(v_b, forward), b
            else:
                # a cap passed on the way: what lies after it is reachable from the cap, not
                # from the anchor alone (the path passes it at most at its cap, also while it
                # accelerates through it: CAM seed 244 crossed a feed rise at 93.3 mm/s and
                # 2.4 m/s², the feed before it 99.0, and the pass from the run boundary 1 mm
                # before it expected 188.1 mm/s 3 mm on, where 163 are reachable from the
                # cap). From zero acceleration at the cap, as the backward pass takes each cap
                # of a run (the tracker plans no other targets); one passed before it at a cap
                # at least as high is left out: farther back and higher, it allows more
                cap_b = path.target(b, smp.override)
                passed = [p for p in passed if p[1] < cap_b] + [(s_b, cap_b, b)]
            entry_v, interval_min, fresh = v_b, INF, False
        if smp.seg != last.seg:
            interval_from = braking_from
            for k in range(last.seg + 1, smp.seg + 1):
                entered[k] = last
        if not held and smp.s > ramp_ends:
            interval_min = min(interval_min, smp.v) if smp.seg == last.seg else smp.v
        gap_low = min(gap_low, smp.v)
        if smp.a >= 0.0 or smp.v == 0.0:
            braking_from = smp.seg
        interval_from = min(interval_from, braking_from)
        last = smp
    if pending is not None:
        out.append(pending[1])
    return out + overruns(path, samples)
