"""What a channel does at the boundaries its path reaches (`BoundaryActions`, the base of
`GeoTask`): M functions with their acknowledge, M00, dwell, the program end, and each lift
range's start and end, at the boundary's exact time; where the path rests, the waiting actions
hold it until they are done. Closing a lift reports its path delay against the nominal run."""

from __future__ import annotations

from typing import Final

from liftd.cnc.geo_program import GeoProgram
from liftd.cnc.lift.controller import LiftController, LiftRecord
from liftd.cnc.lift.ranges import LiftRange
from liftd.cnc.params import MSync
from liftd.cnc.path.interpolator import Crossing, Interpolator
from liftd.cnc.path.program import Action, ActionKind
from liftd.cnc.snapshot import ChannelState, Event, new_event

LANDING_TOL = 1e-6  # m: Z counts as at POS when the path passes LIFT_END (1 µm)
LANDING_TIME_TOL = 1e-6  # s: … and as at rest when its descent ends within 1 µs of that,
LANDING_V_TOL = 1e-6  # m/s: … or when it moves slower than 1 µm/s and ends within
LANDING_SETTLE_MAX = 1e-4  # s: 0.1 ms (then it moves less than 1e-10 m more)
ACK_SYNCS = (MSync.MVS_SVS, MSync.MVS_SNS, MSync.MNS_SNS, MSync.MNE_SNS)
# enum members as C statics of the compiled module (a dict and a type lookup each otherwise)
ACTIVE: Final = ChannelState.ACTIVE
HOLD: Final = ChannelState.HOLD


