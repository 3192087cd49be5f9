"""A PLC RESET, or an NC error, inside a random lift range of a wide scenario
(tests/support/scenarios.py): the runs bench/bench_reset.py makes by the hundred and
tests/unit/cnc/test_stop_start.py by the few. Moved from bench/bench_reset.py (issue 40)."""

from __future__ import annotations

import random

import numpy as np

from liftd.cnc.geo_task import GeoTask
from liftd.cnc.params import LiftMethod
from liftd.cnc.plc import SimPlc
from liftd.cnc.snapshot import ChannelState, Command, GeoSnapshot
from tests.support.closed_loop import run_task
from tests.support.cycle_check import lift_axis_ratio
from tests.support.scenarios import wide_scenario


def reset_in_a_range(
    seed: int, method: LiftMethod
) -> tuple[float, float | None, GeoSnapshot, float] | None:
    """(t of the RESET, t of READY or None, the last snapshot, Z's largest v/a/j ratio from
    the RESET on); None without a lift range."""
    sc = wide_scenario(seed, method)
    ref, _ = run_task(sc.channel, sc.text, sc.schedule, max_time=300)
    rnd = random.Random(seed)
    if not ref.lift.records:
        return None
    rec = rnd.choice(ref.lift.records)
    t_reset = rec.t_start + rnd.uniform(0.0, rec.t_end - rec.t_start)
    dt = sc.channel.cycle_time
    task, plc = GeoTask(sc.channel, sc.text), SimPlc(0.02)
    last: GeoSnapshot | None = None
    sent = False
    after: list[GeoSnapshot] = []  # from three cycles before the RESET on
    for k in range(1, round((t_reset + 3.0) / dt) + 2):
        t = k * dt
        inputs = plc.inputs(last, t, sc.schedule)
        if not sent and t >= t_reset:
            inputs, sent = inputs._replace(command=Command.RESET), True
        last = task.step(inputs, t)
        if t >= t_reset - 3.5 * dt:
            after.append(last)
        if sent and last.state is ChannelState.READY:
            return t_reset, t, last, lift_axis_ratio(sc, after)
    assert last is not None
    return t_reset, None, last, lift_axis_ratio(sc, after)


def nc_error_in_a_range(seed: int, method: LiftMethod) -> dict[str, object] | None:
    """What went wrong when an NC error stops the program inside a random range ({} for
    nothing); None without a range to put it in."""
    sc = wide_scenario(seed, method)
    ref, _ = run_task(sc.channel, sc.text, sc.schedule, max_time=300)
    ranges = [r for r in ref.lift.records if r.range.end_line > r.range.start.line + 1]
    if not ranges:
        return None
    rnd = random.Random(seed)
    rng = rnd.choice(ranges).range
    lines = sc.text.splitlines()
    at = rnd.randrange(rng.start.line, rng.end_line - 1)  # after LIFT_START, before LIFT_END
    text = "\n".join([*lines[:at], "Q1 oops", *lines[at:]]) + "\n"
    _, snaps = run_task(sc.channel, text, sc.schedule, max_time=300)
    last = snaps[-1]
    k = next((i for i, s in enumerate(snaps) if s.state is ChannelState.ERROR), None)
    problems: dict[str, object] = {}
    if k is None or last.state is not ChannelState.ERROR:
        problems["state"] = last.state.name
        return problems
    if last.lift_vz != 0.0 or last.lift_az != 0.0:
        problems["z_moving_at_end"] = (last.lift_vz, last.lift_az)
    spec = rng.start
    # the maximum lift height: POS_LIMIT, raised to the start or POS beyond it (vendor §2.1.1;
    # issue 37 item 1), mirrored for DOWN; and from the error on Z never moves toward the part
    far = min if spec.down else max
    top = far(spec.pos_limit, spec.target, spec.z_start)
    z_axis = [ax.name for ax in sc.channel.axes].index(spec.axis)
    if abs(last.positions[z_axis] - top) > 1e-9:
        problems["z_end"] = (last.positions[z_axis], top)
    sign = -1.0 if spec.down else 1.0
    z = np.array([sign * s.positions[z_axis] for s in snaps[k:]])
    if np.diff(z).min(initial=0.0) < -1e-12:
        problems["z_toward_the_part"] = float(np.diff(z).min())
    ratio = lift_axis_ratio(sc, snaps)
    if ratio > 1.0 + 1e-6:
        problems["z_limit_ratio"] = ratio
    return problems
