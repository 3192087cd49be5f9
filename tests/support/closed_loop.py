"""Closed-loop helpers: drive a GeoTask with a virtual clock (no sleeps), through the cycle
driver of `liftd simulate` (`run_cycles`), and measure what it did."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from liftd.cnc.geo_task import GeoTask
from liftd.cnc.params import ChannelParams, SlopeType
from liftd.cnc.path.limits import transition_allowance
from liftd.cnc.plc import Schedule, SimPlc
from liftd.cnc.snapshot import GeoInputs, GeoSnapshot
from liftd.sim.simulate import run_cycles
from liftd.sim.trace import LimitMonitor

InputFn = Callable[[float, GeoSnapshot | None], GeoInputs]


def run(ch: ChannelParams, text: str, *args: Any, **kw: Any) -> list[GeoSnapshot]:
    """Run a program to its end (run_task's arguments); the snapshots only."""
    return run_task(ch, text, *args, **kw)[1]


def run_task(
    ch: ChannelParams,
    text: str,
    schedule: Schedule | None = None,
    ack_delay: float = 0.02,
    max_time: float = 120.0,
    inputs: InputFn | None = None,
) -> tuple[GeoTask, list[GeoSnapshot]]:
    """The task and every snapshot, through `liftd simulate`'s own cycle driver; `inputs`
    replaces the simulated PLC."""
    task = GeoTask(ch, text)
    plc = SimPlc(ack_delay) if inputs is None else _InputsPlc(inputs)
    snaps = list(run_cycles(task, plc, schedule or Schedule(), ch.cycle_time, max_time))
    return task, snaps


class _InputsPlc:
    """A PLC whose inputs a test computes from the time and the last snapshot."""

    def __init__(self, fn: InputFn) -> None:
        self.fn = fn

    def inputs(self, last: GeoSnapshot | None, t: float, schedule: Schedule) -> GeoInputs:
        return self.fn(t, last)


def batch_row(s: GeoSnapshot) -> list[float]:
    """A snapshot's row as `batch.run_quiet` lays out a quiet cycle (liftd/cnc/batch.py)."""
    return [
        s.t,
        float(s.line),
        float(s.segment),
        s.v_path,
        s.override,
        float(s.lift_active),
        float(s.lift_suppressed),
        float(s.lift_phase),
        s.lift_vz,
        s.lift_az,
        float(s.state),
        s.override_max,
        *s.positions,
    ]


def positions(snaps: list[GeoSnapshot]) -> np.ndarray:
    return np.array([s.positions for s in snaps])


def fd_ratios(ch: ChannelParams, snaps: list[GeoSnapshot]) -> np.ndarray:
    """max |v|/v_max, |a|/a_max, |j|/j_max per axis by finite differences: shape (3, axes). For
    a path axis over a block transition, the ratio to what the block-transition parameters
    allow there (`transition_allowance`, issue 36): ≤ 1 means within what the CNC allows; the
    lift axis over the whole run."""
    p = positions(snaps)
    dt = ch.cycle_time
    v = np.diff(p, axis=0) / dt
    a = np.diff(v, axis=0) / dt
    j = np.diff(a, axis=0) / dt
    lim = np.array([[ax.v_max, ax.a_max, ax.j_max] for ax in ch.axes]).T
    got = np.array([np.abs(v).max(axis=0), np.abs(a).max(axis=0), np.abs(j).max(axis=0)]) / lim
    seg, tr = fd_split(ch, snaps)
    allow = transition_allowance(ch.axes, dt, ch.slope is not SlopeType.STEP,
                                 ch.corr_v_trans_jerk, ch.mode_trans_jerk)  # fmt: skip
    for i, ax in enumerate(ch.axes):
        if ax.name != ch.lift_axis:
            scale = np.array([1.0, allow[i][0], allow[i][1]])
            got[:, i] = np.maximum(seg[:, i], tr[:, i] / scale)
    return got


def fd_split(ch: ChannelParams, snaps: list[GeoSnapshot]) -> tuple[np.ndarray, np.ndarray]:
    """`fd_ratios` apart over the differences that span no block transition (segments) and over
    those that span one (transitions), as the summary's `limits` reports them."""
    mon = LimitMonitor(len(ch.axes), ch.cycle_time)
    for snap in snaps:
        mon.add(snap.positions, snap.segment)
    lim = np.array([[ax.v_max, ax.a_max, ax.j_max] for ax in ch.axes]).T
    return np.array(mon.segments()) / lim, np.array(mon.transitions()) / lim


def limit_problems(ch: ChannelParams, snaps: list[GeoSnapshot], tol: float = 1e-9) -> list[str]:
    """The path axes' limits: within a segment |v|, |a|, |j| ≤ limit; over a block transition
    |v| ≤ limit and |a|, |j| within what the block-transition parameters allow
    (path/limits.py, `transition_allowance`)."""
    seg, tr = fd_split(ch, snaps)
    allow = transition_allowance(ch.axes, ch.cycle_time, ch.slope is not SlopeType.STEP,
                                 ch.corr_v_trans_jerk, ch.mode_trans_jerk)  # fmt: skip
    out = []
    for i, ax in enumerate(ch.axes):
        if ax.name == ch.lift_axis:
            continue
        for k, name in enumerate("vaj"):
            if seg[k, i] > 1 + tol:
                out.append(f"{ax.name} |{name}| ratio {seg[k, i]:.9f} in a segment")
            top = 1.0 if k == 0 else allow[i][k - 1]
            if tr[k, i] > top * (1 + tol):
                out.append(f"{ax.name} |{name}| ratio {tr[k, i]:.9f} over a transition "
                           f"(allowed {top:.6f})")  # fmt: skip
    return out


def events(snaps: list[GeoSnapshot], name: str) -> list[tuple[float, int, float]]:
    return [(e.t, e.line, e.value) for s in snaps for e in s.events if e.name == name]
