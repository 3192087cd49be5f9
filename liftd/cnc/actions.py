"""What a channel does at the boundaries its path reaches (`BoundaryActions`, a part of
`GeoTask`): M functions with their acknowledge, M00, dwell, #FLUSH, the program end, and each
lift range's start and end, at the boundary's exact time; where the path rests, the waiting
actions hold it until they are done. Closing a lift reports its path delay against the nominal
run. The channel's state changes through its state machine (channel_state.py)."""

from __future__ import annotations

from liftd.cnc import events
from liftd.cnc.channel_state import ChannelStateMachine
from liftd.cnc.events import EventLog
from liftd.cnc.geo_program import GeoProgram
from liftd.cnc.lift.controller import LiftController, LiftRecord
from liftd.cnc.lift.ranges import LiftRange
from liftd.cnc.lift_ahead import LiftAhead
from liftd.cnc.params import MSync
from liftd.cnc.path.interpolator import Crossing, Interpolator
from liftd.cnc.path.program import Action, ActionKind

LANDING_TOL = 1e-6  # m: Z counts as at POS when the path passes LIFT_END (1 µm)
LANDING_TIME_TOL = 1e-6  # s: … and as at rest when its descent ends within 1 µs of that,
# or when what is left of it keeps Z within LANDING_TOL of POS (`LiftMotion.travel_left`)
ACK_SYNCS = (MSync.MVS_SVS, MSync.MVS_SNS, MSync.MNS_SNS, MSync.MNE_SNS)
INF = float("inf")


