"""Closed-loop helpers: drive a GeoTask with a virtual clock (no sleeps), through the cycle
driver of `liftd simulate` (`run_cycles`), and measure what it did."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from liftd.cnc.geo_task import GeoTask
from liftd.cnc.params import ChannelParams
from liftd.cnc.plc import Schedule, SimPlc
from liftd.cnc.snapshot import GeoInputs, GeoSnapshot
from liftd.sim.simulate import run_cycles

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
