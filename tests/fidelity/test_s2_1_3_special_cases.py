"""Vendor §2.1.3 "Special cases" (Advanced Lifting; case 2 for both methods, §2.4)."""

from __future__ import annotations

import numpy as np
import pytest

from liftd.cnc.nc import Severity
from liftd.cnc.params import LiftMethod
from liftd.cnc.snapshot import ChannelState, GeoInputs
from tests.fidelity.helpers import MM, decoded, flush_run, ids, on_return, run_z
from tests.support.channel import make_channel
from tests.support.closed_loop import events, fd_ratios, run_task


def _first_at(z: list[float], value: float) -> int:
    return next(k for k, v in enumerate(z) if abs(v - value) <= 1e-9)


def test_s2_1_3_special_case_1_pos_above_the_limit_goes_to_pos_at_the_start() -> None:
    """§2.1.3 special case 1, the vendor's example: "If the specified lift axis target
    position is outside the limit, the limit has no effect ... the axis is positioned at the
    target position at the start of the lifting motion and not at the end." """
    text = (
        "N10 G01 X0 Y0 Z10 F6000\nN20 Z[LIFT_START POS=40 POS_LIMIT=30]\nN30 X10\nN40 X200\n"
        "N50 X350\nN60 Z[LIFT_END]\nN70 M30\n"
    )
    ch = make_channel()
    assert ids(decoded(ch, text), Severity.ERROR) == []
    snaps, z = run_z(ch, text)
    at_pos = _first_at(z, 40 * MM)
    end = next(k for k, s in enumerate(snaps) if s.positions[0] >= 0.35 - 1e-9)
    assert at_pos < end / 2  # at POS early in the range, not only when the path arrives
    assert max(z) <= 40 * MM + 1e-9


def test_s2_1_3_special_case_1_mirrored_for_down() -> None:
    """§2.1.3 special case 1 with DOWN (issue 15 item 4): POS_LIMIT is the lowering depth; a
    depth above both the start and POS is "outside the limit" the same way, so the limit
    has no effect and Z goes to POS at the start (formerly refused with 990015)."""
    text = (
        "N10 G01 X0 Y0 Z10 F6000\nN20 Z[LIFT_START DOWN POS=5 POS_LIMIT=20]\nN30 X10\n"
        "N40 X200\nN50 X350\nN60 Z[LIFT_END]\nN70 M30\n"
    )
    ch = make_channel()
    r = decoded(ch, text)
    assert ids(r, Severity.ERROR) == []
    snaps, z = run_z(ch, text)
    start = next(k for k, s in enumerate(snaps) if s.lift_active)
    at_pos = _first_at(z, 5 * MM)
    end = next(k for k, s in enumerate(snaps) if s.positions[0] >= 0.35 - 1e-9)
    assert start <= at_pos < end / 2
    in_range = z[start:end]
    assert min(in_range) >= 5 * MM - 1e-9 and max(in_range) <= 10 * MM + 1e-6  # no limit
    assert z[-1] == pytest.approx(5 * MM, abs=1e-9)


@pytest.mark.parametrize("method", [LiftMethod.ADVANCED, LiftMethod.LIFTING])
def test_s2_1_3_special_case_2_syntax_error_positions_at_the_maximum_lift_height(
    method: LiftMethod,
) -> None:
    """§2.1.3 special case 2, the vendor's example (N10 Z10, LIFT_START POS_LIMIT=30, X10,
    X20, X35, a syntax error): "the traversing motion is executed up to the last correctly
    decoded point ... the lift axis is positioned at the maximum lift height at the error
    point" (§2.4, both methods: it "stays at POS_LIMIT")."""
    ch = make_channel(method)
    text = (
        "N10 G01 X0 Y0 Z10 F6000\nN20 Z[LIFT_START POS_LIMIT=30]\nN30 X10\nN40 X20\nN50 X35\n"
        "N100 syntax error\nN560 X50\nN600 Z[LIFT_END]\n"
    )
    _, snaps = run_task(ch, text, max_time=5.0)
    last = snaps[-1]
    assert last.state is ChannelState.ERROR and last.error_line == 6
    assert last.positions[0] == pytest.approx(0.035, abs=1e-12)  # the last correct block
    assert last.positions[2] == pytest.approx(30 * MM, abs=1e-9)
    assert last.lift_vz == 0.0


@pytest.mark.parametrize("method", [LiftMethod.ADVANCED, LiftMethod.LIFTING])
def test_s2_1_3_special_cases_1_and_2_the_raised_limit_is_the_height_an_error_holds(
    method: LiftMethod,
) -> None:
    """§2.1.1: where POS lies beyond POS_LIMIT the limit "is raised to the maximum of start
    and target position"; so the maximum lift height of special case 2 is POS here (issue 37
    item 1: Advanced Lifting brought Z from 40 down to 30 after the error). Decided: the
    method-specific passages (§2.1.1, §2.1.3) over §2.4's "POS_LIMIT", and the workpiece's
    safety: an error never moves Z toward it."""
    ch = make_channel(method)
    text = (
        "N10 G01 X0 Y0 Z10 F6000\nN20 Z[LIFT_START POS=40 POS_LIMIT=30]\nN30 X10\nN40 X20\n"
        "N50 X35\nN100 syntax error\nN600 Z[LIFT_END]\n"
    )
    task, snaps = run_task(ch, text, max_time=5.0)
    assert snaps[-1].state is ChannelState.ERROR
    t_end = snaps[-1].t  # the channel stays in error: 300 more cycles (path-based Lifting's Z
    snaps += [task.step(GeoInputs(), t_end + (k + 1) * ch.cycle_time) for k in range(300)]
    k = next(i for i, s in enumerate(snaps) if s.positions[2] >= 40 * MM - 1e-9)
    z = np.array([s.positions[2] for s in snaps[k:]])  # came down after simulate's driver ended)
    assert np.all(np.abs(z - 40 * MM) <= 1e-9)  # up at POS from early on, and it stays


