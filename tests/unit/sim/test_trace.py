"""The trace CSV's rows (docs/reference/design.md §3.2): each is its snapshot's fields formatted, whatever the
writer caches, and the finite-difference limit monitor gives numpy's exact maxima."""

from __future__ import annotations

import io

import numpy as np

from liftd.cnc import batch
from liftd.cnc.plc import Schedule
from liftd.cnc.snapshot import ChannelState, GeoSnapshot, LiftPhase
from liftd.settings import load_settings
from liftd.sim.trace import CHUNK, MM, LimitMonitor, TraceWriter
from tests.support.closed_loop import batch_row as row_of
from tests.support.closed_loop import run
from tests.support.paths import REPO

PROGRAM = """%t
N10 G90 G01 X0 Y0 Z1 F6000
N20 Z[LIFT_START POS=1 POS_LIMIT=20]
N30 X40 F12000
N40 X80 Y5
N50 Z[LIFT_END]
N60 X120 F3000
N70 M30
"""


def plain_row(s: GeoSnapshot, n_axes: int) -> str:
    """A row as docs/reference/design.md §3.2 lists its columns, one %-format per row (the reference)."""
    fmt = (
        ",".join(
            [
                "%.6f",
                "%d",
                *["%.9f"] * n_axes,
                "%.9f",
                "%.6f",
                "%d",
                "%d",
                "%d",
                "%.9f",
                "%.9f",
                "%d",
                "%.6f",
            ]
        )
        + "\n"
    )
    return fmt % (
        s.t,
        s.line,
        *[x * MM for x in s.positions],
        s.v_path * MM,
        s.override,
        s.lift_active,
        s.lift_suppressed,
        s.lift_phase,
        s.lift_vz * MM,
        s.lift_az * MM,
        s.state,
        s.override_max,
    )


def test_every_row_is_its_snapshot_formatted() -> None:
    """Through a lift, override steps (0 % included) and a feed hold: the cached row tails
    print what the snapshot holds, -0.0 and 0.0 each as themselves."""
    ch = load_settings(str(REPO / "config" / "liftd.toml")).channel
    schedule = Schedule(
        override=((0.0, 1.0), (0.3, 0.0), (0.5, 1.5), (0.9, 0.6), (1.2, 2.0)),
        feed_hold=((1.6, 1.8),),
    )
    snaps = run(ch, PROGRAM, schedule)
    # the same snapshots once more with the sign of a zero override flipped: the cache holds
    # "0.000000" by then and must not print it for -0.0
    # (and a resting Z's vz and az: -0.0 after 0.0 with the same key)
    flipped = [
        s._replace(
            override=-0.0 if s.override == 0.0 else s.override,
            lift_vz=-0.0 if s.lift_vz == 0.0 else s.lift_vz,
            lift_az=-0.0 if s.lift_az == 0.0 else s.lift_az,
        )
        for s in snaps
    ]
    assert any(s.override == 0.0 for s in snaps) and any(s.lift_vz != 0.0 for s in snaps)
    out = io.StringIO()
    writer = TraceWriter(out, ch.axis_names)
    for s in snaps + flipped:
        writer.write(s)
    writer.flush()
    rows = out.getvalue().splitlines(keepends=True)[1:]
    expected = [plain_row(s, len(ch.axes)) for s in snaps + flipped]
    assert len(rows) == len(expected)
    bad = [(i, r, e) for i, (r, e) in enumerate(zip(rows, expected, strict=True)) if r != e]
    assert bad == []
    assert any(",-0.000000," in r for r in rows)
    assert any(",-0.000000000,-0.000000000," in r for r in rows)


def test_limit_monitor_matches_numpy_over_chunk_borders() -> None:
    rng = np.random.default_rng(7)
    dt = 0.001
    samples = np.cumsum(rng.normal(size=(2 * CHUNK + 11, 3)) * 1e-4, axis=0)
    mon = LimitMonitor(3, dt)
    for row in samples:
        mon.add(tuple(row))
    v = np.diff(samples, axis=0) / dt
    a = np.diff(v, axis=0) / dt
    j = np.diff(a, axis=0) / dt
    max_v, max_a, max_j = mon.result()
    assert np.array_equal(max_v, np.abs(v).max(axis=0))
    assert np.array_equal(max_a, np.abs(a).max(axis=0))
    assert np.array_equal(max_j, np.abs(j).max(axis=0))
    assert mon.samples == len(samples)


