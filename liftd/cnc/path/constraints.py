"""What the path tracker (`tracker.py`) must keep, as queries on the prepared path table: the
constraint boundaries ahead (static ones from the table, the lift stops, the end of the
look-ahead window), their caps, and for a state (s, v, a) the least distance the path needs to
get below each cap (closed forms in `velocity.py`): a constraint's *slack* is the distance left
minus that need. `Constraints` holds the state these queries read (the window's segment, the
inputs, the stop sets); the tracker and its other parts hold it (`Tracker.con`).

Effective caps come from a backward pass over the constraints up to the next run boundary (and,
for that boundary, beyond it as far as they can matter): a cap that a later constraint makes
unreachable is lowered, so arriving at a constraint with zero acceleration below its effective
cap leaves every later one reachable. The work is bounded by MAX_CANDIDATES constraints at once:
the last of them stands for those after it as a run boundary does (zero acceleration there).
"""

from __future__ import annotations

from collections.abc import Iterator

from liftd.cnc.path.table import PathTable
from liftd.cnc.path.velocity import (
    brake_distance,
    brake_reach,
    projected_velocity,
    ramp_crossing,
    ramp_distance,
    reach_velocity,
    reach_velocity_any_above,
)

INF = float("inf")
MAX_CANDIDATES = 24  # constraints considered at once; the last one stands for those after it
SLACK_TOL = 1e-9  # m
# A step is kept only if every constraint keeps this much slack: the profile toward it from the
# step's start is then comfortably feasible for ruckig (at the very edge it may refuse by
# rounding). 1 µm of path costs nothing measurable.
SLACK_MARGIN = 1e-6  # m
CHAIN_MARGIN = 2.0 * SLACK_MARGIN  # caps from a chain leave this much slack for the next one
CAP_TOL = 1e-6  # relative: a crossing velocity within this of its cap is at the cap
GATE_TOL = 1e-6  # m/s²: zero acceleration at a run boundary, within ruckig's precision
V_ROUND = 1e-12  # m/s: a velocity this close above a cap is at the cap (rounding)


