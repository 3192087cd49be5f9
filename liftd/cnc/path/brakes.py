"""The brakes at once: where the path brakes from the velocity it has now instead of at the
latest moment a time-optimal profile would (`Brakes`, a part of the tracker, `Tracker.br`,
that holds the constraint queries, the path's state and the target profiles of
`targets.py`). A CNC brakes at once after an override drop (known deviation 10 of
docs/geo-core.md: `brake_first`, `brake_into`); where the shift (`Shift.toward`) would
give up a feed cap the path can still get below braking (deviation 12: `brake_through`,
`keep_below`), or one that came into view too late for zero acceleration there (deviation
13: `dip_through`). Each is slower than the late brake, never above a cap and never at
rest; `_first_keeps` is the test they share: a brake at once and a cruise after it keep
every candidate ahead.
"""

from __future__ import annotations

from liftd.cnc.path.constraints import (
    CAP_TOL,
    INF,
    SLACK_MARGIN,
    SLACK_TOL,
    V_ROUND,
    Constraints,
)
from liftd.cnc.path.plan import CRUISE, SETTLE, PathState, Plan
from liftd.cnc.path.profiles import lowest_rise, only_brakes
from liftd.cnc.path.targets import Targets, highest
from liftd.cnc.path.velocity import (
    brake_crossing,
    brake_distance,
    projected_velocity,
    ramp_distance,
)

DIP_STEPS = 10  # `Brakes.dip_through`: its velocity within 2^-10 of the cap (a ruckig solve each)
DIP_FLOOR = 0.1  # ... and never below this fraction of the cap (a brake nearly to rest is a stop)
BISECT_STEPS = 24  # `Brakes.brake_first`: its velocity within 2^-24 of the interval searched
BRAKE_CRUISE = 0.25  # share of the way `Brakes.brake_through`'s cruise may take at most
UNDER_RISE = 0.95  # `Brakes.brake_under`: its profile speeds up again from at least this × v_max