def test_rows_of_quiet_cycles_print_as_their_snapshots() -> None:
    """`write_rows` (a batch's rows) prints what `write` prints, whatever it reuses from the
    row before: positions, v_path, line and tail repeated, each zero with either sign, Z
    moving and resting, override 0 % of either sign; mixed with `write` in one file."""
    ch = load_settings(str(REPO / "config" / "liftd.toml")).channel
    schedule = Schedule(override=((0.0, 1.0), (0.3, 0.0), (0.5, 1.5)), feed_hold=((1.6, 1.8),))
    snaps = run(ch, PROGRAM, schedule)
    signs = [
        s._replace(
            override=-0.0 if s.override == 0.0 and k % 2 else s.override,
            positions=tuple(-0.0 if k % 3 == 1 else x for x in s.positions),
            v_path=-0.0 if s.v_path == 0.0 and k % 2 else s.v_path,
            lift_vz=-0.0 if s.lift_vz == 0.0 and k % 2 else s.lift_vz,
            lift_az=-0.0 if s.lift_az == 0.0 and k % 4 < 2 else s.lift_az,
        )
        for k, s in enumerate(snaps)
    ]
    # Z at rest, one tail field changed at a time, each twice (the second from the row before)
    s0 = next(s for s in snaps if s.lift_vz == 0.0 and s.override == 1.0)
    tails = [s0._replace(lift_phase=p) for p in LiftPhase] + [
        s0._replace(lift_active=not s0.lift_active),
        s0._replace(lift_suppressed=not s0.lift_suppressed),
        s0._replace(override_max=0.5),
        s0._replace(override=0.75),
        s0._replace(state=ChannelState.HOLD),
    ]
    seq = snaps + signs + [s for s in tails for s in (s, s, s0)]
    n_axes = len(ch.axes)
    out = io.StringIO()
    writer = TraceWriter(out, ch.axis_names)
    width = batch.row_width(n_axes)
    for k in range(0, len(seq), 37):  # blocks of rows, every fifth block by `write`
        block = seq[k : k + 37]
        if k % 5 == 0:
            for s in block:
                writer.write(s)
        else:
            rows = [x for s in block for x in row_of(s)]
            writer.write_rows(rows, batch.POSITIONS, width)
    writer.flush()
    got = out.getvalue().splitlines(keepends=True)[1:]
    want = [plain_row(s, n_axes) for s in seq]
    assert [(i, g, w) for i, (g, w) in enumerate(zip(got, want, strict=True)) if g != w] == []
    assert len(got) == len(want)
    assert any(",-0.000000000," in r for r in got) and any(",-0.000000," in r for r in got)


def test_limit_monitor_takes_rows_and_tuples_alike() -> None:
    """Samples given as batch rows and as tuples, interleaved over chunk borders: numpy's
    maxima of the whole, split by block transitions as `add` alone splits them."""
    rng = np.random.default_rng(3)
    dt = 0.001
    n = 2 * CHUNK + 501
    samples = np.cumsum(rng.normal(size=(n, 3)) * 1e-4, axis=0)
    segs = np.cumsum(rng.random(n) < 0.01)
    ref, mon = LimitMonitor(3, dt), LimitMonitor(3, dt)
    for row, seg in zip(samples, segs, strict=True):
        ref.add(tuple(row), int(seg))
    width = batch.row_width(3)
    k = 0
    for size in [1, 2, 700, 3, CHUNK + 5, 1, 1, 333, n]:
        block = range(k, min(k + size, n))
        if size % 2:
            for i in block:
                mon.add(tuple(samples[i]), int(segs[i]))
        else:
            rows = [0.0] * (width * len(block))
            for r, i in enumerate(block):
                rows[r * width + 2] = float(segs[i])
                rows[r * width + batch.POSITIONS : (r + 1) * width] = list(samples[i])
            mon.add_rows(rows, batch.POSITIONS, width)
        k = block.stop
    assert mon.samples == ref.samples == n
    for got, want in [(mon.result(), ref.result()), (mon.segments(), ref.segments()),
                      (mon.transitions(), ref.transitions())]:  # fmt: skip
        for g, w in zip(got, want, strict=True):
            assert np.array_equal(g, w)
    v = np.diff(samples, axis=0) / dt
    assert np.array_equal(mon.result()[0], np.abs(v).max(axis=0))
