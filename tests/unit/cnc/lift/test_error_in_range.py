"""An NC error inside a lift range (issue 37 item 1): Z goes to the maximum lift height and
stays there, and never moves toward the part because of the error (vendor §2.1.1, §2.1.3
case 2, §2.4). The maximum lift height is POS_LIMIT, raised to the start or POS where one lies
beyond it (§2.1.1); for DOWN everything is mirrored."""

from __future__ import annotations

import numpy as np
import pytest

from liftd.cnc.params import LiftMethod
from liftd.cnc.snapshot import ChannelState, GeoInputs, GeoSnapshot
from tests.support.channel import make_channel
from tests.support.closed_loop import fd_ratios, run_task

MM = 1e-3
BOTH = [LiftMethod.ADVANCED, LiftMethod.LIFTING]


def _after_error(task, snaps: list[GeoSnapshot], ch) -> np.ndarray:  # type: ignore[no-untyped-def]
    """Z from the cycle the error stopped the program on, 300 cycles past the driver's end
    (the channel stays in error; Z must stay)."""
    t_end = snaps[-1].t
    more = [task.step(GeoInputs(), t_end + (k + 1) * ch.cycle_time) for k in range(300)]
    k = next(i for i, s in enumerate(snaps) if s.state is ChannelState.ERROR)
    return np.array([s.positions[2] for s in snaps[k:] + more])


@pytest.mark.parametrize("method", BOTH)
def test_pos_above_pos_limit_holds_pos_after_an_error(method: LiftMethod) -> None:
    """The issue's program: Z goes up to POS = 40 at the start (the limit of 30 has no
    effect, §2.1.3 case 1); a syntax error two blocks later must leave Z at 40. Before the
    fix Advanced Lifting brought Z down to 30 after the error."""
    ch = make_channel(method)
    text = (
        "N10 G01 X0 Y0 Z10 F6000\nN20 Z[LIFT_START POS=40 POS_LIMIT=30]\nN30 X10\nN40 X20\n"
        "N50 X35 ?!\nN60 X50\nN70 Z[LIFT_END]\nM30\n"
    )
    task, snaps = run_task(ch, text, max_time=5.0)
    assert snaps[-1].state is ChannelState.ERROR and snaps[-1].error_line == 5
    z = _after_error(task, snaps, ch)
    assert np.all(np.diff(z) >= -1e-12)  # never toward the part
    assert z[-1] == pytest.approx(40 * MM, abs=1e-9)
    assert fd_ratios(ch, snaps)[:, 2].max() <= 1.0 + 1e-6 or method is LiftMethod.LIFTING


def test_start_above_pos_limit_is_the_height_an_error_holds() -> None:
    """§2.1.1: with the start beyond POS_LIMIT the limit is raised to the maximum of start and
    POS. Z starts at 50, goes to POS = 10 at the start (special case 1); after the error it
    goes back up to 50, the maximum lift height of this range, not to the ineffective 30."""
    ch = make_channel()
    text = (
        "G01 X0 Y0 Z50 F6000\nZ[LIFT_START POS=10 POS_LIMIT=30]\nG01 X100\nX200\n"
        "X250 Q1 oops\nX300\nZ[LIFT_END]\nM30\n"
    )
    task, snaps = run_task(ch, text, max_time=5.0)
    assert snaps[-1].state is ChannelState.ERROR
    low = min(s.positions[2] for s in snaps if s.lift_active)
    assert low == pytest.approx(10 * MM, abs=1e-9)  # it did go to POS first
    z = _after_error(task, snaps, ch)
    assert np.all(np.diff(z) >= -1e-12)
    assert z[-1] == pytest.approx(50 * MM, abs=1e-9)
    assert fd_ratios(ch, snaps).max() <= 1.0 + 1e-6


def test_down_mirrors_it() -> None:
    """DOWN (Advanced Lifting only): a lowering depth of 5 above POS = 2 has no effect; Z goes
    to 2 at the start and stays there after an error (never back up toward 5)."""
    ch = make_channel()
    text = (
        "G01 X0 Y0 Z10 F6000\nZ[LIFT_START DOWN POS=2 POS_LIMIT=5]\nG01 X100\nX150 Q1 oops\n"
        "X200\nZ[LIFT_END]\nM30\n"
    )
    task, snaps = run_task(ch, text, max_time=5.0)
    assert snaps[-1].state is ChannelState.ERROR
    z = _after_error(task, snaps, ch)
    assert np.all(np.diff(z) <= 1e-12)
    assert z[-1] == pytest.approx(2 * MM, abs=1e-9)


@pytest.mark.parametrize("method", BOTH)
def test_an_error_before_z_reached_the_limit_still_rises_to_it(method: LiftMethod) -> None:
    """The ordinary case stays: POS below POS_LIMIT, the error comes while Z rises; Z goes on
    to POS_LIMIT and stays."""
    ch = make_channel(method)
    text = (
        "G01 X10 Y10 Z1 F6000\nZ[LIFT_START POS=1 POS_LIMIT=60]\nG01 X14 F24000\nQ1 oops\n"
        "X300\nZ[LIFT_END]\nM30\n"
    )
    task, snaps = run_task(ch, text, max_time=5.0)
    z = _after_error(task, snaps, ch)
    assert np.all(np.diff(z) >= -1e-12)
    assert z[-1] == pytest.approx(60 * MM, abs=1e-9)
