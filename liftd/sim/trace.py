"""Trace CSV (docs/reference/design.md §3.2) and the running finite-difference limit check.

One row per GEO cycle, streamed: t [s], line, one column per channel axis [mm] (named after the
axis, lower case), v_path [mm/s], override [fraction], lift_active, lift_suppressed (0/1), then
the extra columns lift_phase, vz [mm/s], az [mm/s²], state, override_max.
"""

from __future__ import annotations

import math
from itertools import chain
from typing import Final, TextIO

import numpy as np

from liftd.cnc.snapshot import GeoSnapshot

# Final: C constants of the compiled module (a plain global is a dict lookup at each use)
MM: Final = 1e3  # mm per m (the sim package's one factor for its user-facing mm)
CHUNK: Final = 4096
TAILS_MAX: Final = 4096  # distinct row tails cached (override steps, lift flags)
# a row's columns as `TraceWriter.write` formats them: t, the line, a position or v_path
T_TEXT: Final = "%.6f"
LINE_TEXT: Final = ",%d,"
MM_TEXT: Final = "%.9f,"


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
        # Zero overrides and a vz or az of -0.0 are not cached: 0.0 == -0.0 as keys, but they
        # print differently (each value prints as "%.9f" of itself, whatever came before).
        self.tails: dict[tuple[float, bool, bool, int, int, float], str] = {}
        self.rows: list[str] = []  # the text since the last flush, in pieces
        self.n_rows = 0  # rows in it
        # `write_rows`: the last value of each axis and of v_path, and its text
        self.last_values = [0.0] * (self.n_axes + 1)
        self.last_texts = [""] * (self.n_axes + 1)
        self.last_line = -1.0  # and of the line
        self.line_text = ""
        # the last row's tail, when it came from `tails` (`_row_tail`)
        self.prev_cached = False
        self.prev_ov = self.prev_ov_max = self.prev_active = self.prev_suppressed = 0.0
        self.prev_phase = self.prev_state = 0.0
        self.prev_tail = ""

    def write(self, s: GeoSnapshot) -> None:
        p = s.positions
        head = self.head % (s.t, s.line, *[x * MM for x in p], s.v_path * MM)
        if (
            s.lift_vz == 0.0
            and s.lift_az == 0.0
            and math.copysign(1.0, s.lift_vz) > 0.0  # -0.0 prints as itself: not from the cache
            and math.copysign(1.0, s.lift_az) > 0.0
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
        self.n_rows += 1
        if self.n_rows >= CHUNK:
            self.flush()

    def write_rows(self, rows: list[float], axes_at: int, width: int) -> None:
        """The rows of quiet cycles (liftd/cnc/batch.py: `width` floats a row, the axes from
        column `axes_at`), the same text as `write` of their snapshots. A position or v_path
        equal to the row before's (and not zero: -0.0 prints as itself) reuses its text, and
        so does the tail of a row equal to the one before's while Z rests: in a block at
        constant feed only t and the moving axes are formatted."""
        n_axes = self.n_axes
        last_v, last_s = self.last_values, self.last_texts
        out = self.rows
        for base in range(0, len(rows), width):
            out.append(T_TEXT % rows[base])
            line = rows[base + 1]
            if line != self.last_line:
                self.last_line = line
                self.line_text = LINE_TEXT % line
            out.append(self.line_text)
            for i in range(n_axes + 1):  # the axes, then v_path
                x = rows[base + axes_at + i] if i < n_axes else rows[base + 3]
                if x != last_v[i] or x == 0.0:
                    last_v[i] = x
                    last_s[i] = MM_TEXT % (x * MM)
                out.append(last_s[i])
            out.append(self._row_tail(rows, base))
            self.n_rows += 1
            if self.n_rows >= CHUNK:
                self.flush()

    def _row_tail(self, r: list[float], base: int) -> str:
        """A row's tail (from its override on) as `write` makes it: from the same cache while
        Z rests; the row before's text when its cache key was the same."""
        ov, ov_max = r[base + 4], r[base + 11]
        vz, az = r[base + 8], r[base + 9]
        active, suppressed, phase, state = r[base + 5], r[base + 6], r[base + 7], r[base + 10]
        if (
            vz == 0.0
            and az == 0.0
            and math.copysign(1.0, vz) > 0.0  # -0.0 prints as itself, as in `write`
            and math.copysign(1.0, az) > 0.0
            and ov != 0.0
            and ov_max != 0.0
            and len(self.tails) < TAILS_MAX
        ):
            if (
                self.prev_cached
                and ov == self.prev_ov
                and ov_max == self.prev_ov_max
                and active == self.prev_active
                and suppressed == self.prev_suppressed
                and phase == self.prev_phase
                and state == self.prev_state
            ):
                return self.prev_tail
            key = (ov, active != 0.0, suppressed != 0.0, int(phase), int(state), ov_max)
            tail = self.tails.get(key)
            if tail is None:
                tail = self.tails[key] = self._tail_of(key[:5], ov_max, vz, az)
            self.prev_cached = True
            self.prev_ov, self.prev_ov_max = ov, ov_max
            self.prev_active, self.prev_suppressed = active, suppressed
            self.prev_phase, self.prev_state = phase, state
            self.prev_tail = tail
            return tail
        self.prev_cached = False
        return self._tail_of(
            (ov, active != 0.0, suppressed != 0.0, int(phase), int(state)), ov_max, vz, az
        )

    def _tail_of(
        self, head: tuple[float, bool, bool, int, int], ov_max: float, vz: float, az: float
    ) -> str:
        ov, active, suppressed, phase, state = head
        return self.tail % (ov, active, suppressed, phase, vz * MM, az * MM, state, ov_max)

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
        self.n_rows = 0


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
        # rows that came as arrays (`add_rows`) or were carried over, before `rows`, in order
        self.blocks: list[tuple[np.ndarray, np.ndarray]] = []
        self.pending = 0  # samples in blocks and rows
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
        self.pending += 1
        if self.pending >= CHUNK + 3:
            self._reduce()

    def add_rows(self, rows: list[float], axes_at: int, width: int) -> None:
        """Samples given as flat rows of `width` floats (liftd/cnc/batch.py): the axes from
        column `axes_at`, the segment in column 2."""
        n = len(rows) // width
        pos = np.empty((n, self.n_axes))
        for i in range(self.n_axes):  # by column: the other columns are not converted
            pos[:, i] = rows[axes_at + i :: width]
        self._block_rows()
        self.blocks.append((pos, np.array(rows[2::width])))
        self.samples += n
        self.pending += n
        if self.pending >= CHUNK + 3:
            self._reduce()

    def _block_rows(self) -> None:
        """The tuples of `add` so far as a block."""
        if self.rows:
            n = len(self.rows)
            flat = np.fromiter(chain.from_iterable(self.rows), dtype=float, count=n * self.n_axes)
            self.blocks.append((flat.reshape(n, self.n_axes), np.array(self.segs, dtype=float)))
            self.rows = []
            self.segs = []

    def _fold(self, row: int, diffs: np.ndarray, near: np.ndarray) -> None:
        """Fold |diffs| (one derivative) into the split maxima; `near`: each difference spans a
        transition."""
        mag = np.abs(diffs)
        for kind, mask in ((0, ~near), (1, near)):
            if mask.any():
                np.maximum(self.split[kind, row], mag[mask].max(axis=0),
                           out=self.split[kind, row])  # fmt: skip

    def _reduce(self) -> None:
        self._block_rows()
        blocks = self.blocks
        if len(blocks) == 1:
            rows, seg = blocks[0]
        else:
            rows = np.concatenate([b[0] for b in blocks])
            seg = np.concatenate([b[1] for b in blocks])
        n = rows.shape[0]
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
        self.blocks = [(rows[n - tail :].copy(), seg[n - tail :].copy())]
        self.pending = self.keep = tail

    def result(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if self.pending > self.keep:
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
