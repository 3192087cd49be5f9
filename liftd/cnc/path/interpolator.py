"""The cyclic path interpolator: the path's committed future, produced ahead of the cycle.

A `Tracker` (the *producer*) runs ahead of the GEO cycle with the inputs frozen and leaves one
entry per future cycle in a queue (state and the boundaries reached, with their exact times);
the cycle pops one entry. The producer works a bounded quota per cycle (`fill_per_cycle`
entries) until it is `lead` cycles ahead, so in steady state a cycle costs one tracker step.

* **Exact remaining time.** Where the queue reaches a boundary, its arrival time is exact for
  the inputs as they are: the queue *is* the future (the look-ahead window moves in it as it
  will). Beyond the queue, `arrival` is the tail's time plus a lower bound (`bounds.py`), which
  stays valid whatever the window will learn. With a lead of at least the lift axis's longest
  descent, a lift always decides against an exact time when it matters.
* **Events cost O(1).** An input change (override, feed hold, a stop added or acknowledged,
  the resume after a wait) discards the queue and restarts the producer from the state of the
  current cycle; it takes effect in that very cycle. The cycle of an event makes only its own
  entry (the re-plan is its work); the queue grows again from the next cycle on. Until then,
  times beyond it are lower bounds.
* **Determinism.** The quota counts entries, not seconds, so `liftd run` and `liftd simulate`
  produce the same queue and the same arrival times cycle for cycle.
"""

from __future__ import annotations

from collections import deque

from liftd.cnc.path.bounds import lower_bound_time
from liftd.cnc.path.nominal import NominalRun
from liftd.cnc.path.plan import Crossing, Primed
from liftd.cnc.path.program import PathProgram
from liftd.cnc.path.table import PathTable
from liftd.cnc.path.tracker import Tracker
from liftd.cnc.path.velocity import projected_velocity
from liftd.cnc.release import ReleaseBins

INF = float("inf")

__all__ = ["Crossing", "Interpolator"]


class _Entry:
    """One cycle's state of the committed future (a native class: a NamedTuple's __new__ is a
    Python frame, ~0.3 µs of every cycle)."""

    __slots__ = ("a", "crossings", "k", "parked", "s", "seg", "stopped_at", "t", "v")

    def __init__(
        self,
        k: int,
        t: float,
        s: float,
        v: float,
        a: float,
        seg: int,
        crossings: tuple[Crossing, ...],
        stopped_at: int | None,
        parked: bool,
    ) -> None:
        self.k = k  # cycle index (t = k·dt)
        self.t = t  # time of the state (the cycle's time, or when the path came to rest in it)
        self.s = s
        self.v = v
        self.a = a
        self.seg = seg
        self.crossings = crossings
        self.stopped_at = stopped_at
        self.parked = parked


