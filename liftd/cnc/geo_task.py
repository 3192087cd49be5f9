"""GeoTask.step(inputs, t) -> GeoSnapshot: one GEO cycle of the emulated CNC channel.

Pure and deterministic: time is passed in, nothing is read from a clock, nothing is logged; the
same inputs give bit-identical snapshots. Order within a cycle:

1. PLC inputs (command, M acknowledge, override, feed hold) take effect from the time of the
   last state; Advanced Lifting may limit the override first;
2. the path moves to t; the actions of every boundary it passes run at that boundary's exact
   time; where the path rests, waiting actions (M acknowledge, dwell, M00, Z not yet at POS)
   hold it, and it resumes at the exact time the wait ended;
3. the lift axis moves to t: against the absolute time the path reaches its horizon
   (time-based), or to the path position (path-based Lifting, coupled);
4. the lift axis acceleration monitor samples Z; the snapshot is published.
"""

from __future__ import annotations

from typing import Final

from liftd.cnc import events
from liftd.cnc.actions import BoundaryActions
from liftd.cnc.channel_state import ChannelStateMachine
from liftd.cnc.events import EventLog
from liftd.cnc.geo_program import GeoProgram, PreparedPrograms, same_start
from liftd.cnc.lift.controller import LiftController
from liftd.cnc.lift.monitor import AccelMonitor
from liftd.cnc.lift.profile import LiftProfiles, ProfileError
from liftd.cnc.lift_ahead import LiftAhead
from liftd.cnc.nc.blocks import ErrorId
from liftd.cnc.params import ChannelParams
from liftd.cnc.path.interpolator import Interpolator
from liftd.cnc.path.program import PathProgram
from liftd.cnc.plc import MAX_OVERRIDE, clamp_override
from liftd.cnc.runs import Runs, RunState
from liftd.cnc.snapshot import (
    ChannelState,
    Command,
    GeoInputs,
    GeoSnapshot,
    LiftPhase,
    new_snapshot,
)

LIFT_LATE_ID = int(ErrorId.LIFT_LATE)  # the path passed LIFT_END with Z not at POS

# Enum members as C statics of the compiled module: `ChannelState.ACTIVE` is a dict and a type
# lookup each time (~80 ns), about ten a cycle.
READY: Final = ChannelState.READY
ACTIVE: Final = ChannelState.ACTIVE
HOLD: Final = ChannelState.HOLD
ERROR: Final = ChannelState.ERROR
NO_PHASE: Final = LiftPhase.NONE
HOLD_LIMIT: Final = LiftPhase.HOLD_LIMIT
NO_COMMAND: Final = Command.NONE


