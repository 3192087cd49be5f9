"""Trace CSV (docs/reference/design.md §3.2) and the running finite-difference limit check.

One row per GEO cycle, streamed: t [s], line, one column per channel axis [mm] (named after the
axis, lower case), v_path [mm/s], override [fraction], lift_active, lift_suppressed (0/1), then
the extra columns lift_phase, vz [mm/s], az [mm/s²], state, override_max.
"""

from __future__ import annotations

from itertools import chain
from typing import TextIO

import numpy as np

from liftd.cnc.snapshot import GeoSnapshot

MM = 1e3  # mm per m (the sim package's one factor for its user-facing mm)
CHUNK = 4096
TAILS_MAX = 4096  # distinct row tails cached (override steps, lift flags)


def header(axis_names: tuple[str, ...]) -> list[str]:
    return [
        "t",
        "line",
        *(n.lower() for n in axis_names),
        "v_path",
        "override",
        "lift_active",
        "lift_suppressed",
        "lift_phase",
        "vz",
        "az",
        "state",
        "override_max",
    ]


class TraceWriter:
    """Streams snapshots to a CSV file; rows are %-formatted, the tail of a row while Z rests
    from a cache."""

    def __init__(self, out: TextIO, axis_names: tuple[str, ...]) -> None:
        self.out = out
        self.n_axes = len(axis_names)
        out.write(",".join(header(axis_names)) + "\n")
        # 9 decimals in mm (1 pm): finite differences of the CSV keep the jerk to ~1e-3 m/s³
        head = ["%.6f", "%d", *(["%.9f"] * self.n_axes), "%.9f"]
        tail = ["%.6f", "%d", "%d", "%d", "%.9f", "%.9f", "%d", "%.6f"]
        self.head = ",".join(head) + ","
        self.tail = ",".join(tail) + "\n"
        # The tail of a row while Z does not move (vz = az = 0) takes few values: formatted once
        # each (~1 µs of every row otherwise); bounded by the (override, flags, state) seen.
        # Zero overrides are not cached: 0.0 == -0.0 as keys, but they print differently.
        self.tails: dict[tuple[float, bool, bool, int, int, float], str] = {}
        self.rows: list[str] = []

    def write(self, s: GeoSnapshot) -> None:
        p = s.positions
        head = self.head % (s.t, s.line, *[x * MM for x in p], s.v_path * MM)
        if (
            s.lift_vz == 0.0
            and s.lift_az == 0.0
            and s.override != 0.0
            and s.override_max != 0.0
            and len(self.tails) < TAILS_MAX
        ):
            key = (s.override, s.lift_active, s.lift_suppressed, s.lift_phase, s.state,
                   s.override_max)  # fmt: skip
            tail = self.tails.get(key)
            if tail is None:
                tail = self.tails[key] = self._tail(s)
        else:
            tail = self._tail(s)
        self.rows.append(head + tail)
        if len(self.rows) >= CHUNK:
            self.flush()

    def _tail(self, s: GeoSnapshot) -> str:
        return self.tail % (
            s.override,
            s.lift_active,
            s.lift_suppressed,
            s.lift_phase,
            s.lift_vz * MM,
            s.lift_az * MM,
            s.state,
            s.override_max,
        )

    def flush(self) -> None:
        self.out.write("".join(self.rows))
        self.rows.clear()


class LimitMonitor:
    """Maximum |v|, |a|, |j| of every axis by finite differences of the sampled positions over
    the whole run, in constant memory (chunks of samples, numpy); and the same apart over the
    differences that span a block transition (the samples on both sides of a change of the
    active segment) and over all the others (`transitions`, `segments`): a transition may step
    an axis' acceleration as far as the CNC's block-transition parameters allow (issue 36;
    path/limits.py), a segment keeps within the axis' limits."""

    def __init__(self, n_axes: int, dt: float) -> None:
        self.dt = dt
        self.n_axes = n_axes
        # the position tuples of a chunk as they come (the snapshot's own): appending the
        # reference and one numpy conversion per chunk cost ~115 ns a sample, copying the floats
        # into an array ~185 (array.extend parses each item); the first `keep` are carried over
        # from the last chunk (max is idempotent)
        self.rows: list[tuple[float, ...]] = []
        self.segs: list[int] = []
        self.keep = 0
        self.max_v = np.zeros(n_axes)
        self.max_a = np.zeros(n_axes)
        self.max_j = np.zeros(n_axes)
        # [segments, transitions] × [v, a, j]
        self.split = np.zeros((2, 3, n_axes))
        self.samples = 0

    def add(self, positions: tuple[float, ...], segment: int = 0) -> None:
        rows = self.rows
        rows.append(positions)
        self.segs.append(segment)
        self.samples += 1
        if len(rows) == CHUNK + 3:
            self._reduce()

    def _fold(self, row: int, diffs: np.ndarray, near: np.ndarray) -> None:
        """Fold |diffs| (one derivative) into the split maxima; `near`: each difference spans a
        transition."""
        mag = np.abs(diffs)
        for kind, mask in ((0, ~near), (1, near)):
            if mask.any():
                np.maximum(self.split[kind, row], mag[mask].max(axis=0),
                           out=self.split[kind, row])  # fmt: skip

    def _reduce(self) -> None:
        n = len(self.rows)
        flat = np.fromiter(chain.from_iterable(self.rows), dtype=float, count=n * self.n_axes)
        rows = flat.reshape(n, self.n_axes)
        seg = np.array(self.segs)
        dt = self.dt
        if n >= 2:
            cross = seg[1:] != seg[:-1]  # a block boundary lies between samples k and k + 1
            v = np.diff(rows, axis=0) / dt
            np.maximum(self.max_v, np.abs(v).max(axis=0), out=self.max_v)
            self._fold(0, v, cross)
            if n >= 3:
                a = np.diff(v, axis=0) / dt
                np.maximum(self.max_a, np.abs(a).max(axis=0), out=self.max_a)
                near_a = cross[1:] | cross[:-1]
                self._fold(1, a, near_a)
                if n >= 4:
                    j = np.diff(a, axis=0) / dt
                    np.maximum(self.max_j, np.abs(j).max(axis=0), out=self.max_j)
                    self._fold(2, j, near_a[1:] | near_a[:-1])
        tail = min(3, n)
        self.rows = self.rows[n - tail :]
        self.segs = self.segs[n - tail :]
        self.keep = tail

    def result(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if len(self.rows) > self.keep:
            self._reduce()
        return self.max_v, self.max_a, self.max_j

    def segments(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The maxima over the differences that span no block transition."""
        self.result()
        return self.split[0, 0], self.split[0, 1], self.split[0, 2]

    def transitions(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The maxima over the differences that span a block transition."""
        self.result()
        return self.split[1, 0], self.split[1, 1], self.split[1, 2]