class Brakes:
    """The brakes at once, for the path state `st` under the constraints `con`, with the
    profiles of `tg`; `Tracker` holds it and chooses among them and the target profiles."""

    def __init__(self, con: Constraints, st: PathState, tg: Targets) -> None:
        self.con = con
        self.st = st
        self.tg = tg

    def lost_cap(
        self, cands: list[tuple[int, float, float, bool]], i: int, below: bool, event: bool,
        a_max: float, j_max: float, w: int,
    ) -> bool:  # fmt: skip
        """Candidate i, a feed cap, is out of reach and nothing after it is in view to shift to
        (its block goes on past the horizon): known deviation 15 of docs/geo-core.md. Where it
        came into view too late, below it braking through (`dip_through`, deviation 13), else
        a brake at once to it (`brake_lost`); where an input change put it out of reach, the
        brake at once first, as the CNC brakes after an override drop (a dip there went to
        2.03 mm/s in a block of 3 after an override drop to 60 % 12 µm before it, a review's
        program; the check excuses passing it above as far as the brake from the change could
        not avoid it)."""
        if event and self.brake_lost(cands, i, a_max, j_max, w):
            return True
        if below and self.dip_through(cands, cands[i], a_max, j_max, w):
            return True
        return not event and self.brake_lost(cands, i, a_max, j_max, w)

    def brake_first(
        self, cands: list[tuple[int, float, float, bool]], ceiling: float, a_max: float,
        j_max: float, w: int,
    ) -> bool:  # fmt: skip
        """Above a lowered ceiling (an override drop): a brake at once (ruckig's velocity
        interface) down to the ceiling, then a cruise at it, where that keeps every candidate
        ahead (`_first_keeps`); the steps re-plan toward the first candidate whose slack runs
        out, as from any cruise. A CNC brakes from the velocity it has at once; the
        time-optimal profile toward the binding candidate holds that velocity above F ×
        override and brakes late (known deviation 10 of docs/geo-core.md: wide seed 79, 150
        mm/s for 1.4 ms after an override drop to 10 mm/s). Else the brake at once to the
        highest velocity below the ceiling from which a cruise keeps them (a stop or a low
        cap near ahead: narrow seed 426, override 100 → 70 % at 100 mm/s 1.8 mm before a
        stop), re-planned where it ends (`SETTLE`: a cruise below the ceiling is never
        re-planned as the window moves on, and crawled to the program's end, a review found),
        never below the lowest cap ahead (with a jerk limit a brake to a lower velocity can be
        the shorter: CAM seed 956, on the exact brake to 2.68 mm/s at the drop, a brake to
        2.45 fitted and dipped). Where the ceiling's block ends before the candidates and a
        run boundary lies inside the brake to the ceiling, first the brake at once toward the
        ceiling ramped out at the block's end (`_ceiling_end`), a plan of its own (`SETTLE`).
        False where none keeps them (a feed cap it can no longer get below, a run boundary
        inside the brake: `brake_into`)."""
        e, goal = ceiling, CRUISE
        below: list[int] = []  # the feed caps its own velocity keeps (`_first_keeps`)
        if not self._first_keeps(cands, e, a_max, j_max, below=below):
            below = []
            end = self._ceiling_end(cands, ceiling, a_max, j_max, w)
            if end > ceiling and self._first_keeps(cands, end, a_max, j_max, below=below):
                e, goal = end, SETTLE
            else:
                good = min((c[2] for c in cands if not self._moves_on(c)), default=0.0)
                if good >= ceiling or not self._first_keeps(cands, good, a_max, j_max, below=[]):
                    # nothing between (path-based Lifting, wide seed 879: a run boundary 1 µm
                    # ahead above the ceiling, a brake of no length planned again and again)
                    return False
                good = highest(
                    good, ceiling, BISECT_STEPS,
                    lambda e: self._first_keeps(cands, e, a_max, j_max, below=[]),
                )  # fmt: skip
                if good <= 0.0:
                    return False  # never a brake to rest where no stop is
                e, goal = good, SETTLE
                below = []
                self._first_keeps(cands, e, a_max, j_max, below=below)
        plan = self.tg.pf.velocity_plan(e, goal, w, a_max, j_max)
        if plan is None or (goal == SETTLE and plan.dur <= 0.0):
            return False  # refused, or a brake of no length, re-planned at its end without end
        if below:
            # the steps read them by their hard caps (`violated`: with zero acceleration
            # there they are out of reach from inside the brake, a forced re-plan toward them
            # was refused, feeds seed 3)
            plan.soft_from, plan.serves = min(below), max(below)
            self.st.soft_from = plan.soft_from
        self.st.plan = plan
        return True

    def _ceiling_end(
        self, cands: list[tuple[int, float, float, bool]], ceiling: float, a_max: float,
        j_max: float, w: int,
    ) -> float:  # fmt: skip
        """Where the lowered ceiling ends before every candidate ahead and the blocks from its
        end up to the first candidate are higher: the velocity the brake at once toward the
        ceiling (ruckig's velocity interface, as `brake_first`'s) has where the ceiling's block
        ends, its deceleration there ramped out at full jerk (v + a·|a|/2J); 0 where none.
        A CNC brakes toward the ceiling while it holds and speeds up again once it rises;
        this brake, ruckig's time-optimal one to that velocity, is the same motion up to the
        block's end and a cruise after it, re-planned where it ends and at the block's end
        (override 100 → 10 % at 38.9 mm/s, 0.2 mm before the end of an F6000 block and
        0.4 mm before a rounding kink capped at 29.3 mm/s by a second F6000 block: the brake
        to the ceiling of 10 mm/s does not end before the kink, whose target was taken against
        that ceiling, x2 of the jerk gap above it, the slowest brake that fills the 0.4 mm:
        21.0 mm/s at the kink, 27.2 now; feeds seed 942, `test_jerk_gap.py`). One ruckig
        call; the blocks read are those before the first candidate, in the window."""
        tb = self.con.tb
        seg = self.con.seg
        if self.con.hold or not cands or seg + 1 >= tb.n:
            return 0.0
        if abs(ceiling - tb.ceiling(seg, self.con.ov)) > CAP_TOL * ceiling + V_ROUND:
            return 0.0  # a cap ahead as the brake's end (`_brake_past`), not the block's ceiling
        s_end = tb.s[seg + 1]
        first = min(c[1] for c in cands)
        if s_end >= first - SLACK_TOL:
            return 0.0
        plan = self.tg.pf.velocity_plan(ceiling, CRUISE, w, a_max, j_max)
        if plan is None:
            return 0.0
        t_end = plan.time_at(s_end, INF)
        if t_end == INF:
            return 0.0
        _, v_e, a_e = plan.at(t_end)
        e = projected_velocity(v_e, a_e, j_max)
        k = seg + 1
        while k < min(tb.n, w) and tb.s[k] < first - SLACK_TOL:
            if tb.ceiling(k, self.con.ov) < e:
                return 0.0
            k += 1
        return e

    def brake_into(
        self, cands: list[tuple[int, float, float, bool]], v_p: float, s_c: float,
        target: float, ceiling: float, v_max: float, a_max: float, j_max: float, b: int,
        w: int,
    ) -> bool:  # fmt: skip
        """Above a lowered ceiling, where the brake at once to it is not enough
        (`brake_first`): the target profile with ruckig's v_max at the ceiling, or lower, at
        the lowest cap of the candidates before b that the path can still get down to with
        zero acceleration there (a profile held at the ceiling passes them above); ruckig then
        brakes from outside its limits at once (its brake profile) before the profile to the
        target. After an override drop to 40 % at 360 mm/s over 0.1 mm blocks whose feed
        caps it could no longer get down to, the profile with v_max = v held 360 mm/s for
        22 ms. Kept where ruckig accepts it and it does not dip below the target; else (False)
        the target profile with v_max = v stays (known deviation 10 of docs/geo-core.md)."""
        s, v, a = self.st.s, self.st.v, self.st.a
        top = ceiling
        for _, s_j, cap, _ in cands:
            if s_j < s_c and cap < top and brake_distance(v, a, cap, a_max, j_max) <= s_j - s:
                top = cap
        top = max(top, target)
        if top >= v_max or not self.tg.pf.try_target(s, v, a, s_c, target, top, a_max, j_max, b, w):
            return False
        if self.tg.pf.dips(min(v, v_p, target)):
            return False
        # from above its v_max the profile only brakes: ruckig's brake into its limits is not
        # a brake to v_max with zero acceleration, and the profile after it can brake to rest
        # and start again (a review found: override 100 → 30 % at 200 mm/s 5.1 mm before an
        # M00, at rest 0.7 mm before it; a dip below a target of 0 is no dip). Its pieces were
        # read by `dips`.
        assert self.st.plan is not None and self.st.plan.ev.phases is not None
        return only_brakes(self.st.plan.ev.phases)

    def brake_under(
        self, looked: list[tuple[int, float, float, bool]], first: tuple[int, float, float, bool],
        v_p: float, s_c: float, target: float, v_max: float, a_max: float, j_max: float, b: int,
        w: int,
    ) -> bool:  # fmt: skip
        """The shift's profile toward b (`Shift.toward`) passes a feed cap the path can
        still get below above it, and the brake through to b's target is refused (b a stop,
        or the cruise after the brake too long): the target profile toward b with ruckig's
        v_max at the lowest feed cap before b that the path can still get down to with zero
        acceleration there; from above it ruckig brakes at once (its brake into its limits),
        then holds it and brakes late for b. Kept (True) where ruckig accepts it, it passes
        each of those caps below it, it does not dip below its ends, and it speeds up again
        only from at least UNDER_RISE of v_max (ruckig's brake ends still braking: from 145
        mm/s toward v_max 100 it went down to 49 and came back); else a brake at once to that
        cap (below); else (False) the shift's profile stays. Where `first` is lost (the
        caller's other case), v_max is at most its cap: its blocks are still ahead. The steps
        do not get such a cap back (they check the caps the shift passes by their hard caps
        only): 0.5 mm blocks at F45000, then F6000 for 1 mm and an M00, look-ahead 30 (feeds
        seed 4): the profile to rest at the M00, time-optimal, passed the F6000 boundary at
        108.7 mm/s (known deviation 15 of docs/geo-core.md). Slower than the late brake,
        never above a cap it can still keep."""
        s, v, a = self.st.s, self.st.v, self.st.a
        kept: list[tuple[int, float, float, bool]] = []
        lost: list[int] = []  # the caps before b it can no longer get down to
        for c in looked:
            if c[1] >= s_c or c[3]:
                continue
            if brake_distance(v, a, c[2], a_max, j_max) <= c[1] - s + SLACK_TOL:
                kept.append(c)
            else:
                lost.append(c[0])
        # where `first` is lost, no higher than its cap (its blocks are still ahead)
        caps = [c[2] for c in kept] + ([first[2]] if first[0] in lost else [])
        if not caps:
            return False
        top = max(min(caps), target)
        if top >= v_max:
            return False
        shift = self.st.plan
        kept.sort(key=lambda c: c[1])
        if self.tg.pf.try_target(s, v, a, s_c, target, top, a_max, j_max, b, w):
            plan = self.st.plan
            assert plan is not None
            if not self.tg.pf.dips(min(v, v_p, target)):
                assert plan.ev.phases is not None
                if (
                    lowest_rise(plan.ev.phases) >= UNDER_RISE * top
                    and self.tg.pf.passed_above(plan, kept, len(kept)) < 0
                ):
                    return True
        self.st.plan = shift
        # else the brake at once to it with zero acceleration there (ruckig's velocity
        # interface), or to the highest velocity below it that keeps every candidate, and the
        # steps from there (`brake_first`; feeds seed 299: falling feeds on 2 mm blocks,
        # ruckig's profile went down to 174.6 mm/s toward a v_max of 185.5)
        return self._brake_past(looked, lost, top, a_max, j_max, w)

    def brake_tail(
        self, cands: list[tuple[int, float, float, bool]], v_p: float, s_c: float,
        target: float, ceiling: float, v_max: float, a_max: float, j_max: float, b: int,
        w: int, forced: bool,
    ) -> bool:  # fmt: skip
        """The path is above the ceiling, braking, and below it once its acceleration is
        ramped out (v_p): the tail of a brake into a ceiling, or an override that rose inside
        a brake. Where a brake at once to v_p and a cruise there keep every candidate
        (`_first_keeps`; not in a forced re-plan: its step loses one), that ramp-out
        (`SETTLE`, re-planned at its end, from where the ceiling is ruckig's v_max); else the
        target profile with v_max at the ceiling, which brakes on into it at once (ruckig's
        brake into its limits), where it does not dip below its ends. True where either is
        planned. With v_max at v the target profile sped up again above the ceiling after
        the ramp-out (override 10 → 80 % at 70.1 mm/s and −2.0 m/s², 69.9 mm/s in a block of
        69.65; a review's program), or held the velocity above it (a forced re-plan
        0.03 mm/s above an F29399 ceiling at 15 %, 4 ms after the drop, passed the next
        boundary 0.02 mm/s above its cap)."""
        s, v, a = self.st.s, self.st.v, self.st.a
        if self.con.hold or not v_p <= ceiling * (1.0 + CAP_TOL) + V_ROUND < v:
            return False
        if not forced and self._first_keeps(cands, v_p, a_max, j_max):
            plan = self.tg.pf.velocity_plan(v_p, SETTLE, w, a_max, j_max)
            if plan is not None and plan.dur > 0.0:
                self.st.plan = plan
                return True
        top = max(min(v_max, ceiling), target, 1e-12)
        if not self.tg.pf.try_target(s, v, a, s_c, target, top, a_max, j_max, b, w):
            return False
        return not self.tg.pf.dips(min(v, v_p, target))

    def _brake_past(
        self, cands: list[tuple[int, float, float, bool]], lost: list[int], e: float,
        a_max: float, j_max: float, w: int,
    ) -> bool:  # fmt: skip
        """`brake_first` to e with the candidates the path can still keep; the lost ones (their
        boundaries) the plan passes as well as it can (`Plan.serves`, `Plan.soft_from`): read
        by the steps as caps to keep, their forced re-plans and the brake took turns, 203
        tracker errors after an override drop to 20 % (feeds seed 178)."""
        if not self.brake_first([c for c in cands if c[0] not in lost], e, a_max, j_max, w):
            return False
        if lost:
            plan = self.st.plan
            assert plan is not None
            soft = [plan.soft_from] if plan.soft_from >= 0 else []  # and the ones it keeps
            plan.soft_from = self.st.soft_from = min([*lost, *soft])
            plan.serves = max(plan.serves, *lost)
        return True

    def brake_lost(
        self, cands: list[tuple[int, float, float, bool]], i: int, a_max: float, j_max: float,
        w: int,
    ) -> bool:  # fmt: skip
        """Candidate i, a feed cap, is out of reach (an override drop lowered it, or it came
        into view too late), and the path is not above its own block's ceiling: a brake at
        once to its cap, or to the highest velocity below it that keeps every candidate the
        path can still keep (`brake_first`). Its block is still ahead: the path is above its
        feed until it is down to it, and the target at its boundary (the nearest velocity
        above the cap with zero acceleration there) left the brake for the boundary, after
        which the cap of the block after it was lost too (override 100 → 60 % 0.5 mm before
        an F3000 block of 0.4 mm: 50 mm/s at its start, 35.3 at its end for 30; feeds seed
        230). The lost caps are the plan's to pass as well as it can (`_brake_past`)."""
        lost = self._lost(cands, a_max, j_max)
        if cands[i][0] not in lost:
            return False
        # the others the brake to rest still gets below are not lost, however their brake
        # with zero acceleration there reads (a cap in the jerk gap): `brake_first` keeps
        # them or, where its brake at once to i's cap cannot, declines, and the shift's
        # target decides (x1 below such a cap). Read as lost, an override drop to 60 %
        # 0.22 mm before an F1200 block at 34.3 mm/s and −2.1 m/s², its 12 mm/s reachable
        # only below (x1 = 6.1), was left to the brake to 30, the lost cap before it, which
        # entered the block at 29.4 (`drop_scenario(511)` with its drop 20 ms earlier, a
        # cold review's variant; now x1)
        s, v, a = self.st.s, self.st.v, self.st.a
        lost = [
            c[0] for c in cands
            if c[0] in lost and (
                c[0] == cands[i][0]
                or brake_crossing(v, a, 0.0, c[2], a_max, j_max) > c[1] - s + SLACK_TOL
            )
        ]  # fmt: skip
        return self._brake_past(cands, lost, cands[i][2], a_max, j_max, w)

    def brake_down(
        self, cands: list[tuple[int, float, float, bool]], ceiling: float, a_max: float,
        j_max: float, w: int,
    ) -> bool:  # fmt: skip
        """Above a lowered ceiling, where the brake at once to it (`brake_first`) is refused
        because a feed cap ahead is out of reach: the same brake past the lost caps
        (`_brake_past`), rather than the target profile, which holds the velocity before it
        brakes (override 100 → 30 % at 31.5 mm/s 0.19 mm before an F1734 block and 0.39 mm
        before an F1332 one: the profile toward the second held 31.5 mm/s, known deviation
        10 of docs/geo-core.md, a review's program)."""
        lost = self._lost(cands, a_max, j_max)
        if not lost:
            return False
        # down to the lowest of them at most: their blocks are still ahead (to the ceiling,
        # an F3000 block 0.5 mm on under an override of 10 % was entered at 50 mm/s for 5:
        # feeds seed 189)
        e = min(ceiling, *(c[2] for c in cands if c[0] in lost))
        return self._brake_past(cands, lost, e, a_max, j_max, w)

    def _lost(
        self, cands: list[tuple[int, float, float, bool]], a_max: float, j_max: float
    ) -> list[int]:
        """The feed caps of `cands` the path can no longer get down to."""
        s, v, a = self.st.s, self.st.v, self.st.a
        return [
            c[0] for c in cands
            if not c[3] and brake_distance(v, a, c[2], a_max, j_max) > c[1] - s + SLACK_TOL
        ]  # fmt: skip

    def _moves_on(self, cand: tuple[int, float, float, bool]) -> bool:
        """`cand` is the window's end (rest there, or its floor) where that is not a stop: the
        window moves on with the path, block by block. Not a feed cap at the same boundary,
        which stays when the window moves on (`_first_keeps`)."""
        w = self.con.window_end
        return (
            cand[0] == w
            and cand[3]
            and w < self.con.tb.n
            and not self.con.is_stop(w)
            and self.con.window_floor(w) > 0.0
        )

    def _first_keeps(
        self, cands: list[tuple[int, float, float, bool]], e: float, a_max: float, j_max: float,
        margin: float = SLACK_MARGIN, brake: Plan | None = None, below: list[int] | None = None,
    ) -> bool:  # fmt: skip
        """The brake at once from the path's state to e (zero acceleration there) and a cruise
        at e keep every candidate: a run boundary or stop after the brake's end with room to
        get down to its cap from e; a feed cap the brake passes below it (it reaches any
        velocity sooner than the brake to it with zero acceleration there; where `brake`, that
        brake's profile, is given, its own velocity there: a feed drop 20 µm too near for the
        brake to its cap with zero acceleration, passed 10 mm/s below it by the brake to a
        lower drop after it, made that one be passed 80 mm/s above it, known deviation 14 of
        docs/geo-core.md), or one after it that the path gets down to from e. Within `margin`
        (SLACK_MARGIN: as `violated` reads them).
        The window's end where it is not a stop moves on with the path (read by its feed cap
        alone): the steps keep it reachable as from any cruise (`violated`, a forced
        re-plan toward it); read as fixed, rest or its floor there held the brake to
        26 mm/s for a ceiling of 300 after an override drop on a line of 0.1 mm blocks
        (look-ahead 120, 12 mm: the brake to the ceiling took 6.2 of them, the window moving
        on by as much; a review found).
        Where `below` is a list, a feed cap at e or above that the brake to it with zero
        acceleration there no longer fits before is read on the brake's own profile (which
        brakes on through it toward e: `brake_crossing`, closed form, no solve) `margin`
        before it, and appended where kept: falling feeds on 1 mm blocks, 157 mm/s at
        −2.5 m/s² 1 mm before F8900 (148.3 mm/s) and 3 mm before F7500 (125): the brake to
        148.3 with zero acceleration takes 1.1 mm, the brake to 125 is at 131 mm/s after
        1 mm; read by the zero-acceleration brake, no brake at once was found and the target
        profile toward F7500 passed F8900 at 149.3 (feeds seed 413)."""
        s, v, a = self.st.s, self.st.v, self.st.a
        d_e = brake_distance(v, a, e, a_max, j_max)
        for c in cands:
            b, s_b, cap, gate = c
            if self._moves_on(c):
                # the window's end moves on: the steps keep it reachable (`violated`) where
                # it is a run boundary; a feed drop there stays a feed cap (read as rest there
                # and left out, a dip to 76 mm/s passed a drop to 46 there above it, and the
                # steps and the dip took turns: 157 ruckig calls in a cycle, a review found)
                if self.con.tb.gate[b]:
                    continue
                cap, gate = self.con.own_cap(b), False
            room = s_b - s
            if room - d_e < margin:
                if gate:
                    return False
                if brake is not None:
                    if (
                        brake_distance(v, a, cap, a_max, j_max) > room - margin
                        and self.tg.pf.passed_above(brake, [(b, s_b, cap, gate)], 1) >= 0
                    ):
                        return False
                elif cap * (1.0 + CAP_TOL) + V_ROUND < e:
                    # a cap below e inside the brake is passed above it (accepted where its
                    # own brake fitted until the tenth round)
                    return False
                elif brake_distance(v, a, cap, a_max, j_max) > room - margin:
                    # one at e or above is passed below it by the brake at once to e no
                    # later than the brake to it with zero acceleration there gets there,
                    # kept with `margin` to spare as the steps read it (`violated`: to a
                    # rounding only, a forced re-plan toward such a cap from inside the
                    # brake was refused, feeds seed 3); else its own profile decides
                    # (not the window's end: the steps keep it, `violated` reads it where
                    # it is the plan's, a cold review found)
                    if (
                        below is None
                        or self._moves_on(c)
                        or brake_crossing(v, a, e, cap, a_max, j_max) > room - margin
                    ):
                        return False
                    below.append(b)
            elif (cap < e or gate) and (
                room - d_e - self.con.need(e, 0.0, cap, gate, a_max, j_max) < margin
            ):
                return False
        return True

    def brake_through(
        self, cands: list[tuple[int, float, float, bool]], k: int, e: float, a_max: float,
        j_max: float, w: int,
    ) -> bool:  # fmt: skip
        """A brake at once to e, candidate k's target, then a cruise at it (ruckig's velocity
        interface), kept where it gets there before k and passes every candidate before k
        below its cap: braking toward the lowest, it is below the brake toward each of them
        (`Constraints.target_cap`), which keeps that one where its own cap is in reach. Where
        the time-optimal profile toward k holds the velocity and passes a feed drop above its
        cap (CAM seed 0: boundary 52 at 34.19 for 33.09 mm/s 0.2 mm before a run boundary of
        25.82, its target at zero acceleration out of reach, its cap not; the shift of
        `Shift.toward` dropped that cap, known deviation 12 of docs/geo-core.md). Slower than a
        late brake, never above a cap. Not toward rest or the window's end (a cruise at 0 is
        never re-planned: a review found the path stand still for good before an M00), and
        only where the cruise after the brake takes at most BRAKE_CRUISE of the way (one to a
        corner of 0.43 mm/s 4.8 mm early crawled there, 12 % of the program's time)."""
        b, s_k = cands[k][0], cands[k][1]
        if e <= 0.0 or self.con.is_stop(b) or b == w:
            return False
        plan = self.tg.pf.velocity_plan(e, CRUISE, w, a_max, j_max)
        if (
            plan is None
            or plan.p_end > s_k
            or s_k - plan.p_end > BRAKE_CRUISE * (s_k - self.st.s)
            or self.tg.pf.passed_above(plan, cands, k) >= 0
        ):
            return False
        plan.serves, plan.soft_from = cands[k][0], cands[0][0]
        self.st.plan, self.st.soft_from = plan, cands[0][0]
        return True

    def dip_through(
        self, cands: list[tuple[int, float, float, bool]], first: tuple[int, float, float, bool],
        a_max: float, j_max: float, w: int,
    ) -> bool:  # fmt: skip
        """A feed cap that came into view too late for the path to get down to it with zero
        acceleration there, where the path is not above its ceiling (a feed drop, also under
        a lower override the path already rides below): the brake at once to the highest
        velocity e below it from which the brake passes it below its cap, and a cruise at e
        that keeps every other candidate with twice the step's margin (`SETTLE`, re-planned
        where the brake ends; with the margin alone the step found another cap out of reach
        the next cycle, and the forced re-plans toward it and the dip took turns, up to 16
        re-plans a cycle: a review found). With a jerk limit the brake to rest is not the
        shortest way down to every velocity (`brake_reach`): a look-ahead of 30 blocks of
        0.1 mm (3 mm) at 141 mm/s lets the path stop at its end in 2.65 mm, and the brake to
        a drop to F3600 at the window's end takes 2.86 mm; the path passed the F3600 blocks
        at 141 mm/s (a review's program, 0.1 mm blocks, F12000 → F3600). The dip below the
        cap after it is the price of the window: slower, never above a cap, never at rest
        (False where only a brake to rest would pass it below). The plan is kept through the
        boundaries before that cap (`Tracker._arrive`)."""
        cap = first[2]
        others = [c for c in cands if c[0] != first[0]]

        found: list[Plan] = []  # the plan of the last velocity that passes below

        def passes_below(e: float) -> bool:
            plan = self.tg.pf.velocity_plan(e, SETTLE, w, a_max, j_max)
            if plan is None or plan.dur <= 0.0 or self.tg.pf.passed_above(plan, [first], 1) >= 0:
                return False
            if not self._first_keeps(others, e, a_max, j_max, 2.0 * SLACK_MARGIN, plan):
                return False
            found.append(plan)
            return True

        if not passes_below(DIP_FLOOR * cap):
            return False
        good = highest(DIP_FLOOR * cap, cap, DIP_STEPS, passes_below)
        kept = found[-1]
        # it keeps that cap, passed below it braking, and the feed caps after it up to the
        # first one below e or a run boundary (below them braking, `_first_keeps`, or at e):
        # the steps check those by their hard caps only. Read by `violated` as caps to reach
        # with zero acceleration, one of them was out of reach from inside the brake the next
        # step, and the forced re-plans toward it and the dip took turns, 16 re-plans and 88
        # ruckig solves in a cycle (a review found: F6000, F5400, F540 on 0.2 mm blocks)
        serves = first[0]
        for b, s_b, c, gate in sorted(others, key=lambda o: o[1]):
            if s_b <= first[1]:
                continue
            if gate or c < good:
                break
            serves = b
        # so are the caps before it it passes below (`_first_keeps` with the brake): read by
        # `violated` with zero acceleration there, the one before `first` was out of reach
        # at each step, and a forced re-plan and the dip took turns until the dip's cap was
        # lost too (feeds seed 223: falling feeds on 0.5 mm blocks, F8610 passed at 151 mm/s
        # for 143.5)
        soft = min(first[0], *(c[0] for c in cands))
        kept.serves, kept.soft_from = serves, soft
        self.st.plan, self.st.soft_from = kept, soft
        return True

    def keep_below(
        self, passed: Plan | None, first: tuple[int, float, float, bool], b: int, w: int,
        target: float = INF,
    ) -> bool:  # fmt: skip
        """The shift's new profile toward b passes `first` above its feed cap, and the one that
        brought the path to the boundary it just passed, toward the same goal, passes it below:
        that one is kept (True). As the window moves on, the goal's target rises and each
        re-plan brakes later; one that gives up a cap the profile in hand still keeps is the
        step that loses it (known deviation 12 of docs/geo-core.md, CAM seed 956: boundary 93,
        114.8 mm/s, passed at 113.8 by the profile in hand, at 120.9 by the new one). So is
        the profile in hand where only the window moved on, if it ends at b's `target` now
        (a brake under the cap, `brake_under`, re-planned from inside its brake at each block
        lost the cap again: feeds seed 4; one toward rest at the window's end it planned for
        is not kept once that end has moved on and b's target is above rest)."""
        if (
            passed is None
            or passed.goal != b
            or passed.t0 > self.st.t
            or (target < INF and abs(passed.v_end - target) > CAP_TOL * target + V_ROUND)
            or self.tg.pf.passed_above(passed, [first], 1) >= 0
        ):
            return False
        passed.window = w
        self.st.plan = passed
        return True


