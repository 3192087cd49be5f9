"""#FLUSH / #FLUSH WAIT inside an Advanced Lifting range (issue 37 item 2): the flush is no
waiting point of the lift (vendor §2.1.3 case 3): Z neither lands at POS there nor starts
again after it; the path stops there as at any flush, and waits there only if Z could not
reach POS from there in time. Path-based Lifting keeps its own passage (§2.2.3 case 2, Z at
POS_LIMIT at the flush: test_path_based.py)."""

from __future__ import annotations

import numpy as np
import pytest

from liftd.cnc.snapshot import ChannelState, GeoSnapshot
from tests.support.channel import make_channel
from tests.support.closed_loop import events, fd_ratios, run_task

MM = 1e-3
TOL = 1 + 1e-9
FLUSHES = ["#FLUSH", "#FLUSH WAIT"]


def _at_flush(snaps: list[GeoSnapshot], x: float) -> list[GeoSnapshot]:
    """The cycles the path rests at X = x inside the range."""
    return [s for s in snaps if s.lift_active and s.v_path == 0.0 and s.positions[0] == x]


def _passing(snaps: list[GeoSnapshot], x: float, back: bool = False) -> GeoSnapshot:
    """The cycle nearest to the path's stop at X = x (a flush's stop lasts no cycle); `back`:
    on the way back, after the path's largest X."""
    k = int(np.argmax([s.positions[0] for s in snaps])) if back else 0
    return min(snaps[k:], key=lambda s: abs(s.positions[0] - x))


def _check(ch, task, snaps) -> None:  # type: ignore[no-untyped-def]
    assert snaps[-1].state is ChannelState.READY
    assert fd_ratios(ch, snaps).max() <= TOL
    assert not events(snaps, "lift.late")
    (rec,) = task.lift.records  # one range: no implicit LIFT_END + LIFT_START
    assert rec.arrival_error <= 1e-9


@pytest.mark.parametrize("flush", FLUSHES)
def test_a_flush_mid_range_does_not_land_z(flush: str) -> None:
    """The vendor's shape (§2.2.3 case 2's program, POS=12 POS_LIMIT=40), with 100 mm after
    the flush: Z is at POS_LIMIT when the path stops at the flush (it came down to POS = 12
    there before), and the lift is one rise and one descent."""
    ch = make_channel()
    text = (
        "N10 G01 X10 Y10 F6000\nN20 X40 Z2\nN30 Z[LIFT_START POS=12 POS_LIMIT=40]\nN40 X150\n"
        f"N50 X140\nN60 {flush}\nN70 X90\nN80 X40\nN90 Z[LIFT_END]\nM30\n"
    )
    task, snaps = run_task(ch, text)
    _check(ch, task, snaps)
    flushed = _passing(snaps, 0.14, back=True)
    assert flushed.positions[0] == pytest.approx(0.14, abs=1e-4)
    assert flushed.positions[2] == pytest.approx(40 * MM, abs=1e-9)
    assert not _at_flush(snaps, 0.14)  # the flush's own stop: the path does not wait for Z
    z = np.array([s.positions[2] for s in snaps if s.lift_active])
    top = int(np.argmax(z))
    assert np.all(np.diff(z[: top + 1]) >= -1e-12) and np.all(np.diff(z[top:]) <= 1e-12)


@pytest.mark.parametrize("flush", FLUSHES)
def test_the_path_waits_at_the_flush_when_z_could_not_land_from_there(flush: str) -> None:
    """2 mm after the flush (20 ms at F6000) while Z, up at POS_LIMIT = 40, needs about
    0.14 s to POS = 12: the path waits at the flush (§2.1.3 case 3, "the path may have to be
    stopped") while Z descends, and leaves as soon as Z lands in time from there; Z is
    still above POS when it leaves. Counted as the lift's path delay."""
    ch = make_channel()
    text = (
        "N10 G01 X10 Y10 F6000\nN20 X40 Z2\nN30 Z[LIFT_START POS=12 POS_LIMIT=40]\nN40 X150\n"
        f"N60 {flush}\nN70 X148\nN90 Z[LIFT_END]\nN100 X100\nM30\n"
    )
    task, snaps = run_task(ch, text)
    _check(ch, task, snaps)
    rest = _at_flush(snaps, 0.15)
    assert len(rest) > 50  # waits for Z
    assert rest[0].positions[2] > 39.9 * MM  # not landed: it starts down when the path stops
    assert rest[-1].positions[2] > 12 * MM + 1e-4  # leaves before Z is down
    z = np.array([s.positions[2] for s in rest])
    assert np.all(np.diff(z) <= 0.0)
    (rec,) = task.lift.records
    assert rec.waits == 0.0 and rec.path_delay == pytest.approx(len(rest) * ch.cycle_time,
                                                                abs=0.03)  # fmt: skip


def test_a_waiting_point_after_the_flush_is_still_the_lifts_horizon() -> None:
    """A dwell after the flush is a waiting point (vendor §2.1.1): Z is at POS there, the
    flush before it changes nothing of that."""
    ch = make_channel()
    text = (
        "G01 X10 Y10 Z1 F6000\nZ[LIFT_START POS=1 POS_LIMIT=40]\nG01 X100\n#FLUSH\nX200\n"
        "G04 0.2\nX300\nZ[LIFT_END]\nM30\n"
    )
    task, snaps = run_task(ch, text)
    _check(ch, task, snaps)
    assert _passing(snaps, 0.1).positions[2] == pytest.approx(40 * MM, abs=1e-9)
    dwell = _at_flush(snaps, 0.2)
    assert len(dwell) >= 195 and dwell[len(dwell) // 2].positions[2] == pytest.approx(1 * MM)