class GeoTask:
    """One CNC channel's GEO task running one NC program. It holds its parts: the channel's
    state machine (`channel`), the actions at the path's boundaries (`actions`), what the lift
    sees ahead (`ahead`), the runs of the program (`next_runs`) and the run loaded: its
    program (`prog`), its interpolator with the nominal run (`interp`) and its lift (`lift`)."""

    def __init__(
        self,
        channel: ChannelParams,
        program_text: str,
        *,
        autostart: bool = True,
        start_position: tuple[float, ...] | None = None,
    ) -> None:
        self.ch = channel
        self.dt = channel.cycle_time  # read every cycle: a native attribute
        self.autostart = autostart
        self.z_index = channel.lift_axis_index
        self.home = start_position or tuple(0.0 for _ in channel.axes)
        self.log = EventLog()
        self.channel = ChannelStateMachine(self.log)
        self.cycle = 0
        self.t_cycle = 0.0
        self.ov_eff = 1.0
        self.ov_req = 1.0
        self.ov_max = MAX_OVERRIDE
        self.was_holding = False
        # the run loaded (`_load`)
        self.prog: GeoProgram
        self.path: PathProgram  # self.prog.path
        self.interp: Interpolator
        self.lift: LiftController
        # the IPO acceleration monitor of every axis that lifts (the configured lift axis and
        # any other a program lifts); `z_monitor` is the configured one's, for the summary
        self.monitors: dict[int, AccelMonitor] = {}
        # axis name → index, for a START's lift axes (`ChannelParams.axis_names` is a property
        # of an interpreted class that builds a tuple: ~23 % of a repeat START's cycle, perf)
        self.axis_of = {name: k for k, name in enumerate(channel.axis_names)}
        self.ahead = LiftAhead(channel.cycle_time)
        self.actions = BoundaryActions(
            self.channel, self.log, self.ahead, self.axis_of, channel.cycle_time
        )
        self.z_monitor = self._monitor_of(self.z_index)
        self.programs = PreparedPrograms(program_text, channel)
        # committed look-ahead per axis that may lift (computed here, outside the cycle)
        self.leads = {name: lead_cycles(channel, name) for name in channel.axis_names}
        # the run after this one, built ahead for a repeat START (runs.py)
        self.next_runs = Runs(channel, self.programs, self.leads)
        self._started = False  # a START in this cycle: no deferred work in it
        self._loaded = False
        self._load(self.home)

    # -- program control ---------------------------------------------------------------------------
    def prepare_next_run(self) -> None:
        """Prepare now (outside the GEO cycle, e.g. before the loop starts) the program for a
        run from where this one ends, and that run's state, so that a repeat START costs no
        decoding and no building in its cycle; from then on, the run after each START is
        built in the cycles after it, a piece per cycle (`Runs.deferred`)."""
        # before the first START: the run after run 1
        self.next_runs.prepare(self.prog.path.end_position, max(self.channel.runs, 1))

    def wants_run(self) -> tuple[float, ...] | None:
        """Where a START now would load the program from, when the run from there is not
        built yet: the channel READY after a run (a RESET, an NC error's RESET, the end of
        a program not repeated) with nothing built ahead for where its axes are; None
        otherwise. The GEO process builds that run off the cycle (`build_run`, in a
        thread) and hands it over (`offer_run`) before it lets the START through, so that
        a START after a RESET costs its cycle what a repeat START does."""
        ch = self.channel
        if ch.state is not READY or not ch.runs or ch.reset_requested:
            return None
        pos = self._positions()
        ahead = self.next_runs.ahead
        if ahead is not None and ahead.lift is not None and same_start(ahead.start, pos):
            return None
        return pos

    def build_run(self, start: tuple[float, ...]) -> RunState:
        """The run from `start` (see `wants_run`); reads only what does not change."""
        return self.next_runs.build_for(start)

    def offer_run(self, run: RunState) -> None:
        """The run `build_run` built, for the next START (cheap: a GEO cycle may call it)."""
        self.next_runs.offer(run, self.channel.runs)

    @property
    def state(self) -> ChannelState:
        return self.channel.state

    @property
    def runs(self) -> int:
        """Runs started (a START after the first loads the next one)."""
        return self.channel.runs

    @property
    def ready_after_reset(self) -> bool:
        """READY since a RESET completed, and no START since (the GEO loop's reload keeps
        it READY whatever its autostart)."""
        return self.channel.ready_after_reset

    @property
    def next_run_ready(self) -> bool:
        """Whether the state of a repeat run is built (a START from where this run ends
        only swaps it in)."""
        return self.next_runs.ready

    def _load(self, start: tuple[float, ...]) -> None:
        run = self.next_runs.take(start)
        if self._loaded:  # released over the next cycles, not in this one
            self.next_runs.retire(self.interp, self.lift)
        self._loaded = True
        self.prog = run.prog
        self.path = run.prog.path  # read every cycle: a native attribute, not GeoProgram's
        self.interp = run.interp
        lift = run.lift
        assert lift is not None
        self.lift = lift
        for name in run.prog.lift_axes:
            self._monitor_of(self.axis_of[name])
        self.channel.new_run()
        self.actions.load(run.prog, run.interp, lift)
        self.ahead.load(run.prog, run.interp, lift)

    # -- helpers ----------------------------------------------------------------------------------
    def _positions(self) -> tuple[float, ...]:
        """Command positions: the path's, Z from the lift while a lift runs. Where the path rests
        on a boundary, it is where the path arrived (the end of the block before), not the start
        of the next block: the decoder puts a lift's POS there, which Z reaches only through the
        lift (a range without path motion after a wait made Z jump, issue 15)."""
        k = self.interp.stopped_at
        segs = self.path.segments
        if k is not None and 0 < k <= len(segs):
            pos = segs[k - 1].geom.end
            z_rest = self.actions.z_rest
            if z_rest is not None:
                z, value = z_rest
                pos = (*pos[:z], value, *pos[z + 1 :])
        else:
            pos = self.interp.position()
        if self.lift.current is not None:
            z = self.lift.axis_index
            pos = (*pos[:z], self.lift.z, *pos[z + 1 :])
        elif self.actions.z_hold is not None:  # a RESET inside a range left Z there
            z, value = self.actions.z_hold
            pos = (*pos[:z], value, *pos[z + 1 :])
        return pos

    # -- override -------------------------------------------------------------------------------
    def _limit_override(self, ov_req: float, holding: bool) -> float:
        """The lift's override rule (Advanced Lifting: vendor §2.5; path-based: none)."""
        self.ov_max = MAX_OVERRIDE
        m = self.lift.motion
        if m is None or holding:
            return ov_req
        k = self.ahead.horizon()
        verdict = m.limit_override(ov_req, self.ov_eff, self.was_holding, k, self.interp)
        self.ov_max = verdict.override_max
        t0 = self.interp.t_state
        if verdict.path_waits:
            self.interp.add_lift_stop(k)
            self.log.emit(events.LIFT_PATH_WAITS, t0, self.line, float(k))
        elif verdict.limited and verdict.override != self.ov_eff:  # a new grant, not each cycle
            self.log.emit(events.LIFT_OVERRIDE_LIMITED, t0, self.line, verdict.override)
        return verdict.override

    # -- cycle ------------------------------------------------------------------------------------
    def step(self, inputs: GeoInputs, t: float) -> GeoSnapshot:
        """Advance the channel to absolute time t (a multiple of the cycle time)."""
        positions = self.advance(inputs, t)
        snap = self.snapshot(t, inputs, positions)
        self.after_cycle()
        return snap

    def advance(self, inputs: GeoInputs, t: float) -> tuple[float, ...]:
        """`step` up to its snapshot: the positions; then the caller reads the cycle (`snapshot`,
        or a row: liftd/cnc/batch.py) and calls `after_cycle`."""
        self.cycle += 1
        # inputs take effect at the start of the cycle; a task's first cycle (which may come
        # mid-run, after a reload) starts at the previous cycle's t = (k − 1)·dt, not at 0
        dt = self.dt
        t_in = self.t_cycle if self.cycle > 1 else (round(t / dt) - 1) * dt
        self.t_cycle = t
        log, ch, actions = self.log, self.channel, self.actions
        log.clear()
        if self.autostart and ch.runs == 0:
            self._start(t_in)
        if inputs.command is not NO_COMMAND:
            self._command(inputs.command, t_in)
        if inputs.m_ack and ch.m_pending >= 0:
            number = ch.acknowledge(t_in, self.line)
            # the dict, not GeoProgram.conditional_for: a Python frame in an acknowledge's cycle
            for k in self.prog.conditional.get(number, ()):
                self.interp.acknowledge_conditional(k)
        self.ov_req = clamp_override(inputs.override)
        holding = ch.holding(inputs.feed_hold)
        self.ov_eff = actions.ov_eff = self._limit_override(self.ov_req, holding)
        self.was_holding = holding
        self.interp.set_inputs(self.ov_eff, holding)
        self.interp.nominal_step(t, self.ov_req, holding)
        if ch.state is ACTIVE:
            self._run_path(t)
        elif ch.state is HOLD and self.interp.stopped_at is None:
            # a PLC STOP holds the path at rest mid-block: its time goes on, as in a feed
            # hold, so that START leaves from here and now (a path left at the stop's time
            # jumped on START to where it would have been without the stop, further the
            # longer it was held), and a lift's remaining time is measured from now
            self.interp.advance(t)
        m = self.lift.motion
        if m is not None:
            ip = self.interp
            t_rem, refine = 0.0, None
            if m.uses_time and self.lift.ending:
                # past LIFT_END, Z within 1 µm of POS on what is left of its descent: it
                # follows that descent to its end (the path resting at a later boundary read
                # as unknown time would have made it rise again; a review found)
                t_rem = m.needed_time()
            elif m.uses_time:
                t_rem, refine = self.ahead.lift_time(t, m.t, self.ov_eff)
            self.lift.step(t, ip.s, ip.v, ip.a, t_rem, self.ov_eff, refine)
            for finding in self.lift.findings:
                log.emit(finding.name, t, self.line, finding.value)
            self.lift.findings.clear()
            if self.lift.ending and self.lift.z_done:
                actions.close_lift(t, self.line)
        self._settle(t)
        if not log.items and not self._started:
            if self.interp.stopped_at is None:
                self.ahead.prime(t)
            elif ch.state is ACTIVE:
                self.interp.prime_leaving()  # the resume's profile, in a quiet cycle of the wait
        positions = self._positions()
        self._monitor(positions, t)
        return positions

    def after_cycle(self) -> None:
        """The cycle's deferred work, after its snapshot: a piece of the next run's build."""
        if self._started:
            self._started = False
        else:
            self.next_runs.deferred(self.path.end_position, self.channel.runs)

    # -- the PLC's commands: what a transition of the channel does to the path and the lift ------
    def _start(self, t: float) -> None:
        ch = self.channel
        if ch.state is READY:
            if ch.runs:
                self._load(self._positions())  # a new run from where the last one ended
                self.actions.z_hold = None  # the new run starts there
            self._started = True
            self.interp.start(t)
            self.actions.begin(t)
            ch.program_start(t, self.prog.first_line)
        elif ch.state is HOLD:
            self.actions.resume_at(t)
            ch.resume(t, self.line)
        else:
            ch.cancel_stop()

    def _command(self, cmd: Command, t: float) -> None:
        ch = self.channel
        if ch.takes_start(cmd):
            self._start(t)
        elif ch.request(cmd) and self.lift.current is not None and ch.state is not ERROR:
            # a RESET: the program ends inside a lift range: Z rises to POS_LIMIT and stays,
            # the vendor's reaction to an error in a range (§2.4), never down onto the path
            # it leaves between LIFT_START and LIFT_END
            self.lift.error_in_range(t)

    def _settle(self, t: float) -> None:
        """STOP and RESET complete once the path is at rest."""
        ch = self.channel
        if not ch.stop_requested and not ch.reset_requested:
            return
        at_rest = self.interp.v == 0.0 and self.interp.a == 0.0
        if ch.stop_due(at_rest):
            ch.stopped(t, self.line)
        lift = self.lift
        if ch.reset_due(at_rest) and (
            lift.current is None
            or (
                not lift.error_pending  # Z still follows the path to rest, then rises
                and lift.vz == 0.0
                and lift.az == 0.0
                # at POS_LIMIT, not at the start of its rise from rest (path-based)
                and (lift.phase is not HOLD_LIMIT or lift.needed_time() == 0.0)
            )
        ):
            # every axis at rest, the lift axis too: a lift it was in ends where Z is (at
            # POS_LIMIT: `_command`) and stays there (not the path's Z inside the range) until
            # the next START loads the program from the current positions
            self.actions.waiting = []
            line = self.line
            if lift.current is not None:
                self.actions.z_hold = (lift.axis_index, lift.z)
                lift.abort()
                self.log.emit(events.LIFT_ABORTED, t, line, lift.z)
            lift.active = lift.suppressed = False
            ch.reset_done(t, line)

    @property
    def line(self) -> int:
        """The NC line of the block being executed (or of the action waiting)."""
        waiting = self.actions.waiting
        if waiting:
            return waiting[0].line
        k = self.interp.stopped_at
        if k is not None:
            return self.path.boundaries[k].line or self.prog.first_line
        segs = self.path.segments
        return segs[min(self.interp.segment, len(segs) - 1)].line if segs else 0

    def _monitor_of(self, axis: int) -> AccelMonitor:
        mon = self.monitors.get(axis)
        if mon is None:
            mon = self.monitors[axis] = AccelMonitor(self.ch.axes[axis], self.ch.cycle_time)
        return mon

    def _monitor(self, positions: tuple[float, ...], t: float) -> None:
        rec = self.lift.record
        lifting = self.lift.axis_index if rec is not None else -1
        for axis, mon in self.monitors.items():
            entered = mon.sample(positions[axis])
            if axis == lifting and mon.ratio > rec.z_a_max_ratio:  # type: ignore[union-attr]
                rec.z_a_max_ratio = mon.ratio  # type: ignore[union-attr]
            if entered == mon.ERROR:
                self.log.emit(events.LIFT_Z_ACC_ERROR, t, self.line, mon.ratio)
            elif entered == mon.WARNING:
                self.log.emit(events.LIFT_Z_ACC_WARNING, t, self.line, mon.ratio)

    def _run_path(self, t: float) -> None:
        actions = self.actions
        for _ in range(100000):  # bounded: every pass ends a wait or passes a boundary
            if self.interp.stopped_at is not None:
                if not actions.work_waiting(t):
                    return
                k = self.interp.stopped_at
                rested = self.interp.t_state
                self.interp.resume(actions.wait_since)
                actions.z_rest = None
                if k is not None:
                    actions.resumed(k, rested)
            for crossing in self.interp.advance(t):
                actions.cross(crossing)
            if self.interp.stopped_at is None or self.channel.state is not ACTIVE:
                return

    def snapshot(self, t: float, inputs: GeoInputs, positions: tuple[float, ...]) -> GeoSnapshot:
        lift, ch = self.lift, self.channel
        if lift.current is None:
            phase, vz, az = NO_PHASE, 0.0, 0.0
        else:
            phase, vz, az = lift.phase, lift.vz, lift.az
        # unpacked into locals: a native tuple of two C doubles (starred into the field tuple it
        # went through a list)
        v_block_max, v_block_end = self.path.block_velocities(self.interp.segment, self.ov_eff)
        # positional, GeoSnapshot field order, built by tuple.__new__ (keywords cost ~2 µs per
        # cycle here, NamedTuple.__new__ is a Python frame: ~0.3 µs)
        return new_snapshot(
            (
                self.cycle,
                t,
                ch.state,
                self.line,
                self.interp.segment,
                positions,
                self.interp.v,
                self.ov_eff,
                self.ov_req,
                self.ov_max,
                inputs.feed_hold,
                lift.active,
                lift.suppressed,
                phase,
                vz,
                az,
                ch.m_pending,
                ch.error_id,
                ch.error_line,
                tuple(self.log.items),
                v_block_max,
                v_block_end,
                lift.axis_index,
                lift.counts,
            )
        )


def lead_cycles(ch: ChannelParams, axis: str) -> int:
    """How far ahead the path's future is committed for a lift on `axis`: its slowest descent
    (a time-optimal move over its whole travel, at most 2 s) plus a margin, so that a lift
    always decides its descent against an exact remaining time."""
    z = ch.axis(axis)
    travel = z.sw_limit_pos - z.sw_limit_neg
    try:
        t_full = LiftProfiles(z.v_max, z.a_max, z.j_max).to_rest(0.0, 0.0, 0.0, travel).duration
    except ProfileError:
        t_full = 0.5
    t_full = min(float(t_full), 2.0) if travel > 0.0 else 0.1
    return max(10, round((t_full + 0.05) / ch.cycle_time))