def rests_before(
    cands: list[tuple[int, float, float, bool]], s: float, v: float, a: float,
    s_b: float, a_max: float, j_max: float,
) -> bool:  # fmt: skip
    """The brake to rest from (v, a) ends before s_b and before every run boundary in
    `cands` (where the path acceleration must be zero), so it keeps them all: braking
    harder than any profile to a boundary, it passes the others below their caps. Before
    them by SLACK_MARGIN: a brake that ends on a run boundary reaches it with the rounding
    of its last acceleration (−0.0004 m/s², wide seeds 81, 101, 369, 459, 693), where
    the target profile to rest there has zero acceleration by construction. Where s_b,
    a feed cap, lies inside the brake, the feed caps there are read off the brake's own
    profile. A feed hold's brake (`Tracker._replan`)."""
    if projected_velocity(v, a, j_max) > 0.0:
        stop = brake_distance(v, a, 0.0, a_max, j_max) + SLACK_MARGIN
    else:
        stop = ramp_distance(v, a, j_max) + SLACK_MARGIN
    if not all(not gate or stop <= s_c - s for _, s_c, _, gate in cands):
        return False
    if stop <= s_b - s:
        return True
    # a feed cap inside the brake: read off the brake's own profile (`brake_crossing`,
    # SLACK_MARGIN before it; the lowest velocity at b with zero acceleration there was
    # 104.2 mm/s for a cap of 107.3, 1 mm ahead at 115.7 mm/s, look-ahead 3: the target
    # profile toward it held 104.2 mm/s at b before the brake to rest went on, 95.3 at
    # the next boundary, feeds seed 787)
    return all(
        brake_crossing(v, a, 0.0, cap, a_max, j_max) <= s_c - s - SLACK_MARGIN
        for _, s_c, cap, _ in cands
        if s_c - s < stop
    )
