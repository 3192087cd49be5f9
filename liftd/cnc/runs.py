"""A channel's program runs: each run's state built before its START, the last one's released
after it.

A run's state is the program prepared for its start position, its `Interpolator` and its
`LiftController`. Building one, and freeing the one it replaces, cost a repeat START 158–205
µs of its cycle on the demo and 475–757 µs on a 500-part job (2026-12-01). `Runs` keeps the
next run of a repeated program built ahead instead: `prepare` builds it with the program,
outside the GEO cycle; after each START `deferred` builds the one after it in the following
cycles, a piece per cycle (the interpolator, the lift controller, the tracker of the lifts'
nominal runs, from the program `PreparedPrograms.prepared` has for where this run ends; it
never decodes), so `take` only swaps it in. What a START replaces goes to `ReleaseBins`, the
parts that grow with the program (lift records, the committed queue, its arrival times) item
by item. None of it changes what a cycle computes: the state built ahead is the one a START
would build (test_repeat.py).
"""

from __future__ import annotations

from collections import deque

from liftd.cnc.geo_program import GeoProgram, PreparedPrograms, load_program
from liftd.cnc.lift.controller import LiftController
from liftd.cnc.params import ChannelParams, LiftMethod
from liftd.cnc.path.geometry import Vec, within
from liftd.cnc.path.interpolator import Interpolator
from liftd.cnc.pause import pause
from liftd.cnc.release import ReleaseBins


class RunState:
    """One run's state before it starts (`lift` None while it is still being built)."""

    __slots__ = ("interp", "lift", "prog", "start")

    def __init__(
        self, start: Vec, prog: GeoProgram, interp: Interpolator, lift: LiftController | None
    ) -> None:
        self.start = start
        self.prog = prog
        self.interp = interp
        self.lift = lift


class Runs:
    """The runs of one channel's program (see the module docstring)."""

    def __init__(
        self, channel: ChannelParams, programs: PreparedPrograms, leads: dict[str, int]
    ) -> None:
        self.ch = channel
        self.programs = programs
        self.leads = leads  # committed look-ahead per axis that may lift
        self.repeats = False  # `prepare` was asked: keep the next run built
        self.ahead: RunState | None = None  # the next run, built
        self._building: RunState | None = None
        self._built_for = -1  # the run (GeoTask.runs) whose next run was built or looked for
        self.released = ReleaseBins()

    @property
    def ready(self) -> bool:
        ahead = self.ahead
        return ahead is not None and ahead.lift is not None

    def build(self, start: Vec) -> RunState:
        """A whole run from `start` (decodes unless a program is prepared for it)."""
        prog = self.programs.from_start(start)
        return RunState(start, prog, self._interpolator(prog), self._lift(prog))

    def build_for(self, start: Vec) -> RunState:
        """A whole run from `start`, decoded and planned from the program text, with pause
        points (pause.py) between its pieces. Touches nothing of this object but what it
        reads (the channel, the leads, the text): the GEO process builds it in a thread off
        the cycle (runtime/preparer.py) and hands it over with `offer`."""
        prog = load_program(self.programs.text, self.ch, start)
        interp = self._interpolator(prog, nominal=False)
        pause()
        if prog.ranges:
            interp.prepare_nominal(prog.nominal)
            pause()
        lift = self._lift(prog)
        pause()
        return RunState(start, prog, interp, lift)

    def offer(self, run: RunState, runs: int) -> None:
        """Take `run` (from `build_for`) as the next run, the one after run `runs`: what was
        built ahead or was being built goes to the release bins. A few assignments: the GEO
        cycle may call it."""
        if self.ahead is not None:
            self.released.put([self.ahead])
        if self._building is not None:
            self.released.put([self._building])
            self._building = None
        self.ahead = run
        self._built_for = runs
        self.programs.keep(run.start, run.prog)

    def prepare(self, end: Vec, run: int) -> None:
        """Build now, outside the cycle, the run from `end`, the one after run `run`."""
        self.repeats = True
        self.ahead = self.build(end)
        self._built_for = run

    def take(self, start: Vec) -> RunState:
        """The state of the run from `start`: the one built ahead, else built now."""
        run, self.ahead = self.ahead, None
        if self._building is not None:
            self.released.put([self._building])
            self._building = None
        if run is None:
            return self.build(start)
        if run.lift is not None and within(run.start, start, PreparedPrograms.SAME_START_M):
            return run
        self.released.put([run])
        return self.build(start)

    def retire(self, interp: Interpolator, lift: LiftController) -> None:
        """Hand a finished run's state to the release bins: what grows with the program item
        by item, then the rest."""
        records, lift.records = lift.records, []
        queue, interp.queue = interp.queue, deque()
        arrivals, interp.arrivals = interp.arrivals, {}
        self.released.put(queue)
        self.released.put(arrivals)
        self.released.put(records)
        self.released.take_from(interp.discarded)  # futures an event discarded, not yet freed
        self.released.put([interp, lift])

    def deferred(self, end: Vec, run: int) -> None:
        """At most one piece of deferred work (never in a START's cycle): release a few
        objects a START replaced, or build a piece of the run after run `run`, which ends at
        `end`; a program not prepared for that start is decoded by the START, as before."""
        if self.released:
            self.released.release()
            return
        if not self.repeats or self._built_for == run:
            return
        b = self._building
        if b is None:
            prog = self.programs.prepared(end)
            if prog is None:
                self._built_for = run  # nothing to build ahead: the START decodes
                return
            self._building = RunState(end, prog, self._interpolator(prog, nominal=False), None)
        elif b.lift is None:
            b.lift = self._lift(b.prog)
        else:
            if b.prog.ranges:
                b.interp.prepare_nominal(b.prog.nominal)
            self.ahead, self._building = b, None
            self._built_for = run

    def _interpolator(self, prog: GeoProgram, nominal: bool = True) -> Interpolator:
        lead = self.leads[self.ch.lift_axis]
        for name in prog.lift_axes:
            lead = max(lead, self.leads[name])
        interp = Interpolator(
            prog.path, prog.table, self.ch.look_ahead_blocks, self.ch.cycle_time, lead
        )
        if nominal and prog.ranges:
            interp.prepare_nominal(prog.nominal)
        return interp

    def _lift(self, prog: GeoProgram) -> LiftController:
        return LiftController(
            self.ch.axes,
            prog.ranges,
            self.ch.cycle_time,
            prog.plans,
            both_flags=self.ch.lift_method is not LiftMethod.LIFTING,
            rises=prog.rises,
            lift_axes=prog.lift_axes,
        )