FLUSHES = ["#FLUSH", "#FLUSH WAIT"]


@pytest.mark.parametrize("flush", FLUSHES)
def test_s2_1_3_special_case_3_a_flush_has_no_influence_on_the_lift_profile(flush: str) -> None:
    """§2.1.3 special case 3 (Advanced Lifting): "emptying the channel (#FLUSH, #FLUSH WAIT)
    can mean that the path has to be stopped if the lift axis can no longer reach the lift
    position in time. Otherwise #FLUSH WAIT has no influence on the lift profile." The same
    range with and without the flush: Z rises once to the same height and lowers once, it is
    up at the flush, not at POS, and the path does not wait there. §2.4 (both methods: "the
    programmed target position is reached briefly in the flush block") disagrees; liftd
    follows the method-specific passage (issue 37 item 2)."""
    ch = make_channel()
    heights = []
    for blocks in (f"N40 X150\nN50 X140\nN60 {flush}\nN70 X90\nN80 X40\n",
                   "N40 X150\nN50 X140\nN70 X90\nN80 X40\n"):  # fmt: skip
        _, snaps = flush_run(ch, blocks)
        lifted = [s for s in snaps if s.lift_active]
        heights.append(np.array([s.positions[2] for s in lifted]))
    z, plain = heights
    assert z.max() == pytest.approx(plain.max()) == pytest.approx(40 * MM)
    _, snaps = flush_run(ch, f"N40 X150\nN50 X140\nN60 {flush}\nN70 X90\nN80 X40\n")
    at_flush = on_return(snaps, 0.14)
    assert at_flush.positions[0] == pytest.approx(0.14, abs=1e-4)
    assert at_flush.positions[2] == pytest.approx(40 * MM, abs=1e-9)
    assert not [s for s in snaps if s.v_path == 0.0 and s.positions[0] == 0.14]  # no wait
    top = int(np.argmax(z))  # one rise, one descent: no landing in between
    assert np.all(np.diff(z[: top + 1]) >= -1e-12) and np.all(np.diff(z[top:]) <= 1e-12)


@pytest.mark.parametrize("flush", FLUSHES)
def test_s2_1_3_special_case_3_the_path_stops_if_z_could_not_reach_pos_in_time(
    flush: str,
) -> None:
    """§2.1.3 special case 3, its first sentence: 2 mm of path after the flush are 20 ms at
    F6000; Z, up at 40 mm, needs about 0.14 s to POS = 12: the path stops at the flush while Z
    descends and leaves as soon as Z can land from there, Z still above POS; never late. The
    wait is the lift's path delay, not a program wait."""
    ch = make_channel()
    task, snaps = flush_run(ch, f"N40 X150\nN60 {flush}\nN70 X148\n")
    rest = [s for s in snaps if s.lift_active and s.v_path == 0.0 and s.positions[0] == 0.15]
    assert len(rest) > 50  # waits for Z
    assert rest[0].positions[2] > 39.9 * MM  # not landed: it starts down when the path stops
    assert rest[-1].positions[2] > 12 * MM + 1e-4  # leaves before Z is down
    assert np.all(np.diff([s.positions[2] for s in rest]) <= 0.0)
    assert fd_ratios(ch, snaps).max() <= 1.0 + 1e-9 and not events(snaps, "lift.late")
    (rec,) = task.lift.records
    assert rec.waits == 0.0
    assert rec.path_delay == pytest.approx(len(rest) * ch.cycle_time, abs=0.03)


def test_s2_1_1_a_waiting_point_after_a_flush_is_still_one() -> None:
    """A dwell after the flush is a waiting point (§2.1.1: Z "moves on to target height"):
    Z is at POS while the path waits there; the flush before it changes nothing of that."""
    ch = make_channel()
    text = (
        "G01 X10 Y10 Z1 F6000\nZ[LIFT_START POS=1 POS_LIMIT=40]\nG01 X100\n#FLUSH\nX200\n"
        "G04 0.2\nX300\nZ[LIFT_END]\nM30\n"
    )
    _, snaps = run_task(ch, text)
    assert snaps[-1].state is ChannelState.READY
    assert min(snaps, key=lambda s: abs(s.positions[0] - 0.1)).positions[2] == pytest.approx(
        40 * MM, abs=1e-9
    )
    dwell = [s for s in snaps if s.lift_active and s.v_path == 0.0 and s.positions[0] == 0.2]
    assert len(dwell) >= 195 and dwell[len(dwell) // 2].positions[2] == pytest.approx(1 * MM)
