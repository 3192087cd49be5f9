"""The re-plan toward the candidate that binds (`Shift`, a part of the tracker,
`Tracker.sh`, that holds the constraint queries, the path's state, the target profiles of
`targets.py` and the brakes at once of `brakes.py`). `Tracker._replan` picks the candidate
with the least slack and hands it here with its target once the brakes for an override drop,
the one brake through a feed drop (`aims.py`) and the gap state have not taken the re-plan.

Zero acceleration at a boundary that does not need it, below a feed cap the path can no
longer get down to (an override drop), is at a velocity from which the next candidate may be
lost too, although the path could still keep it by braking through this one: the *shift*
aims at the next candidate, passing this one as it brakes (only its hard cap kept). Then the
brake at once for a lost cap (`Brakes.lost_cap`), the profile that brought the path to the
boundary it just passed, a brake into or through the candidates from above a lowered
ceiling, or the target profile (`Targets.settle`); and where the shift's profile passes a
candidate above its cap, a brake at once, under or through it (`Brakes`)."""

from __future__ import annotations

from liftd.cnc.path.brakes import Brakes
from liftd.cnc.path.constraints import (
    CAP_TOL,
    CHAIN_MARGIN,
    INF,
    SLACK_MARGIN,
    SLACK_TOL,
    V_ROUND,
    Constraints,
)
from liftd.cnc.path.plan import PathState, Plan
from liftd.cnc.path.targets import Targets
from liftd.cnc.path.velocity import brake_crossing, reach_velocity

# after an input change, a feed cap whose nearest reachable velocity below it (the jerk gap's
# lower end, `Targets.pick_target`) is less than this fraction of it is out of reach
# (`Brakes.lost_cap`)
GAP_FLOOR = 0.5


class Replan:
    """What one re-plan read (`Tracker._replan`): the path's state (s, v, a in segment seg;
    v_p after ramping a out), its limits, the ceiling, the window's end w, the cycle dt,
    whether a step forced it, whether an input changed, the profile that brought the path to
    the boundary it just passed and the one in hand."""

    __slots__ = (
        "a", "a_max", "ceiling", "dt", "event", "forced", "held", "j_max", "passed", "s", "seg",
        "v", "v_p", "w",
    )  # fmt: skip

    def __init__(
        self, s: float, v: float, a: float, seg: int, v_p: float, a_max: float, j_max: float,
        ceiling: float, w: int, dt: float, forced: bool, event: bool, passed: Plan | None,
        held: Plan | None,
    ) -> None:  # fmt: skip
        self.s = s
        self.v = v
        self.a = a
        self.seg = seg
        self.v_p = v_p
        self.a_max = a_max
        self.j_max = j_max
        self.ceiling = ceiling
        self.w = w
        self.dt = dt
        self.forced = forced
        self.event = event
        self.passed = passed
        self.held = held


def _brakes_for(plan: Plan | None, b: int) -> bool:
    """`plan` is a brake at once (no goal boundary) that passes b as well as it can: an
    earlier re-plan's for a cap out of reach (`Brakes.lost_cap`), which a re-plan as the
    window moves on keeps taking while b's target with zero acceleration there is still in
    the jerk gap near rest. The event's re-plan braked at once, the next one, the window
    moved on and no event, took x1 (an F4800 drop after 0.5 mm blocks at F60000 and F24000,
    override 100 → 80 % in the brake: 21.1 mm/s for 64, `test_run_brakes.py`)."""
    return plan is not None and plan.goal < 0 and plan.serves >= b