class Interpolator(NominalRun):
    """Path state over one path program (see the module docstring)."""

    def __init__(
        self,
        program: PathProgram,
        table: PathTable,
        look_ahead: int,
        dt: float,
        lead: int = 300,
        fill_per_cycle: int = 4,
    ) -> None:
        self.program = program
        self.table = table
        self.dt = dt
        self.lead = max(1, lead)
        self.fill_per_cycle = max(1, fill_per_cycle)
        self.lift_stops: set[int] = set()
        self.acked_conditional: set[int] = set()
        self.prod = Tracker(table, look_ahead, self.lift_stops, self.acked_conditional)
        self.queue: deque[_Entry] = deque()
        self.arrivals: dict[int, float] = {}
        self.discarded = ReleaseBins()  # what events discard, freed over the next cycles
        self.k_next = 1  # cycle index of the next entry the producer makes
        self._fresh = False  # restarted since the last cycle: it fills no more than its own
        self._quiet = True  # no restart since the last `advance`: it may free discarded items
        # the state of the current cycle
        self.t_state = 0.0
        self.s = table.s[0] if table.s else 0.0
        self.v = 0.0
        self.a = 0.0
        self.segment = 0
        self.stopped_at: int | None = 0
        self.parked = False
        self.override = 1.0
        self.hold = False
        self._init_nominal(table)
        # the last lower bound `arrival` computed and its inputs (boundary, producer state,
        # override): the lift asks for the same one twice when nothing moved in between
        self._bound_key: tuple[int, float, float, float, float, int, float] | None = None
        self._bound = INF
        self.restarts = 0  # committed futures discarded (events)
        # (boundary, restarts) of the last lower bound: it stays a lower bound while the
        # future it was computed on stands (`arrival_bound`)
        self._loose_key = (-1, -1)
        # the profile the path will leave the stop it rests at with (`prime_leaving`), and
        # (restarts, acks) when it was made: it holds while neither changed
        self._leaving: Primed | None = None
        self._leaving_key = (-1, -1)
        self._acks = 0  # conditional M functions acknowledged (one changes the stop set)

    # -- errors of the producer (never expected; counted for the summary and events) ----------
    @property
    def plan_errors(self) -> int:
        return self.prod.errors

    @property
    def last_plan_error(self) -> str:
        return self.prod.last_error

    # -- events ---------------------------------------------------------------------------------
    def _restart(self) -> None:
        """Discard the committed future; the producer goes on from the current state."""
        self.restarts += 1
        self.discarded.put(self.queue)  # released over the next cycles, not now
        self.discarded.put(self.arrivals)
        self.queue = deque()
        self.arrivals = {}
        self.parked = self.parked and self.hold
        p = self.prod
        if p.plan is not None:  # its profile freed later too (~10 µs of the event's cycle cold)
            self.discarded.put([p.plan])
        p.set_inputs(self.override, self.hold)
        p.set_state(self.t_state, self.s, self.v, self.a, self.segment, self.stopped_at)
        self.k_next = int(self.t_state / self.dt + 1e-6) + 1
        self._fresh = True
        self._quiet = False
        self._event = True  # (`nominal_step`)

    def start(self, t: float) -> None:
        """The program starts: at rest at boundary 0 from time t (its actions run first)."""
        self.t_state = t
        self.stopped_at = 0
        self._restart()

    def set_inputs(self, override: float, hold: bool) -> None:
        """Override (fraction) and feed hold from the time of the current state on."""
        if override == self.override and hold == self.hold:
            return
        self.override, self.hold = override, hold
        self._restart()

    def add_lift_stop(self, k: int) -> None:
        """The path must wait at boundary k for the lift axis."""
        if k not in self.lift_stops:
            self.lift_stops.add(k)
            self._restart()

    def drop_lift_stop(self, k: int) -> None:
        if k in self.lift_stops:
            self.lift_stops.discard(k)
            if self.stopped_at != k:
                self._restart()

    def acknowledge_conditional(self, boundary: int) -> None:
        """An MVS_SNS M function was acknowledged before the path got there: no stop."""
        if boundary not in self.acked_conditional:
            self.acked_conditional.add(boundary)
            self._acks += 1
            if self.stopped_at is None and boundary > self.segment:
                self._restart()

    def resume(self, t: float) -> None:
        """Leave the boundary where the path rests (its actions are done) at time t."""
        primed = self._leaving if self._leaving_key == (self.restarts, self._acks) else None
        self._leaving = None
        self.stopped_at = None
        self.parked = False
        self.t_state = t
        self._restart()
        self.prod.resume(t)
        if primed is not None:
            self.prod.take_leaving(primed)

    def prime_leaving(self) -> None:
        """While the path rests at a stop: choose the profile it will leave it with now, in a
        quiet cycle of the wait, not in the cycle of the resume (an M acknowledge's cycle,
        the end of a dwell), and read its pieces (`Evaluator.prepare`: the resume's first
        state is then native too; through the binding it was 16 % of that cycle cold). Done
        once per wait; an event in between (a restart, a conditional M acknowledged) makes
        the resume plan as before. The choice does not depend on when the path leaves
        (`Tracker.plan_leaving`): the same run either way."""
        key = (self.restarts, self._acks)
        if self.stopped_at is None or self._leaving_key == key:
            return
        self._leaving_key = key
        p = self.prod
        primed = p.plan_leaving(self.dt) if p.stopped_at == self.stopped_at else None
        if primed is not None:
            primed.plan.ev.prepare()
        self._leaving = primed

    # -- cycle ----------------------------------------------------------------------------------
    def _produce(self) -> bool:
        """One more entry; False when the producer rests (a stop or a hold)."""
        p = self.prod
        resting: int | None = p.stopped_at  # a local: `advance` changes p.stopped_at
        if resting is not None or (p.parked and self.queue):
            return False  # resting: the last entry stands for every later cycle
        k = self.k_next
        crossings = p.advance(k * self.dt, self.dt)
        for c in crossings:
            self.arrivals[c.boundary] = c.t
        self.queue.append(
            _Entry(k, p.t, p.s, p.v, p.a, p.seg, tuple(crossings), p.stopped_at, p.parked)
        )
        self.k_next = k + 1
        return True

    def advance(self, t: float) -> list[Crossing]:
        """Move to the cycle at time t (a multiple of dt); the boundaries reached since the last
        call, with their exact times."""
        k = round(t / self.dt)
        if self._quiet:  # an event's cycle frees nothing: its re-plan is its work
            self.discarded.release()
        self._quiet = True  # (`_fresh` stays set while the path rests: not a cycle's flag)
        if self.stopped_at is not None:
            return []
        if self.parked and not self.queue:
            self.t_state = t  # holding at rest
            return []
        while not self.queue or self.queue[0].k < k:
            if self.queue:
                self._consume(self.queue.popleft())
                continue
            if self.k_next > k or not self._produce():
                break
        out: list[Crossing] = []
        if self.queue and self.queue[0].k == k:
            e = self.queue.popleft()
            out.extend(e.crossings)
            self._consume(e)
        if self._fresh:
            self._fresh = False  # the event's re-plan was this cycle's work
        else:
            self.fill()
        return out

    def _consume(self, e: _Entry) -> None:
        self.t_state, self.s, self.v, self.a = e.t, e.s, e.v, e.a
        self.segment = e.seg
        self.stopped_at = e.stopped_at
        self.parked = e.parked
        for c in e.crossings:
            if self.arrivals.get(c.boundary) == c.t:
                del self.arrivals[c.boundary]
            if self._virtual and c.boundary >= self._shadow_target >= 0:
                self.nominal_arrival = c.t  # the nominal run is the path: it arrives with it
                self._virtual = False

    def fill(self, quota: int | None = None) -> None:
        """Produce ahead: at most `quota` (default `fill_per_cycle`) entries, up to the lead."""
        budget = self.fill_per_cycle if quota is None else quota
        while budget > 0 and len(self.queue) < self.lead and self._produce():
            budget -= 1

    def crossing_within(self, k: int, cycles: int) -> tuple[int, Crossing] | None:
        """The committed crossing of boundary k when one of the next `cycles` cycles reports it,
        with that cycle's index (bounded: looks at `cycles` entries of the queue)."""
        q = self.queue
        for j in range(min(cycles, len(q))):
            e = q[j]
            for c in e.crossings:
                if c.boundary == k:
                    return e.k, c
        return None

    # -- queries ---------------------------------------------------------------------------------
    def arrival(self, k: int) -> float:
        """Absolute time the path reaches boundary k with the inputs as they are: exact where the
        committed queue reaches it, else a lower bound; inf while it holds or waits before k."""
        if self.stopped_at is not None:
            return self.t_state if self.stopped_at == k else INF
        if k <= self.segment:
            return self.t_state
        t = self.arrivals.get(k)
        if t is not None:
            return t
        p = self.prod
        if (p.stopped_at is not None and p.stopped_at < k) or p.parked:
            return INF  # the path rests before k (a wait, or a hold that stops short of it)
        if self.hold or self.override <= 0.0:
            # braking for a hold, or override 0 which acts as one (the velocity only falls) and
            # not yet at rest: it may still pass k (wide seed 890: the path passed LIFT_END
            # braking for override 0 while Z, told "never", rose)
            tb = self.table
            gap = tb.s[min(k, tb.n)] - p.s
            j_max = tb.run_j[tb.run[min(p.seg, tb.n - 1)]]
            top = projected_velocity(p.v, max(p.a, 0.0), j_max)
            return p.t + gap / top if top > 0.0 else INF
        key = (k, p.t, p.s, p.v, p.a, p.seg, self.override)
        if key != self._bound_key:  # asked again in the next cycle's override rule: keep it
            self._bound_key = key
            self._bound = p.t + lower_bound_time(self.table, p.s, p.v, p.seg, k, self.override, p.a)
            self._loose_key = (k, self.restarts)
        return self._bound

    def arrival_bound(self, k: int) -> float:
        """A lower bound of `arrival(k)` that may be looser but costs nothing when the last
        one is still good: a lower bound computed from an earlier state of the producer stays
        one as long as the committed future it started from stands (no restart since), and it
        is never above the one computed now (the path from that state to this one is a
        feasible motion of the same relaxation). Exact times are returned as `arrival`."""
        if (
            self.stopped_at is None
            and k > self.segment
            and k not in self.arrivals
            and self._loose_key == (k, self.restarts)
        ):
            return self._bound
        return self.arrival(k)

    def exact(self, k: int) -> bool:
        """Whether `arrival(k)` is the committed (exact) time."""
        return k in self.arrivals or self.stopped_at == k

    def lower_bound(self, k: int, override: float) -> float:
        """Absolute time before which the path cannot reach boundary k from the current state
        if the override were `override` from now on (lift override rules)."""
        if self.stopped_at is not None and self.stopped_at == k:
            return self.t_state
        return self.t_state + lower_bound_time(
            self.table, self.s, self.v, self.segment, k, override, self.a
        )

    def position(self) -> tuple[float, ...]:
        """Command positions of all axes at the current path position."""
        segs = self.program.segments
        if not segs:
            return self.program.start_position
        if self.segment >= len(segs):
            return self.program.end_position
        seg = segs[self.segment]
        return seg.geom.position(min(max(self.s - seg.s0, 0.0), seg.length))
