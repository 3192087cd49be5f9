"""The nominal run of a lift range (path_delay_s): the same path without any lift's limits,
under the override the PLC requests, waits at stops counting as zero. `NominalRun` is the
base of `Interpolator` (`interpolator.py`), whose state it reads: it changes with how the
path delay is measured, the interpolator with how the path moves (docs/geo-core.md,
"The lift")."""

from __future__ import annotations

from liftd.cnc.path.table import PathTable
from liftd.cnc.path.tracker import Tracker


class _Due:
    """A step of the nominal run left to the next cycle (`Interpolator.nominal_step`)."""

    __slots__ = ("hold", "override", "t")

    def __init__(self, t: float, override: float, hold: bool) -> None:
        self.t = t
        self.override = override
        self.hold = hold


class NominalRun:
    """The nominal run of the current lift range, on the interpolator's state."""

    dt: float
    prod: Tracker
    acked_conditional: set[int]
    lift_stops: set[int]
    override: float
    hold: bool
    t_state: float
    s: float
    v: float
    a: float
    segment: int
    stopped_at: int | None

    def _init_nominal(self, table: PathTable) -> None:
        self._shadow: Tracker | None = None
        self._shadow_target = -1
        self._shadow_table = table
        self._virtual = False  # the nominal run is the path itself (not parted yet)
        self.nominal_arrival: float | None = None
        self.nominal_override = 1.0
        self._event = False  # a restart since the last `nominal_step` (`Interpolator._restart`)
        # False: the nominal run steps in an event's cycle too (the same run: tests compare)
        self.nominal_later = True
        self._nominal_due: _Due | None = None  # its step an event's cycle left to the next

    def prepare_nominal(self, table: PathTable) -> None:
        """Build the nominal run's tracker now, outside the GEO cycle: built where a lift's
        start (or the path's parting from its nominal run) first needed it, it cost up to
        80 µs of that cycle with cold caches (bench_step.py --cold)."""
        self._shadow_table = table
        sh = self._shadow
        if sh is None or sh.tb is not table:
            self._shadow = Tracker(table, self.prod.look_ahead, set(), self.acked_conditional)

    def nominal_start(
        self,
        table: PathTable,
        target: int,
        t: float,
        s: float,
        v: float,
        a: float,
        seg: int,
        differs: bool = True,
    ) -> None:
        """Start the nominal run toward boundary `target` from the given state (the path
        leaving the range's start). Unless the lifts' limits change the path (`differs`), it
        is the path itself until they part (`nominal_step`): no second tracker meanwhile."""
        self.nominal_flush()
        self._shadow_target = target
        self._shadow_table = table
        self.nominal_arrival = t if seg >= target else None
        self._virtual = not differs
        if differs:
            self._shadow_from(t, s, v, a, seg)

    def _shadow_from(self, t: float, s: float, v: float, a: float, seg: int) -> None:
        sh = self._shadow
        table = self._shadow_table
        if sh is None or sh.tb is not table:
            sh = self._shadow = Tracker(table, self.prod.look_ahead, set(), self.acked_conditional)
        sh.set_inputs(self.nominal_override, self.hold)
        sh.set_state(t, s, v, a, seg, None)

    def _parts(self, override: float) -> bool:
        """Whether the path leaves its nominal run from this cycle on: the lift limits the
        override, makes the path stop for Z, or the path waits inside the range (the nominal
        run goes on at once)."""
        if override != self.override:
            return True
        target = self._shadow_target
        if any(self.segment < k <= target for k in self.lift_stops):
            return True
        return self.stopped_at is not None and self.stopped_at < target

    def nominal_step(self, t: float, override: float, hold: bool) -> None:
        """Advance the nominal run to t with the requested override and feed hold. In the
        cycle of an event (a restart: the path's re-plan is its work) the nominal run's step,
        often its own re-plan (40 % of such an override write's cycle cold), is left to the
        next cycle: the same calls in the same order, one cycle later (`nominal_flush`)."""
        self.nominal_flush()
        event, self._event = self._event, False
        self.nominal_override = override
        if self.nominal_arrival is not None or self._shadow_target < 0:
            return
        if self._virtual:
            if not self._parts(override):
                return  # it arrives when the path does (`_consume`)
            self._virtual = False
            self._shadow_from(self.t_state, self.s, self.v, self.a, self.segment)
        if self._shadow is None:
            return
        if event and self.nominal_later:
            self._nominal_due = _Due(t, override, hold)
            return
        self._nominal_advance(t, override, hold)

    def nominal_flush(self) -> None:
        """Make the nominal run's step an event's cycle left (`nominal_step`), before anything
        else touches or reads the nominal run."""
        due = self._nominal_due
        if due is not None:
            self._nominal_due = None
            self._nominal_advance(due.t, due.override, due.hold)

    def _nominal_advance(self, t: float, override: float, hold: bool) -> None:
        sh = self._shadow
        if sh is None:
            return
        sh.set_inputs(override, hold)
        for _ in range(1000):  # bounded: every pass ends at t or at a stop it passes at once
            for c in sh.advance(t, self.dt):
                if c.boundary >= self._shadow_target:
                    self.nominal_arrival = c.t
                    return
            if sh.stopped_at is None or sh.stopped_at >= sh.tb.n:
                return
            sh.resume(sh.t)  # waits do not count in the nominal run

    def nominal_stop(self) -> None:
        self.nominal_flush()
        self._shadow_target = -1
        self.nominal_arrival = None
        self._virtual = False