class BoundaryActions:
    """The actions at the path's boundaries, for the run loaded."""

    def __init__(
        self,
        channel: ChannelStateMachine,
        log: EventLog,
        ahead: LiftAhead,
        axis_of: dict[str, int],
        cycle_time: float,
    ) -> None:
        self.channel = channel
        self.log = log
        self.ahead = ahead  # the lift's horizon (a #FLUSH), the next range to prime
        self.axis_of = axis_of  # axis name -> index in the channel
        self.dt = cycle_time
        self.ov_eff = 1.0  # the override in effect in this cycle (`GeoTask.step` sets it)
        self.waiting: list[Action] = []  # actions left at the boundary where the path rests
        self.wait_since = 0.0  # time from which the current wait counts
        self.rest_since = 0.0  # time the path came to rest at the boundary where it rests
        self.z_delay = 0.0  # the part of the last wait inside a range that was for Z
        self.z_rest: tuple[int, float] | None = None  # (axis, Z) after a lift that ended here
        self.z_hold: tuple[int, float] | None = None  # (axis, Z) a RESET left, until a START

    def load(self, prog: GeoProgram, interp: Interpolator, lift: LiftController) -> None:
        """A run is loaded: its program, path and lift; nothing waits."""
        self.prog = prog
        self.interp = interp
        self.lift = lift
        self.lift_ranges = prog.ranges
        self.range_of = prog.range_of  # id of a LIFT_START's spec -> its range
        self.waiting = []

    def begin(self, t: float) -> None:
        """The run starts at t: the actions of the program's first boundary wait."""
        self.waiting = list(self.prog.path.boundaries[0].actions)
        self.wait_since = t

    def resume_at(self, t: float) -> None:
        """A START after a STOP or an M00 at t: an M00 waiting is done; a path held at a
        boundary leaves it no earlier than now: its waits may have ended while it was held (Z
        arrived, an M function was acknowledged), and left at their time it jumped ahead by the
        time it was held (a dwell under way starts again)."""
        if self.waiting and self.waiting[0].kind is ActionKind.M00:
            self.waiting.pop(0)
        self.wait_since = max(self.wait_since, t)

    def end_of_program(self, t: float, line: int) -> None:
        """The program ends: M30 reached, or an NC error stops it (then a lift under way rises
        to POS_LIMIT and stays, vendor §2.4)."""
        err = self.prog.error
        if err is not None:
            if self.lift.current is not None:
                self.lift.error_in_range(t)
            self.channel.error(t, err.id, err.line, err.message)
        else:
            self.channel.program_end(t, line)
        self.waiting = []

    def cross(self, c: Crossing) -> None:
        actions = self.prog.path.boundaries[c.boundary].actions
        if c.at_rest:
            self.waiting = list(actions)
            self.wait_since = self.rest_since = c.t
            return
        for action in actions:  # passing without a stop: nothing here waits
            self._do(action, c.t, c)

    def work_waiting(self, now: float) -> bool:
        """Run the actions where the path rests; True when it may go on."""
        while self.waiting:
            if not self._do(self.waiting[0], self.wait_since, None, now):
                return False
            self.waiting.pop(0)
        k = self.interp.stopped_at
        if k is not None and k >= len(self.prog.path.segments):
            self.end_of_program(self.wait_since, self.prog.path.boundaries[k].line)
            return False
        # a RESET under way keeps the path where it came to rest (a resume inside a range
        # set the lift rising for the rest of it again, instead of holding at POS_LIMIT)
        return self.channel.may_move() and self.z_lets_go(now)

    def _do(self, action: Action, t_at: float, crossing: Crossing | None, now: float = 0.0) -> bool:
        """Execute one action at time t_at; False while it still waits (only where the path
        rests, `now` being the cycle time)."""
        kind = action.kind
        if kind is ActionKind.LIFT_START:
            # the range without GeoProgram.range_at: a Python frame, 9 µs of a lift start's
            # cycle with cold caches
            self._lift_start(self.lift_ranges[self.range_of[id(action.lift_start)]], t_at, crossing)
        elif kind is ActionKind.LIFT_END:
            return self._lift_end(action, t_at, crossing, now)
        elif kind is ActionKind.M_OUTPUT:
            needs_ack = action.sync in ACK_SYNCS
            self.channel.m_output(t_at, action.line, action.m_number, needs_ack)
        elif kind is ActionKind.M_WAIT:
            if not self.channel.take_ack(action.m_number):
                return False
            if crossing is None:
                self.wait_since = max(self.wait_since, self.channel.ack_time)
        elif kind is ActionKind.M00:
            self.channel.m00(t_at, action.line)
            return False
        elif kind is ActionKind.DWELL:
            if now < t_at + action.seconds:
                return False
            self.wait_since = t_at + action.seconds
        elif kind is ActionKind.PROGRAM_END:
            self.end_of_program(t_at, action.line)
            return False
        # (a #FLUSH where the path rests: it leaves unless Z could not make it from there,
        # decided with the boundary's other waits, `work_waiting`)
        return True

    def z_lets_go(self, now: float) -> bool:
        """The path rests inside a lift range at a #FLUSH or at a waiting point of the program
        (G04, a synchronised M function, M00) whose wait is over: it leaves unless it must
        wait for Z, that is unless Z, as it is now, needs longer to reach POS than the path
        needs from here to the horizon beyond (a lower bound at the override in effect).
        Then it leaves at the exact time from which Z lands before the path can arrive
        (vendor §2.1.3 case 3: the flush "may stop the path"; §2.1.1: the path waits for Z
        where the feed cannot be reduced enough); meanwhile Z descends against that time
        (`LiftAhead.lift_time`). A waiting point's wait for Z is the lift's delay
        (`z_delay`), not the program's wait. Z is short of POS there after a START or a feed
        hold's release just before it (`TimeBasedLift.limit_override`: the path waits
        there), and left then it rose again for the rest of the range and landed after the
        path had passed LIFT_END (wide --stops seed 474: 0.48 mm, 10 ms late)."""
        self.z_delay = 0.0
        if not self._z_lets_go(now):
            return False
        ip = self.interp
        here = ip.stopped_at
        if here is not None and here in ip.lift_stops:  # (the path rests there: no re-plan)
            ip.drop_lift_stop(here)
        return True

    def _z_lets_go(self, now: float) -> bool:
        lift = self.lift
        m = lift.motion
        if m is None or not m.uses_time:
            return True
        k = self.ahead.leaving_horizon()
        if k < 0:
            return True  # not inside a range, or another flush lies before the horizon
        landing = lift.t + m.landing_time()
        if landing <= self.wait_since:
            return True  # Z is down by then (at POS as a rule): no bound needed
        ip = self.interp
        path_needs = ip.lower_bound(k, self.ov_eff) - ip.t_state
        if path_needs == INF:
            return True  # a feed hold or override 0: the override rule decides on release
        leave = landing - path_needs
        if leave > self.wait_since:
            if leave > now:
                return False
            # never before the last cycle, where the path was published at rest (Z's need
            # can fall by more than a cycle in one, when it turns to its descent)
            leave = max(leave, now - self.dt)
            self.z_delay = leave - self.wait_since
            self.wait_since = leave
        return True

    def resumed(self, k: int, rested: float) -> None:
        """The path left boundary k, where it rested from `rested`, at `wait_since`. Inside a
        lift range Z lifts again for the rest of it after a waiting point (its wait is the
        program's, not the lift's); at a #FLUSH Z goes on as it was (vendor §2.1.3 case 3:
        no influence on the lift profile), and a wait there was for Z, the lift's delay."""
        rng = self.lift.current
        rec = self.lift.record
        if rng is None or rec is None:
            return
        if rng.k_start < k and (rng.k_end < 0 or k < rng.k_end):
            if k in self.prog.flushes[rng.index]:
                return
            self.lift.resume_in_range(self.wait_since)
            rec.waits += max(0.0, self.wait_since - self.z_delay - rested)
        elif k == rng.k_start:
            # where the range's own waits held the path there, a wait for Z after them is
            # the lift's delay: the nominal run leaves when the program's waits end
            self._departure(rec, self.wait_since - self.z_delay, None)
            if k in self.prog.stops[rng.index]:
                self.lift.resume_in_range(self.wait_since)  # Z went to POS: lift again

    def _lift_start(self, rng: LiftRange, t_at: float, crossing: Crossing | None) -> None:
        if self.channel.reset_requested:  # the path brakes for a RESET: no range starts now
            if self.lift.current is None and self.z_hold is None:
                # the axis stays where it is (the first range skipped: the next one's start
                # assumes this one ran), not where the path's POS would put it
                self.z_hold = (self.axis_of[rng.start.axis], rng.start.z_start)
            return
        if self.lift.current is not None:  # the last lift is still finishing (late): go on from Z
            z, vz, az = self.lift.z, self.lift.vz, self.lift.az
            self.close_lift(t_at, rng.start.line)
        else:  # the programmed Z at the start (the decoder tracked every earlier lift's POS)
            u_z = self.prog.entry_dir[rng.index]
            z = rng.start.z_start
            vz = crossing.v * u_z if crossing else 0.0
            az = crossing.a * u_z if crossing else 0.0
        self.lift.start(rng, t_at, z, vz, az)
        self.ahead.prime_next = rng.index + 1
        m = self.lift.motion
        if m is not None and not m.uses_time:  # coupled: Z at z(s) from the range's start
            s = self.prog.path.boundaries[rng.k_start].s
            self.lift.step(t_at, s, crossing.v if crossing else 0.0, 0.0, 0.0, self.ov_eff)
        rec = self.lift.record
        if rec is not None and crossing is not None:  # passing: the path leaves at once
            self._departure(rec, t_at, crossing)
        self.log.emit(
            events.LIFT_START,
            t_at,
            rng.start.line,
            rng.start.target,
            "suppressed" if rng.suppressed else "",
        )

    def _departure(self, rec: LiftRecord, t: float, crossing: Crossing | None) -> None:
        """The path leaves the start of the lift range: the nominal run starts with it."""
        rng = rec.range
        rec.departure = t
        if rng.k_end > rng.k_start:
            b = self.prog.path.boundaries[rng.k_start]
            v, a = (crossing.v, crossing.a) if crossing is not None else (0.0, 0.0)
            differs = self.prog.nominal_differs[rng.index]
            self.interp.nominal_start(
                self.prog.nominal, rng.k_end, t, b.s, v, a, rng.k_start, differs
            )

    def _lift_end(self, action: Action, t_at: float, crossing: Crossing | None, now: float) -> bool:
        lift = self.lift
        m = lift.motion
        if lift.current is None or m is None:
            return True
        if self.channel.reset_requested:
            # the path braking for a RESET passes LIFT_END: the range ends with the RESET,
            # Z held up at POS_LIMIT (`lift.aborted`), never closed here with Z far from POS
            # and handed back to the path's Z (Z jumped up to 35 mm in one cycle: bench_reset)
            return True
        s_end = self.prog.path.boundaries[lift.current.k_end].s
        if not m.uses_time:  # Z to where the path got
            lift.step(t_at, s_end, crossing.v if crossing else 0.0, 0.0, 0.0, self.ov_eff)
        elif lift.t < t_at:  # Z to the time the path got here
            lift.step(t_at, s_end, 0.0, 0.0, t_at - lift.t, self.ov_eff)
        rec = lift.record
        # where the path rests, the program's own waits before LIFT_END (a dwell, an M
        # function, a STOP) end at `reached`: they are not the lift's delay, the wait for Z is
        reached = t_at
        if crossing is None and not lift.z_done:
            lift.step(now, s_end, 0.0, 0.0, 0.0, self.ov_eff)  # the path waits here for Z
            if not self._z_landed():  # (a call: mypy keeps the narrowing of lift.z_done)
                return False
            t_at = self.wait_since = max(t_at, lift.landed)
        if crossing is None and rec is not None:
            rec.waits += max(0.0, reached - max(self.rest_since, rec.t_start))
        error = abs(lift.z - lift.current.start.target)
        # Z at POS but its descent ends a rounding later than the path's crossing (≤ 1 µs; wide
        # seed 1965: 2e-17 m, 0.5 µs), or later at a crawl that keeps it within LANDING_TOL of
        # POS to its end (wide --stops seed 983: the path braking for a STOP comes to rest on
        # LIFT_END, Z 3e-15 m from POS at 3e-9 m/s, 2.8 µs to go; --flush seed 425: a descent
        # re-planned 0.23 µm above POS for the path's later arrival, 1.07 ms and under 8 nm
        # still to go): landed. It finishes that descent as planned, and the lift closes when
        # it has (snapping it to rest here would be a jerk).
        need = m.needed_time() if m.uses_time and not lift.z_done else -1.0
        settling = 0.0 <= need <= LANDING_TIME_TOL or (
            need >= 0.0 and error + m.travel_left() <= LANDING_TOL
        )
        if error <= LANDING_TOL and settling:
            lift.ending = True
            return True
        if not lift.z_done or error > LANDING_TOL:
            # Never expected (the path is limited and waits so that Z makes it): the path passes
            # LIFT_END with Z not at POS. Reported as it is: the error is |Z − POS| now.
            if rec is not None:
                rec.arrival_error, rec.late = error, True
            text = f"Z {error * 1e3:.6f} mm from POS when the path passed LIFT_END"
            self.log.emit(events.LIFT_LATE, t_at, action.line, error, text)
            lift.ending = True
            return True
        self.close_lift(t_at, action.line)
        return True

    def _z_landed(self) -> bool:
        return self.lift.z_done

    def close_lift(self, t: float, line: int) -> None:
        rng = self.lift.current
        if rng is not None:
            self.interp.drop_lift_stop(rng.k_end)
        self.z_rest = (self.lift.axis_index, self.lift.z)  # Z while the path rests here
        rec = self.lift.finish(t)
        if rec is not None:
            self.interp.nominal_flush()  # a step an event's cycle left (`nominal_step`)
            nominal = self.interp.nominal_arrival
            start = rec.departure if rec.departure is not None else rec.t_start
            if rng is not None and rng.k_end > rng.k_start:
                if nominal is not None:
                    rec.nominal_time = nominal - start
                    rec.path_delay = max(0.0, rec.t_end - start - rec.waits - rec.nominal_time)
                else:
                    # the nominal run has not arrived yet (it was stepped to this cycle's end):
                    # the path without the lift's limits is no faster, the lift cost nothing.
                    # Its time is at least the path's own (issue 37 item 4: path-based Lifting
                    # reported the whole range, 1.57 s, where its path arrived 0.4 ms early)
                    rec.nominal_time = rec.t_end - start - rec.waits
                    rec.path_delay = 0.0
            else:  # no path motion: all the time is the path waiting for Z
                rec.path_delay = max(0.0, rec.t_end - rec.t_start - rec.waits)
            self.interp.nominal_stop()
            self.log.emit(events.LIFT_END, rec.t_end, line, rec.peak)