class Constraints:
    """The tracker's constraint queries over one table, and the state they read."""

    def __init__(
        self,
        table: PathTable,
        look_ahead: int,
        lift_stops: set[int] | None = None,
        acked: set[int] | None = None,
    ) -> None:
        self.tb = table
        self.n = table.n
        self.look_ahead = max(1, look_ahead)
        # up to this path position no constraint can bind within a step (no checks needed)
        self._clear_s = -INF
        self.seg = 0  # segment containing s (its start boundary is behind the path)
        self.ov = 1.0
        self.hold = False
        self.lift_stops = lift_stops if lift_stops is not None else set()
        self.acked = acked if acked is not None else set()
        self._beyond_key: tuple[int, int, float, float] | None = None
        self._beyond_val = INF
        self._beyond_open = False  # the last `_beyond` chain ended at the window's end or a cut
        # (window end, override, its block before ahead) of `window_floor`'s last value
        self._floor_key = (-1, -1.0, False)
        self._floor_val = 0.0
        self._low = INF  # the lowest cap `collect` kept so far (`_ahead` leaps below it)

    def set_inputs(self, ov: float, hold: bool) -> bool:
        """Override (fraction) and feed hold; whether they changed (the constraints are then
        checked again). Override 0 acts as a hold; the caps keep the last override above 0 (a
        stopping path does not make every corner a stop)."""
        hold = hold or ov <= 0.0
        cap_ov = ov if ov > 0.0 else self.ov
        if cap_ov == self.ov and hold == self.hold:
            return False
        self.ov, self.hold = cap_ov, hold
        self.recheck()
        return True

    def recheck(self, stops: bool = False) -> None:
        """Check the constraints again from the next step on (`_clear_s`: a re-plan, new
        inputs); with `stops`, also the chains behind run boundaries (the stop sets may have
        changed: `_beyond`'s cache)."""
        self._clear_s = -INF
        if stops:
            self._beyond_key = None

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
        w = self.seg + self.look_ahead
        return w if w < self.n else self.n

    # -- constraints ----------------------------------------------------------------------------
    def limits(self, seg: int) -> tuple[float, float]:
        tb = self.tb
        r = tb.run[seg if seg < tb.n else tb.n - 1]
        return tb.run_a[r], tb.run_j[r]

    @staticmethod
    def horizon(v: float, a: float, a_max: float, j_max: float, dt: float) -> float:
        """Distance beyond which no constraint can bind within the next step."""
        stop = 0.0
        if projected_velocity(v, a, j_max) > 0.0:
            stop = brake_reach(v, a, a_max, j_max)
        return stop + 2.0 * dt * (v + a_max * dt) + 1e-9

    def _ahead(self, b: int, w: int, leap: bool = False, keep: int = -1) -> Iterator[int]:
        """Constraint boundaries from b on (static ones, lift stops, the window end w). With
        `leap`, after a boundary without zero acceleration only those whose cap is below
        `self._low` (the lowest the caller kept, which it sets before asking for the next), the
        run boundaries, lift stops, `keep` and w: the first constraint below a cap lies on the
        chain of lower feeds or of lower hard caps from the last one kept (`PathTable`
        `lower_feed`, `lower_hard`), so a run of feed drops that cannot bind costs nothing."""
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
            if nxt != k:
                continue
            if k + 1 > n:
                nxt = n + 1
            elif leap and not tb.gate[k]:
                low = self._low
                ov = self.ov
                nxt = min(tb.next_gate[k + 1], w)  # within the window (a review: past it)
                f = k
                while f < nxt and tb.feed[f] * ov >= low:
                    f = tb.lower_feed[f]
                h = k
                while h < nxt and min(tb.point_cap[h], tb.cap[h]) >= low:
                    h = tb.lower_hard[h]
                nxt = min(nxt, f, h)
                if k < keep < nxt:
                    nxt = keep
            else:
                nxt = tb.next_constraint[k + 1]

    def own_cap(self, b: int) -> float:
        """Boundary b's own cap: its entry cap, and where the block before it lies ahead of
        the path's, that block's ceiling. The feed drop where that block begins keeps it,
        unless the path passes that one above it after an override drop (a block of 16 mm/s
        entered at 37 mm/s: the run boundary at its end, read by its entry cap of 100 and the
        chain after it, 37.9, was passed at 22.9 mm/s, an overrun; a cold review's program,
        `drop_scenario(1735)`)."""
        cap = self.tb.entry_cap(b, self.ov)
        if b - 1 > self.seg:
            cap = min(cap, self.tb.ceiling(b - 1, self.ov))
        return cap

    def _cap(self, b: int, w: int) -> tuple[float, bool, bool]:
        """(cap, zero acceleration required, stop) of constraint boundary b (`own_cap`)."""
        if b == w or self.is_stop(b):
            return 0.0, True, True
        return self.own_cap(b), self.tb.gate[b], False

    def collect(
        self, s: float, seg: int, reach: float, soft: tuple[int, int] = (0, 0), keep: int = -1,
        first: int = -1, every: bool = False,
    ) -> list[tuple[int, float, float, bool]]:  # fmt: skip
        """Constraints within `reach` of (s, seg), from boundary `first` on (the next one by
        default), up to and including the first run boundary or stop: (boundary, position,
        cap, zero acceleration required). The run boundary's cap is lowered so that everything
        after it stays reachable (`_beyond`): the constraints after it are not in the list. The
        others keep their own caps, and every one up to the run boundary that can bind is in
        the list and checked by itself.

        One that cannot bind is left out: a constraint without zero acceleration (a feed drop,
        a transition cap inside a run) whose cap is at least that of one before it in the
        list. A path that keeps that one passes it with its projected velocity (`need`) at
        most that cap, so it keeps this one however near, and it is in the list from there on
        (not by slack: the brake to a higher cap with zero acceleration at its end can be the
        longer, 21.00 against 20.72 mm to 100 and 10 mm/s from 500 mm/s, a review found); the
        chain of `target_cap` leaves it reachable for the same reason. Without this, 0.2 mm
        blocks with a feed drop at every second one put 24 constraints within 9.6 mm and the
        24th counted as a stop
        (known deviation 1 of docs/geo-core.md: 314 for 500 mm/s). The caps compared are the
        ones the check uses: a plan passes the feed caps of boundaries soft[0] … soft[1] − 1
        above them (`Plan.soft_from`), keeping only their hard caps. `keep` is never left out
        (a forced re-plan's constraint, found from the step's end, where the one that would
        keep it is behind). `every`: none left out and no cut (at most the look-ahead window's
        constraints: what the leaps of `_ahead` are checked against)."""
        tb = self.tb
        n = tb.n
        out: list[tuple[int, float, float, bool]] = []
        if seg >= n:
            return out
        w = min(seg + self.look_ahead, n)
        limit = s + reach
        low = INF  # the lowest cap (as checked) in the list so far
        leap = not every and soft[0] >= soft[1]
        self._low = INF
        for b in self._ahead(seg + 1 if first < 0 else first, w, leap, keep):
            s_b = tb.s[b]
            if s_b > limit:
                break
            cap, gate, stop = self._cap(b, w)
            if not gate and not every:
                used = min(tb.point_cap[b], tb.cap[b]) if soft[0] <= b < soft[1] else cap
                if used >= low and b != keep:
                    continue  # kept by one before it
                low = min(low, used)
                self._low = low
            if len(out) == MAX_CANDIDATES - 1 and not every and not gate:
                # the last: zero acceleration there, below what the constraints after it
                # allow (`_beyond`, as behind a run boundary); it counted as a stop, and a
                # feed falling block by block held the path 5-15 % below the rules (known
                # deviation 1 of docs/geo-core.md)
                gate = True
                if soft[0] <= b < soft[1]:
                    cap = min(tb.point_cap[b], tb.cap[b])
            if gate and not stop and cap > 0.0:
                cap = min(cap, self._beyond(b, cap, w))
            out.append((b, s_b, cap, gate))
            if gate:
                if b == w and stop and not self.is_stop(b):
                    floor = self.window_floor(w)
                    if floor > 0.0:
                        out.append((b, s_b, floor, True))
                break
        return out

    def window_floor(self, w: int) -> float:
        """The lowest cap the window's end w can have once the window moves on by a block: its
        own entry cap, or what rest at the boundary after it leaves over block w (known
        deviation 3 of docs/geo-core.md). The path keeps both rest and this velocity reachable
        at w (a second candidate at w in `collect`; `Constraints.window_end_lost`): with a jerk
        limit, braking to a low velocity takes longer than braking to rest, so a path braking
        to rest at w may no longer get down to w's cap exactly when the window moves on, and
        brakes to near rest instead (wide seed 22: 0.2 mm blocks, look-ahead 3, boundaries of
        7.3 mm/s passed at 0.005). 0 where the window is a single block (the path rests at its
        end) or w is the program's end."""
        tb = self.tb
        if self.look_ahead < 2 or w >= tb.n:
            return 0.0
        key = (w, self.ov, w - 1 > self.seg)
        if self._floor_key == key:  # asked every step while the profile aims at w
            return self._floor_val
        a_max, j_max = self.limits(w)
        after = reach_velocity_any_above(
            0.0, max(tb.s[w + 1] - tb.s[w] - CHAIN_MARGIN, 0.0), a_max, j_max
        )
        self._floor_key = key
        self._floor_val = min(self.own_cap(w), after)
        return self._floor_val

    def hard_reach(self, b: int, w: int) -> float:
        """The highest velocity at run boundary b, with zero acceleration there, from which
        every stop and every hard cap (axis and transition caps, which no override scales)
        after b up to the window's end w stays reachable: a backward pass, zero acceleration
        at the run boundaries and stops, one brake through the hard caps between them (each a
        brake of its own), rest at a stop, and at w (not a stop) the least of its hard cap and
        what rest one block on allows (the window moves on). Feed caps are left out: after an
        override drop the path passes those it can no longer get down to above them. Read
        where the jerk gap's rule would pass b above its cap (`Shift.toward`: x2 above
        this loses what lies after b; a cold review built it with a lift's stop 0.5 mm after
        b, and with a corner of 25 mm/s there)."""
        tb = self.tb
        end = min(w, tb.n)
        if self.is_stop(end):
            v_link = 0.0
        else:
            a_max, j_max = self.limits(end)
            after = reach_velocity_any_above(
                0.0, max(tb.s[end + 1] - tb.s[end] - CHAIN_MARGIN, 0.0), a_max, j_max
            )
            v_link = min(tb.point_cap[end], tb.cap[end], after)
        s_link = tb.s[end]
        lows: list[tuple[float, float]] = []  # hard caps inside the run before the link
        for k in range(end - 1, b, -1):
            s_k = tb.s[k]
            if self.is_stop(k):
                v_link, s_link, lows = 0.0, s_k, []
                continue
            h = min(tb.point_cap[k], tb.cap[k])
            if not tb.gate[k]:
                lows.append((s_k, h))
                continue
            a_max, j_max = self.limits(k)
            v = min(h, reach_velocity(v_link, max(s_link - s_k - CHAIN_MARGIN, 0.0), a_max, j_max))
            for s_h, c in lows:
                v = min(v, reach_velocity(c, max(s_h - s_k - CHAIN_MARGIN, 0.0), a_max, j_max))
            v_link, s_link, lows = v, s_k, []
        s_b = tb.s[b]
        a_max, j_max = self.limits(b)
        v = reach_velocity(v_link, max(s_link - s_b - CHAIN_MARGIN, 0.0), a_max, j_max)
        for s_h, c in lows:
            v = min(v, reach_velocity(c, max(s_h - s_b - CHAIN_MARGIN, 0.0), a_max, j_max))
        return v

    def chain_open(self, cands: list[tuple[int, float, float, bool]]) -> bool:
        """Whether the chain of `cands` ends at the window's end (or its run boundary's chain
        does): its end may rise as the window moves on (`_beyond`)."""
        last = cands[-1][0]
        w = self.window_end
        if last == w:
            return True
        if cands[-1][3] and not self.is_stop(last):
            if cands[-1][2] <= 0.0:
                return True  # rest behind no stop (a cap of 0): a later list may raise it
            # cached: `collect` just asked for it with g's own cap (the result depends on
            # the cap: a review found a chain for cap 0, cached under g, read back for its
            # entry cap, which left out every feed drop behind g: 19 mm/s in a 1 mm/s block)
            self._beyond(last, self.own_cap(last), w)
            return self._beyond_open
        return False

    def _link(self, e: float, s_from: float, b: int, s_b: float, is_open: bool) -> float:
        """The highest velocity at s_from (zero acceleration) from which e at boundary b (at
        s_b) stays reachable: every higher end too where the chain is open."""
        a_max, j_max = self.limits(b - 1)
        length = max(s_b - s_from - CHAIN_MARGIN, 0.0)
        if is_open:
            return reach_velocity_any_above(e, length, a_max, j_max)
        return reach_velocity(e, length, a_max, j_max)

    def target_cap(self, cands: list[tuple[int, float, float, bool]], i: int) -> float:
        """The velocity to plan for at candidate i (zero acceleration there): its cap, lowered
        so that the later candidates in the list stay reachable from it. They lie in one run
        up to its end (the list's last, a run boundary, a stop or the window's end, with the
        window end's floor after it): one brake passes any number of caps inside a run, with
        zero acceleration only at its end, so each later candidate is a brake of its own from
        i (known deviation 8 of docs/geo-core.md: composed link by link, zero acceleration at
        every cap, CAM seed 41 passed boundary 70 at 44.5 for 47.2 mm/s). Braking toward the
        lowest of them from i passes every higher one no later than the brake to that one
        (the same jerk phase first, its ramp out later), so the least over them keeps all."""
        s_i = cands[i][1]
        e = cands[i][2]
        is_open = self.chain_open(cands)
        for k in range(i + 1, len(cands)):
            bk, sk, ck, gate = cands[k]
            # a cap inside the run is its own (no later window raises it): the exact reach; the
            # run's end is lowered for what lies after it, which a later window may raise
            e = min(e, self._link(ck, s_i, bk, sk, is_open and gate))
        return e

    def binding(self, cands: list[tuple[int, float, float, bool]], i: int, e: float) -> int:
        """The first candidate after i whose brake alone from i gives i's target e
        (`target_cap`), -1 where none does (e is i's own cap)."""
        is_open = self.chain_open(cands)
        s_i = cands[i][1]
        for k in range(i + 1, len(cands)):
            bk, sk, ck, gate = cands[k]
            if self._link(ck, s_i, bk, sk, is_open and gate) <= e:
                return k
        return -1

    def extend(
        self, cands: list[tuple[int, float, float, bool]], s: float, a_max: float, j_max: float,
        times: int,
    ) -> list[tuple[int, float, float, bool]]:  # fmt: skip
        """`cands` (collected from position s) and the constraints after its last within the
        brake to rest from that one's cap, again from the new last, at most `times` times:
        until the list ends at a run boundary or a stop, or nothing more is in reach; at most
        MAX_CANDIDATES long (its users' loops are quadratic in it: `Aims.through`)."""
        ext = list(cands)
        for _ in range(times):
            last = ext[-1]
            if last[3] or len(ext) >= MAX_CANDIDATES:
                break
            seen = last[1] - s + brake_distance(last[2], 0.0, 0.0, a_max, j_max)
            more = self.collect(s, self.seg, seen, first=last[0] + 1)
            if not more:
                break
            ext += more[: MAX_CANDIDATES - len(ext)]
        return ext

    def _beyond(self, g: int, cap: float, w: int) -> float:
        """Velocity at run boundary g (zero acceleration) from which every constraint after it
        up to the window end stays reachable. Braking does not compose across run boundaries
        (each one wants zero acceleration), so far constraints matter through the chain of
        links after g (`_chain`). It is followed up to MAX_CANDIDATES links, the last counting
        as a stop; where that stop lowers g's cap, four times as far, then to the window's
        end. (A CAM polyline's rounding kinks are run boundaries, known deviation 0: 0.2 mm
        apart, braking to rest through them takes ~17 mm from 100 mm/s, and the stop at the
        24th link held CAM seeds 0, 30, 38 and 162 5–40 % below their caps.)
        Cached per (g, window end, override, cap; `Tracker.set_state` drops it where the stop
        sets change): a step within one segment asks again."""
        key = (g, w, self.ov, cap)
        if self._beyond_key == key:
            return self._beyond_val
        limit = MAX_CANDIDATES
        while True:
            e, is_open, cut = self._chain(g, cap, w, limit)
            # a cut counts as a stop, the lowest end the links can have (every higher end kept
            # reachable, `reach_velocity_any_above`): where g keeps its cap with it, it keeps it
            # with whatever lies beyond the cut
            if not cut or e >= cap or limit > self.look_ahead:
                break
            limit *= 4
        self._beyond_key, self._beyond_val, self._beyond_open = key, e, is_open
        return e

    def _chain(self, g: int, cap: float, w: int, limit: int) -> tuple[float, bool, bool]:
        """(`_beyond`'s velocity at g, whether the chain is open, whether it was cut) over at
        most `limit` links after g, the last counting as a stop. A constraint without zero
        acceleration that a lower cap before it keeps (g's own cap first) is not a link. The
        links compose as in `target_cap`: from each run boundary (g first), a brake of its
        own to every cap inside its run and to the run's end, at that end's value."""
        tb = self.tb
        chain: list[tuple[float, float, int, bool]] = []
        low = self._low = cap
        cut = False
        for b in self._ahead(g + 1, w, True):  # leaping over those it keeps
            c, gate, stop = self._cap(b, w)
            if not gate and c >= low:
                continue
            low = self._low = min(low, c)
            chain.append((tb.s[b], c, b, gate))
            if stop or len(chain) == limit:
                cut = not stop
                chain[-1] = (tb.s[b], 0.0, b, True)
                break
        # open: the chain ends at the window's end or is cut, not at a stop of the program: its
        # end may rise as the window moves on, and with a jerk limit a higher end velocity is
        # not always reachable from where a lower one is (`reach_velocity_any_above`), so every
        # run's end keeps every higher end reachable (wide seed 146: 162's cap fell from 261.9
        # to 259.8 mm/s as the window moved from 189 to 190; the path, planned for the first,
        # went on above every cap after it and came to near rest at 189 for a corner it could
        # no longer get down to)
        is_open = bool(chain) and not self.is_stop(chain[-1][2])
        end: tuple[float, float, int, bool] | None = None  # the next run's end: (s, value, b, open)
        inside: list[tuple[float, float, int]] = []  # the caps before it, after the next start
        for i in range(len(chain) - 1, -2, -1):
            if i >= 0 and not chain[i][3]:
                inside.append(chain[i][:3])
                continue
            s_start = chain[i][0] if i >= 0 else tb.s[g]
            e = INF
            for s_k, c_k, b_k in inside:  # their own caps: the exact reach
                e = min(e, self._link(c_k, s_start, b_k, s_k, False))
            if end is not None:
                e = min(e, self._link(end[1], s_start, end[2], end[0], end[3]))
            if i < 0:
                return e, is_open, cut
            s_i, c_i, b_i, _ = chain[i]
            # a run's end held at its own cap keeps it however the window moves on: the exact
            # reach to it (wide seed 768: a 0.107 mm/s corner a block on, 69.98 mm/s where
            # every higher end kept reachable gave 66.16)
            own = c_i <= e and i < len(chain) - 1
            end, inside = (s_i, min(c_i, e), b_i, is_open and not own), []
        return INF, is_open, cut  # not reached: the loop returns at i = -1

    @staticmethod
    def need(v: float, a: float, cap: float, gate: bool, a_max: float, j_max: float) -> float:
        """Least distance after which the path can be below `cap` (with zero acceleration where
        `gate`). A cruise ends at v_p = cap up to rounding (3e-17 m/s above it read as a
        violation of the cap, which hid the stop behind it the path could still make: stress
        seed 380, lifting, passed the program end at 99 mm/s)."""
        if projected_velocity(v, a, j_max) > cap + V_ROUND:
            return brake_distance(v, a, cap, a_max, j_max)
        if not gate:
            # below the cap once the acceleration is ramped to 0, but braking through it now:
            # where that ramp crosses the cap (issue 36: 0.45 mm before a kink of 16.5 mm/s at
            # 67 mm/s, braking, the ramp ended below it 0.6 mm on and the path passed the kink
            # at 24 mm/s)
            return ramp_crossing(v, a, cap, j_max) if v > cap + V_ROUND else 0.0
        # zero acceleration there: ramp it to 0 now, or (shorter when already braking hard)
        # brake to rest
        ramp = ramp_distance(v, a, j_max)
        if a < 0.0 and v > 0.0:
            ramp = min(ramp, brake_distance(v, a, 0.0, a_max, j_max))
        return ramp

    def window_end_lost(
        self, goal: int, v_end: float, s: float, v: float, a: float, s1: float, v1: float,
        a1: float, seg1: int,
    ) -> int | None:  # fmt: skip
        """A profile toward `goal`, the window's end, keeps the velocity it targets there
        (`v_end`: rest, or the end's floor, `window_floor`); the other one is kept while it can
        be: the window's end if the step from (s, v, a) to (s1, v1, a1) in segment seg1 would
        lose it, having kept it at the step's start (a forced re-plan then aims at the lower of
        the two slacks; one lost before the step is not asked for again, so the two do not
        take turns)."""
        g = goal
        if g != seg1 + self.look_ahead or g >= self.n or self.is_stop(g):
            return None
        floor = self.window_floor(g)
        if floor <= 0.0:
            return None
        other = 0.0 if v_end > 0.0 else floor
        s_g = self.tb.s[g]
        if not self.stays(s, v, a, self.seg, s_g, other):
            return None  # lost before this step
        return None if self.stays(s1, v1, a1, seg1, s_g, other) else g

    def stays(self, s: float, v: float, a: float, seg: int, s_b: float, e: float) -> bool:
        """From (s, v, a) in segment seg the path can still be at e or below with zero
        acceleration at s_b, with SLACK_MARGIN to spare (with seg's limits)."""
        a_max, j_max = self.limits(seg)
        return s_b - s - self.need(v, a, e, True, a_max, j_max) >= SLACK_MARGIN

    def passable(self, b: int, v: float, a: float, w: int, soft: bool = False) -> bool:
        """Whether the path may reach constraint boundary b at (v, a) (only its hard cap when
        `soft`: a plan passes its feed cap, `Plan.soft_from`)."""
        tb = self.tb
        if not tb.constraint[b] and b != w and b not in self.lift_stops:
            return True
        cap, gate, _ = self._cap(b, w)
        if soft and not gate:
            cap = min(tb.point_cap[b], tb.cap[b])
        if v > cap * (1.0 + CAP_TOL) + 1e-12:
            return False
        if not gate and not soft and a > 0.0 and b < tb.n and not self.hold:
            # crossed accelerating: the acceleration ramps out after b, in the block whose
            # ceiling it is (narrow seed 525: a feed drop to 96.69 mm/s crossed at 49.4 mm/s
            # and 6.17 m/s², ramped out to 96.86; known deviation 11 of docs/geo-core.md)
            top = tb.ceiling(b, self.ov)
            if projected_velocity(v, a, self.limits(b)[1]) > top * (1.0 + CAP_TOL) + 1e-12:
                return False
        return not gate or abs(a) <= GATE_TOL

    def violated(
        self, s: float, v: float, a: float, seg: int, dt: float, goal: int, soft_from: int,
        aim: int = -1,
    ) -> int | None:  # fmt: skip
        """The first constraint that could no longer be kept from (s, v, a), if any (not a feed
        drop between `goal` and a plan's `aim`, `Plan.aim`: the plan's brake state keeps it)."""
        if s <= self._clear_s:
            return None
        if goal >= 0:
            # the profile keeps `goal`; if it is the first constraint ahead and a run boundary,
            # everything after it is kept through its cap (no other constraint to check)
            tb = self.tb
            n = self.n
            nxt = tb.next_constraint[seg + 1] if seg + 1 <= n else n
            w = min(seg + self.look_ahead, n)
            nxt = min(nxt, w)
            if (
                nxt == goal
                and (tb.gate[goal] or goal == w or self.is_stop(goal))
                and not (self.lift_stops and any(seg < k < goal for k in self.lift_stops))
            ):
                return None
        a_max, j_max = self.limits(seg)
        if v == 0.0 and a <= 0.0:
            return None
        cands = self.collect(s, seg, self.horizon(v, a, a_max, j_max, dt), (soft_from, goal))
        if not cands:
            self._clear(s, projected_velocity(v, max(a, 0.0), j_max), seg, a_max, j_max, dt)
            return None
        v_p = projected_velocity(v, a, j_max)
        for b, s_c, c, gate in cands:
            if b == goal:
                continue  # kept by the profile
            # a candidate the plan passes above its feed cap (Plan.soft_from): only its hard cap
            soft = soft_from <= b < goal and not gate
            cap = min(self.tb.point_cap[b], self.tb.cap[b]) if soft else c
            if not gate and v_p <= cap + V_ROUND and v <= cap + V_ROUND:
                # a cap the path is below, and stays below as its acceleration is ramped to 0,
                # cannot bind, however near (as in `_replan`): read as a violation 0.76 µm
                # before a feed change, its forced cruise dropped the target of the stop
                # behind it and made that stop unreachable (seed 1537)
                continue
            if not gate and 0 <= goal < b < aim:
                # a drop between a brake state and its aim (or a point cap there: its cap is
                # the candidate's): the brake after the state passes it below its cap
                # (`Aims._brake_state` checked it, from the state it plans).
                # Read with zero acceleration there, a brake state through an F5182 drop
                # toward a rest chain two blocks on forced re-plans that held the F4295 drop
                # at its cap and braked again after it (boundary 38 at 89.4 for 97.7 mm/s,
                # feeds seed 441). Read so for every drop, by the brake a later cap needs, a
                # profile toward a later goal passed one at 100.01 for 100 mm/s: the forced
                # re-plan that the brake put off came where only the brake at once kept it,
                # and the re-plan reads it with zero acceleration there (feeds seed 48).
                continue
            slack = s_c - s - self.need(v, a, cap, gate, a_max, j_max)
            if slack < SLACK_MARGIN:
                return b
        return None

    def _clear(self, s: float, v: float, seg: int, a_max: float, j_max: float, dt: float) -> None:
        """No constraint within the horizon: up to where none can be, whatever the step (the
        velocity stays below max(v, ceiling) and the acceleration below a_max until the next
        re-plan, which resets this)."""
        tb = self.tb
        n = self.n
        w = min(seg + self.look_ahead, n)
        nxt = w
        if seg + 1 <= n:
            nxt = min(nxt, tb.next_constraint[seg + 1])
        for k in self.lift_stops:
            if seg < k < nxt:
                nxt = k
        top = max(v, 0.0 if self.hold else tb.ceiling(seg if seg < n else n - 1, self.ov))
        self._clear_s = tb.s[nxt] - self.horizon(top, a_max, a_max, j_max, dt)
