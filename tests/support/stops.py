"""Simulated PLCs that also send a STOP and a START (tests/unit/cnc/test_stop_start.py and
bench/bench_lift_safety.py --stops)."""

from __future__ import annotations

import random

from liftd.cnc.plc import Schedule, SimPlc
from liftd.cnc.snapshot import ChannelState, Command, GeoInputs, GeoSnapshot
from tests.support.closed_loop import run_task
from tests.support.scenarios import Scenario


class StopThenStart:
    """The simulated PLC (with `schedule`), plus a STOP at t_stop and a START `held` seconds
    after the channel reported HOLD."""

    def __init__(self, t_stop: float, held: float, schedule: Schedule | None = None) -> None:
        self.plc = SimPlc(0.02)
        self.schedule = schedule or Schedule()
        self.t_stop, self.held = t_stop, held
        self.t_hold: float | None = None
        self.stopped = self.started = False

    def __call__(self, t: float, last: GeoSnapshot | None) -> GeoInputs:
        inputs = self.plc.inputs(last, t, self.schedule)
        if last is not None and last.state is ChannelState.HOLD and self.t_hold is None:
            self.t_hold = last.t
        if not self.stopped and t >= self.t_stop - 1e-9:  # the first cycle from t_stop on
            self.stopped = True
            return inputs._replace(command=Command.STOP)
        if self.t_hold is not None and not self.started:
            if t >= self.t_hold + self.held - 1e-9:
                self.started = True
                return inputs._replace(command=Command.START)
            # a PLC STOP is not undone by the automatic PLC (it continues only after M00)
            return inputs._replace(command=Command.NONE)
        return inputs


def stop_and_start(sc: Scenario, seed: int) -> StopThenStart:
    """The scenario's PLC with a STOP at a random moment of its run (inside a lift range in
    two of three, when it has one) and START after a random hold of 1 ms–2 s."""
    ref, _ = run_task(sc.channel, sc.text, sc.schedule, max_time=300)
    rnd = random.Random(seed)
    lifts = ref.lift.records
    if lifts and rnd.random() < 2 / 3:
        rec = rnd.choice(lifts)
        t_stop = rec.t_start + rnd.uniform(0.0, rec.t_end - rec.t_start)
    else:
        t_stop = rnd.uniform(0.0, ref.t_cycle)
    return StopThenStart(round(t_stop, 3), round(rnd.uniform(0.001, 2.0), 3), sc.schedule)
