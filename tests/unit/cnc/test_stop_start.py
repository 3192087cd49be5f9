"""A PLC STOP brings the path to rest (HOLD) and START goes on from there, however long the
channel was held, mid-block or inside a lift range: as after a feed hold, the path leaves
where it stopped with a jerk-limited ramp, every axis within its limits, and Z lands on time.
(The path used to jump on START to where it would have been without the stop: 25 mm after
0.27 s, 110 mm after 3 s, blocks skipped; `liftd simulate` has no STOP, so no trace showed it.)"""

from __future__ import annotations

import numpy as np
import pytest

from liftd.cnc.params import LiftMethod
from liftd.cnc.plc import Schedule, SimPlc
from liftd.cnc.snapshot import ChannelState, Command, GeoInputs, GeoSnapshot
from tests.support.channel import make_channel
from tests.support.closed_loop import events, fd_ratios, run_task
from tests.support.paths import REPO

DEMO = (REPO / "config" / "programs" / "demo.nc").read_text()


class StopThenStart:
    """The simulated PLC, plus a STOP at t_stop and a START `held` seconds after the channel
    reported HOLD."""

    def __init__(self, t_stop: float, held: float) -> None:
        self.plc = SimPlc(0.02)
        self.t_stop, self.held = t_stop, held
        self.t_hold: float | None = None
        self.started = False

    def __call__(self, t: float, last: GeoSnapshot | None) -> GeoInputs:
        inputs = self.plc.inputs(last, t, Schedule())
        if last is not None and last.state is ChannelState.HOLD and self.t_hold is None:
            self.t_hold = last.t
        if abs(t - self.t_stop) < 1e-9:
            return inputs._replace(command=Command.STOP)
        if self.t_hold is not None and not self.started:
            if t >= self.t_hold + self.held - 1e-9:
                self.started = True
                return inputs._replace(command=Command.START)
            # a PLC STOP is not undone by the automatic PLC (it continues only after M00)
            return inputs._replace(command=Command.NONE)
        return inputs


@pytest.mark.parametrize("method", [LiftMethod.ADVANCED, LiftMethod.LIFTING])
@pytest.mark.parametrize("held", [0.001, 0.27, 3.0])
@pytest.mark.parametrize(("t_stop", "in_lift"), [(0.45, False), (5.6, True), (6.1, True),
                                                 (12.6, True)])  # fmt: skip
def test_start_after_a_stop_goes_on_from_where_the_path_stopped(
    method: LiftMethod, held: float, t_stop: float, in_lift: bool
) -> None:
    ch = make_channel(method)
    plc = StopThenStart(t_stop, held)
    task, snaps = run_task(ch, DEMO, inputs=plc, max_time=60.0)
    assert plc.started, "the channel never reached HOLD"
    assert snaps[-1].state is ChannelState.READY  # the program ends, no error
    at_stop = next(s for s in snaps if s.t >= t_stop)
    assert (at_stop.lift_active or at_stop.lift_phase != 0) == in_lift
    # at rest while held: the path does not move until START
    hold = [s for s in snaps if s.state is ChannelState.HOLD]
    assert len(hold) >= round(held / ch.cycle_time)
    xy = np.array([s.positions[:2] for s in hold])
    assert np.abs(xy - xy[0]).max() == 0.0
    # every axis within its limits across the stop and the START (finite differences; the
    # lift method `lifting` may take Z's acceleration and jerk beyond the limits by design)
    ratios = fd_ratios(ch, snaps)
    assert ratios[:, :2].max() <= 1.0 + 1e-6, ratios
    z = ratios[:, 2] if method is LiftMethod.ADVANCED else ratios[:1, 2]
    assert z.max() <= 1.0 + 1e-6, ratios
    # the path goes on from where it stopped: the first cycle after START moves a jerk pulse
    k = next(i for i, s in enumerate(snaps) if s.t > hold[-1].t)
    step = np.abs(np.array(snaps[k].positions[:2]) - xy[-1]).max()
    assert step < 1e-6, step
    # and Z lands on time in every range, as without the stop
    assert not events(snaps, "lift.late")
    assert all(r.arrival_error <= 1e-6 for r in task.lift.records)
    assert len(task.lift.records) == 5