class BoundaryActions:
    """The actions at the path's boundaries, on the channel state `GeoTask` holds."""

    prog: GeoProgram
    interp: Interpolator
    lift: LiftController
    state: ChannelState
    ov_eff: float
    m_pending: int  # M function waiting for its acknowledge, -1 for none
    m_acked: set[int]
    ack_time: float
    waiting: list[Action]  # actions left at the boundary where the path rests
    wait_since: float  # time from which the current wait counts
    rest_since: float  # time the path came to rest at the boundary where it rests
    z_rest: tuple[int, float] | None  # (axis, Z) after a lift that ended here
    events: list[Event]
    lift_ranges: tuple[LiftRange, ...]  # the program's (`GeoProgram.ranges`)
    range_of: dict[int, int]  # id of a LIFT_START's spec -> its range (`GeoProgram.range_of`)
    prime_next: int  # the range whose start `LiftAhead._prime_lift` prepares
    reset_requested: bool  # a PLC RESET is under way (the path brakes, Z rises to POS_LIMIT)
    z_hold: tuple[int, float] | None  # (axis, Z) a RESET left, until the next START
    axis_of: dict[str, int]  # axis name -> index in the channel

    def _end_of_program(self, t: float, line: int) -> None:
        """The program ends (M30 reached, or an error stops it): `GeoTask`'s."""
        raise NotImplementedError

    def _flush_may_go(self, now: float) -> bool:
        """Whether the path may leave the #FLUSH it rests at (`LiftAhead`'s)."""
        raise NotImplementedError

    def _emit(self, name: str, t: float, line: int, value: float = 0.0, text: str = "") -> None:
        self.events.append(new_event((name, t, line, value, text, 0)))

    def _cross(self, c: Crossing) -> None:
        actions = self.prog.path.boundaries[c.boundary].actions
        if c.at_rest:
            self.waiting = list(actions)
            self.wait_since = self.rest_since = c.t
            return
        for action in actions:  # passing without a stop: nothing here waits
            self._do(action, c.t, c)

    def _work_waiting(self, now: float) -> bool:
        """Run the actions where the path rests; True when it may go on."""
        while self.waiting:
            if not self._do(self.waiting[0], self.wait_since, None, now):
                return False
            self.waiting.pop(0)
        k = self.interp.stopped_at
        if k is not None and k >= len(self.prog.path.segments):
            self._end_of_program(self.wait_since, self.prog.path.boundaries[k].line)
            return False
        # a RESET under way keeps the path where it came to rest (a resume inside a range
        # set the lift rising for the rest of it again, instead of holding at POS_LIMIT)
        return self.state is ACTIVE and not self.reset_requested

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
            self._emit("geo.m_output", t_at, action.line, float(action.m_number))
            if action.sync in ACK_SYNCS:
                self.m_pending = action.m_number
                self.m_acked.discard(action.m_number)
        elif kind is ActionKind.M_WAIT:
            if action.m_number not in self.m_acked:
                return False
            self.m_acked.discard(action.m_number)
            if crossing is None:
                self.wait_since = max(self.wait_since, self.ack_time)
        elif kind is ActionKind.M00:
            self._emit("geo.m00", t_at, action.line)
            self.state = HOLD
            return False
        elif kind is ActionKind.DWELL:
            if now < t_at + action.seconds:
                return False
            self.wait_since = t_at + action.seconds
        elif kind is ActionKind.PROGRAM_END:
            self._end_of_program(t_at, action.line)
            return False
        elif kind is ActionKind.FLUSH and crossing is None:
            return self._flush_may_go(now)  # unless Z could not make it from here
        return True

    def _resumed(self, k: int, rested: float) -> None:
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
            if k not in self.interp.lift_stops:
                rec.waits += self.wait_since - rested
        elif k == rng.k_start:
            self._departure(rec, self.wait_since, None)

    def _lift_start(self, rng: LiftRange, t_at: float, crossing: Crossing | None) -> None:
        if self.reset_requested:  # the path brakes for a RESET: no range starts any more
            if self.lift.current is None and self.z_hold is None:
                # the axis stays where it is (the first range skipped: the next one's start
                # assumes this one ran), not where the path's POS would put it
                self.z_hold = (self.axis_of[rng.start.axis], rng.start.z_start)
            return
        if self.lift.current is not None:  # the last lift is still finishing (late): go on from Z
            z, vz, az = self.lift.z, self.lift.vz, self.lift.az
            self._close_lift(t_at, rng.start.line)
        else:  # the programmed Z at the start (the decoder tracked every earlier lift's POS)
            u_z = self.prog.entry_dir[rng.index]
            z = rng.start.z_start
            vz = crossing.v * u_z if crossing else 0.0
            az = crossing.a * u_z if crossing else 0.0
        self.lift.start(rng, t_at, z, vz, az)
        self.prime_next = rng.index + 1
        m = self.lift.motion
        if m is not None and not m.uses_time:  # coupled: Z at z(s) from the range's start
            s = self.prog.path.boundaries[rng.k_start].s
            self.lift.step(t_at, s, crossing.v if crossing else 0.0, 0.0, 0.0, self.ov_eff)
        rec = self.lift.record
        if rec is not None and crossing is not None:  # passing: the path leaves at once
            self._departure(rec, t_at, crossing)
        self._emit(
            "lift.start",
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
        if self.reset_requested:
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
        # seed 1965: 2e-17 m, 0.5 µs), or a few µs later at a crawl (wide --stops seed 983: the
        # path braking for a STOP comes to rest on LIFT_END; Z 3e-15 m from POS at 3e-9 m/s,
        # 2.8 µs to go): landed. It finishes that descent as planned, and the lift closes when
        # it has (snapping it to rest here would be a jerk).
        need = m.needed_time() if m.uses_time and not lift.z_done else -1.0
        settling = 0.0 <= need <= LANDING_TIME_TOL or (
            0.0 <= need <= LANDING_SETTLE_MAX and abs(lift.vz) <= LANDING_V_TOL
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
            self._emit("lift.late", t_at, action.line, error, text)
            lift.ending = True
            return True
        self._close_lift(t_at, action.line)
        return True

    def _z_landed(self) -> bool:
        return self.lift.z_done

    def _close_lift(self, t: float, line: int) -> None:
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
            self._emit("lift.end", rec.t_end, line, rec.peak)
