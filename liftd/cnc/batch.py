"""Quiet GEO cycles in one call: `run_quiet` advances a GeoTask many cycles with the same inputs
and hands back each quiet cycle as a flat row of floats instead of a `GeoSnapshot`.

A cycle is quiet when the caller has nothing to react to: the channel ACTIVE, no M function
waiting for its acknowledge, no event. Its row holds what `liftd simulate` records of a cycle
(the trace CSV's columns, the segment for the limit monitor); everything else a snapshot
holds (events, M function, errors, block velocities, lift counts) is known to be unchanged or
empty in such a cycle. The first cycle that is not quiet, and the last of the batch, come
back as the snapshot `GeoTask.step` would have published: every cycle runs exactly as in
`step` (`GeoTask.advance`, then `after_cycle`), so a batch equals single steps bit for bit
(tests/unit/cnc/test_batch.py). The GEO loop of `liftd run` steps one cycle at a time.
"""

from __future__ import annotations

from typing import Final

from liftd.cnc.geo_task import GeoTask
from liftd.cnc.snapshot import ChannelState, GeoInputs, GeoSnapshot, LiftPhase

# a quiet cycle's row: these columns, then one per channel axis (its command position, m)
T: Final = 0  # s
LINE: Final = 1
SEGMENT: Final = 2
V_PATH: Final = 3  # m/s
OVERRIDE: Final = 4  # in effect (fraction)
LIFT_ACTIVE: Final = 5  # 0/1
LIFT_SUPPRESSED: Final = 6  # 0/1
LIFT_PHASE: Final = 7  # LiftPhase
VZ: Final = 8  # lift axis m/s
AZ: Final = 9  # lift axis m/s²
STATE: Final = 10  # ChannelState (ACTIVE)
OVERRIDE_MAX: Final = 11
POSITIONS: Final = 12  # the first axis

ACTIVE: Final = ChannelState.ACTIVE
NO_PHASE: Final = float(LiftPhase.NONE)


def row_width(n_axes: int) -> int:
    return POSITIONS + n_axes


def run_quiet(
    task: GeoTask, inputs: GeoInputs, k: int, n: int, dt: float, rows: list[float]
) -> GeoSnapshot:
    """Run cycles k … k + n − 1 (t = k·dt, as the caller's own loop computes it) with `inputs`,
    appending each quiet cycle's row to `rows`, up to the first cycle that is not quiet or the
    n-th: that one is returned as its snapshot (n ≥ 1). The caller counts the cycles run:
    the rows appended plus one."""
    j = k
    last = k + n - 1
    ch = task.channel
    log = task.log
    while j < last:
        t = j * dt
        positions = task.advance(inputs, t)
        if ch.state is not ACTIVE or ch.m_pending >= 0 or log.items:
            snap = task.snapshot(t, inputs, positions)
            task.after_cycle()
            return snap
        lift = task.lift
        interp = task.interp
        if lift.current is None:
            phase, vz, az = NO_PHASE, 0.0, 0.0
        else:
            phase, vz, az = float(lift.phase), lift.vz, lift.az
        rows.append(t)
        rows.append(float(task.line))
        rows.append(float(interp.segment))
        rows.append(interp.v)
        rows.append(task.ov_eff)
        rows.append(1.0 if lift.active else 0.0)
        rows.append(1.0 if lift.suppressed else 0.0)
        rows.append(phase)
        rows.append(vz)
        rows.append(az)
        rows.append(float(ch.state))
        rows.append(task.ov_max)
        rows.extend(positions)
        task.after_cycle()
        j += 1
    return task.step(inputs, last * dt)