class Shift:
    """The re-plan toward a candidate, for the path state `st` under the constraints `con`,
    with the profiles of `tg` and the brakes of `br`; `Tracker` holds it."""

    def __init__(self, con: Constraints, st: PathState, tg: Targets, br: Brakes) -> None:
        self.con = con
        self.st = st
        self.tg = tg
        self.br = br

    def toward(
        self, r: Replan, cands: list[tuple[int, float, float, bool]], best_i: int, cap: float,
        target: float, skip: int, top: float,
    ) -> None:  # fmt: skip
        """Plan toward candidate best_i of `cands` (its chain's cap `cap`, its target
        `target`, `Targets.boundary_target`), shifting to the candidates after it where its
        target is out of reach; `skip` and `top`: a forced candidate that cannot bind from
        here, kept by not accelerating beyond its cap `top` (-1, the ceiling: none)."""
        s, v, a, seg, v_p = r.s, r.v, r.a, r.seg, r.v_p
        a_max, j_max, ceiling, w, dt = r.a_max, r.j_max, r.ceiling, r.w, r.dt
        forced, event, passed, held = r.forced, r.event, r.passed, r.held
        tb = self.con.tb
        b, s_c, _, gate = cands[best_i]
        d = s_c - s
        soft_from = b
        shifted = False
        horizon = max(self.con.horizon(v, a, a_max, j_max, dt), d)
        # Zero acceleration at a boundary that does not need it, below a feed cap the path can
        # no longer get down to (an override drop), is at a velocity from which the next
        # candidate may be lost too, although the path could still keep it by braking through
        # this one (a feed drop 5 mm before a corner: stress seed 1777, lifting). Then the path
        # aims at the next candidate, passing this one as it brakes (only its hard cap kept).
        first = cands[best_i]  # the candidate the shift, if any, passes first
        looked = list(cands)  # every candidate the shift looks at (`Brakes.brake_into`)
        while not gate:
            own = cands[best_i][2]
            hard = min(tb.point_cap[b], tb.cap[b])
            # its target: the cap the ones after it leave it, with zero acceleration; not
            # feasible nearer than the deceleration takes to ramp out (after an override drop
            # at 40 %, 3.3 mm ahead at 338 mm/s and −4.1 m/s², it takes 3.4 mm), nor where the
            # ones after it leave less than the path can get down to (a stop 0.8 mm after it)
            if (
                own >= hard
                or self.con.need(v, a, cap, True, a_max, j_max) <= d + SLACK_TOL
                or self.con.need(v, a, hard, False, a_max, j_max) > max(d - SLACK_MARGIN, 0.0)
            ):
                break  # its target is reachable, or its hard cap binds (kept as it is)
            # the constraints after b as a list of their own: one that the list left out for
            # a cap before b may bind once b is passed above its cap (its first is the next
            # constraint; within the braking horizon, also for a forced re-plan)
            tail = self.con.collect(s, seg, horizon, first=b + 1)
            if not tail and forced and target < GAP_FLOOR * min(cap, ceiling):
                # a forced re-plan, none within the brake to rest from here, and b's target
                # with zero acceleration at the low end of the jerk gap: the candidates after
                # b as far as the window reaches may still cap it. A forced re-plan 5.04 mm
                # before a feed cap of 100 mm/s, 0.5 mm before an M00 beyond the brake to
                # rest, at 72.2 mm/s and +7.6 m/s², aimed at 46.29 there, which it could not
                # reach from below (the brake to a velocity is longer than the brake to
                # rest), and passed the cap at 1.38 mm/s (feeds seed 915); it now aims at the
                # M00, passing the cap as it brakes. Only toward a stop: toward a corner of
                # 2.6 mm/s 0.1 mm after a feed cap the shift braked through the cap at once
                # (3.77 mm/s for 13.6; 9.86 without it, feeds seed 310)
                far = self.con.collect(s, seg, INF, first=b + 1)
                if far and self.con.is_stop(far[0][0]):
                    tail = far
            if not tail:
                break
            nb, ns, _, ngate = tail[0]
            ncap = self.con.target_cap(tail, 0)
            e = reach_velocity(ncap, max(ns - s_c - CHAIN_MARGIN, 0.0), a_max, j_max)
            if (
                self.con.need(v, a, e, False, a_max, j_max) <= d + SLACK_TOL
                and self.con.need(v, a, hard, True, a_max, j_max) <= d + SLACK_TOL
            ):
                # zero acceleration at b, at most e there, loses nothing after it (where the
                # path can have zero acceleration at b at all: an override drop to 40 % at
                # 48.8 mm/s and +6.0 m/s², 0.32 mm before a feed cap, the ramp to zero
                # acceleration 1.06 mm long; every target there was refused, 50 tracker
                # errors, a review's program)
                break
            cands, best_i = tail, 0
            looked += tail
            b, s_c, gate, cap = nb, ns, ngate, ncap
            d = s_c - s
            # a run boundary with the jerk gap's bound (`Targets.boundary_target`): a feed
            # drop lost after an override drop, the run boundary after its block, which that
            # block's ceiling caps, passed at x1 = 9.59 mm/s for 16 where x2 is nearer
            target = self.tg.boundary_target(
                tail, 0, cap, v, a, v_p, ceiling, a_max, j_max, w,
                self.tg.gap_rule(b, tail[0][2]),
            )  # fmt: skip
            shifted = True
        below = ceiling * (1.0 + CAP_TOL) + V_ROUND >= v_p  # not after an override drop
        top_b = min(cap, ceiling)
        # after an input change, or inside the brake at once it started for b
        changed = event or _brakes_for(held, b) or _brakes_for(passed, b)
        if not event and not forced:
            for kept in (passed, held):
                if kept is not None and _brakes_for(kept, b) and self.st.t < kept.t0 + kept.dur:
                    # inside that brake, no input changed: it goes on (re-planned in its last
                    # phase, where v_p is b's cap, the target profile toward the cap itself
                    # was refused, a tracker error and a dip to 3.56 mm/s, a cold review's
                    # program; or it took x1 from there, 7.11 mm/s for 8)
                    kept.window = w
                    self.st.plan = kept
                    return
        if (
            not shifted
            and not gate
            and not self.con.hold
            and (
                target > cands[best_i][2] * (1.0 + CAP_TOL) + V_ROUND
                # after an input change, the cap in the jerk gap (`pick_target`) and the
                # nearest velocity below it near rest: 1.25 mm/s for a cap of 8.44 after an
                # override drop to 10 % at 117 mm/s 2 mm before it, the path went down to
                # 1.06 mm/s (feeds seed 576); the brake at once passes it above, braking from
                # the change on (deviation 10: a CNC brakes at once, it does not dip)
                or (
                    changed
                    and v_p > top_b
                    and (
                        target < GAP_FLOOR * top_b
                        or (
                            target < top_b
                            and brake_crossing(v, a, top_b, top_b * top_b / target, a_max, j_max)
                            <= d + SLACK_TOL
                        )
                    )
                )
            )
            and self.br.lost_cap(cands, best_i, below, changed, a_max, j_max, w)
        ):
            return
        self.st.soft_from = soft_from
        for kept in (passed, None if event else held):
            if (
                kept is not None
                and kept.goal == b
                and kept.t0 <= self.st.t
                and abs(kept.v_end - top_b) <= CAP_TOL * top_b
                and abs(target - top_b) > CAP_TOL * top_b
            ):
                # the profile that brought the path to the boundary it just passed reaches b
                # at its cap, and nothing from here does (a new one from its last µm before
                # the brake can find the exact brake a few 10 nm too long): it keeps b. So
                # does the profile in hand where only the window moved on (no input changed:
                # it was planned under the same ceilings): a brake state at b's cap
                # (`Plan.a_end`) whose later cap the move raised, from where zero
                # acceleration at b at its cap is in the jerk gap (an F3000 drop after
                # 0.5 mm blocks at F60000 and F24000, look-ahead 10: x1, 26.9 for 50 mm/s)
                kept.window = w
                self.st.plan = kept
                return
        # above the ceiling (the override just dropped, or a hold): no acceleration, but the
        # brake toward the target may start from the current velocity
        # (a positive acceleration still lifts it to v_p while it is ramped down)
        if self.con.hold or v > ceiling:
            v_max = max(ceiling, target, v, v_p, 1e-12)
        else:
            # v_p too: a positive acceleration takes the path there whatever it plans (a cruise
            # ends at v_p = ceiling up to rounding; 3e-17 m/s above it made ruckig refuse every
            # target and the path passed the program end at 99 mm/s: stress seed 380, lifting)
            v_max = max(ceiling, target, v_p)
        if shifted:
            v_max = max(min(v_max, max(v, v_p)), target, 1e-12)  # no speeding up through them
        if skip >= 0:  # nor beyond the forced one's cap
            target = min(target, top)
            v_max = max(min(v_max, top), target, v, v_p)
        braked = (
            not self.con.hold
            and skip < 0
            and v_p > ceiling * (1.0 + CAP_TOL) + V_ROUND
            and self.br.brake_into(
                looked, v_p, s_c, target, min(ceiling, v_max), v_max, a_max, j_max, b, w
            )  # above a lowered ceiling: brake at once (deviation 10 of docs/geo-core.md)
        ) or self.br.brake_tail(
            looked, v_p, s_c, target, ceiling, v_max, a_max, j_max, b, w, forced
        )  # above the ceiling, below it once the acceleration is ramped out
        if not braked:
            self.tg.settle(s, v, a, v_p, s_c, target, cap, v_max, a_max, j_max, b, w,
                           self.tg.hard(b, w), passed, held, event, ceiling)  # fmt: skip
            if b == w and target <= 0.0 and best_i + 1 < len(cands) and v <= ceiling:
                # (not after a brake, nor above the ceiling: its v_max there is v, and the
                # profile to the floor could hold it, a cold review found)
                self.tg.keep_floor(cands[best_i + 1], v_max, a_max, j_max, w)
        plan = self.st.plan
        if plan is None or not shifted or plan.goal != b:
            return
        # the first candidate before b the shift's profile passes above its cap: `first`, or
        # one after it the path can still get down to (a cap between `first` and b, read by
        # neither the shift nor the steps, passed at 24.6 mm/s for 24.2: feeds seed 232)
        between = sorted(
            (c for c in looked if first[1] < c[1] < s_c and not c[3]
             and self.con.need(v, a, c[2], False, a_max, j_max) <= c[1] - s + SLACK_TOL),
            key=lambda c: c[1],
        )  # fmt: skip
        j = self.tg.pf.passed_above(plan, [first, *between], 1 + len(between))
        if j < 0 and self.tg.pf.rises_above(plan, first):
            j = 0
        if j > 0:
            first = between[j - 1]
        in_reach = self.con.need(v, a, first[2], False, a_max, j_max) <= first[1] - s + SLACK_TOL
        if (
            j < 0
            or self.br.keep_below(passed, first, b, w)
            or self.br.keep_below(held, first, b, w, target)
        ):
            return
        # the shift's profile passes `first` above its cap
        if in_reach and (
            self.br.brake_through([first, (b, s_c, cap, gate)], 1, target, a_max, j_max, w)
            or self.br.brake_under(looked, first, v_p, s_c, target, v_max, a_max, j_max, b, w)
            or (b != w and not gate)
        ):
            # a feed cap the path could still get below braking: a brake at once instead
            # (known deviation 12 of docs/geo-core.md, CAM seed 0), or a brake under it
            # (deviation 15); where both are refused, the steps re-plan toward the cap (a dip
            # there slowed falling feeds, feeds seed 394), but not where the goal is a run
            # boundary or a stop just after it: the dip follows (feeds seed 177, a corner of
            # 4.5 mm/s 1 mm after a drop to F6000, passed at 106.7 mm/s)
            return
        if (
            changed
            and below
            and not in_reach
            and self.br.brake_lost(looked, looked.index(first), a_max, j_max, w)
        ):
            # out of reach after an input change: the brake at once passes it above, as
            # where it is the candidate itself (`lost_cap`), not below it braking through
            # (override 100 → 60 % 2.6 ms before a 0.5 mm brake toward an F6000 block,
            # look-ahead 10, the window's end the shift's goal: 59.997 mm/s at −2.2 m/s² at
            # its boundary, ramped out to 53.8, 56.2 for 60 at the next one)
            return
        if below and self.br.dip_through(looked, first, a_max, j_max, w):
            # below it braking through (it came into view too late, or the shift's goal is
            # the window's end, toward which a cruise is no plan): known deviations 13 and 14
            # (0.1 mm blocks, look-ahead 10, F8110 -> F1740: the profile to rest at the
            # window's end, 0.3 mm after the drop, passed it at 63.4 mm/s for 29 with 2 µm
            # of slack left)
            return
        if below and not in_reach:
            # `first` is lost, the blocks after it are not: a brake under their caps, the
            # caps after it the path can still get below read again (the lists leave them
            # out as kept by `first`, `collect`): an override drop to 30 % lowered F6000
            # blocks to 30 mm/s, their first boundary out of reach, and the shift's profile
            # passed the second, 0.5 mm on, at 75.9 mm/s (feeds seed 192)
            after = self.con.collect(s, seg, s_c - s, first=first[0] + 1)
            self.br.brake_under(looked + after, first, v_p, s_c, target, v_max, a_max, j_max, b, w)
