"""The trace CSV's rows (docs/reference/design.md §3.2): each is its snapshot's fields formatted, whatever the
writer caches, and the finite-difference limit monitor gives numpy's exact maxima."""

from __future__ import annotations

import io

import numpy as np

from liftd.cnc.plc import Schedule
from liftd.cnc.snapshot import GeoSnapshot
from liftd.settings import load_settings
from liftd.sim.trace import CHUNK, MM, LimitMonitor, TraceWriter
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
    flipped = [s._replace(override=-0.0) if s.override == 0.0 else s for s in snaps]
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
