"""Closed-loop helpers: drive a GeoTask with a virtual clock in a plain loop (no sleeps)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from liftd.cnc.geo_task import GeoTask
from liftd.cnc.params import ChannelParams
from liftd.cnc.plc import Schedule, SimPlc
from liftd.cnc.snapshot import ChannelState, GeoInputs, GeoSnapshot

InputFn = Callable[[float, GeoSnapshot | None], GeoInputs]


def run(
    ch: ChannelParams,
    text: str,
    schedule: Schedule | None = None,
    ack_delay: float = 0.02,
    max_time: float = 120.0,
    inputs: InputFn | None = None,
) -> list[GeoSnapshot]:
    """Run a program to its end; the simulated PLC acknowledges M functions after ack_delay."""
    return run_task(ch, text, schedule, ack_delay, max_time, inputs)[1]


def run_task(
    ch: ChannelParams,
    text: str,
    schedule: Schedule | None = None,
    ack_delay: float = 0.02,
    max_time: float = 120.0,
    inputs: InputFn | None = None,
) -> tuple[GeoTask, list[GeoSnapshot]]:
    task = GeoTask(ch, text)
    plc = SimPlc(ack_delay)
    sched = schedule or Schedule()
    out: list[GeoSnapshot] = []
    last: GeoSnapshot | None = None
    dt = ch.cycle_time
    for k in range(1, round(max_time / dt) + 1):
        t = k * dt
        inp = inputs(t, last) if inputs is not None else plc.inputs(last, t, sched)
        last = task.step(inp, t)
        out.append(last)
        if last.state in (ChannelState.READY, ChannelState.ERROR) and task.runs:
            break
    return task, out


def positions(snaps: list[GeoSnapshot]) -> np.ndarray:
    return np.array([s.positions for s in snaps])


def fd_ratios(ch: ChannelParams, snaps: list[GeoSnapshot]) -> np.ndarray:
    """max |v|/v_max, |a|/a_max, |j|/j_max per axis by finite differences: shape (3, axes)."""
    p = positions(snaps)
    dt = ch.cycle_time
    v = np.diff(p, axis=0) / dt
    a = np.diff(v, axis=0) / dt
    j = np.diff(a, axis=0) / dt
    lim = np.array([[ax.v_max, ax.a_max, ax.j_max] for ax in ch.axes]).T
    got = np.array([np.abs(v).max(axis=0), np.abs(a).max(axis=0), np.abs(j).max(axis=0)])
    return got / lim


def events(snaps: list[GeoSnapshot], name: str) -> list[tuple[float, int, float]]:
    return [(e.t, e.line, e.value) for s in snaps for e in s.events if e.name == name]
