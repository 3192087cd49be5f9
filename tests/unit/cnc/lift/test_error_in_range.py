"""An NC error inside a lift range (issue 37 item 1): Z goes to the maximum lift height and
stays there, and never moves toward the part because of the error (vendor §2.1.1, §2.1.3
case 2, §2.4). The maximum lift height is POS_LIMIT, raised to the start or POS where one lies
beyond it (§2.1.1); for DOWN everything is mirrored. The issue's own program (POS above
POS_LIMIT) is the fidelity test of §2.1.1 / §2.1.3 (tests/fidelity/test_s2_1_3_special_cases.py)."""

from __future__ import annotations

import numpy as np
import pytest

from liftd.cnc.snapshot import ChannelState, GeoInputs, GeoSnapshot
from tests.support.channel import make_channel
from tests.support.closed_loop import fd_ratios, run_task

MM = 1e-3


def _after_error(task, snaps: list[GeoSnapshot], ch) -> np.ndarray:  # type: ignore[no-untyped-def]
    """Z from the cycle the error stopped the program on, 300 cycles past the driver's end
    (the channel stays in error; Z must stay)."""
    t_end = snaps[-1].t
    more = [task.step(GeoInputs(), t_end + (k + 1) * ch.cycle_time) for k in range(300)]
    k = next(i for i, s in enumerate(snaps) if s.state is ChannelState.ERROR)
    return np.array([s.positions[2] for s in snaps[k:] + more])


@pytest.mark.parametrize(
    ("text", "low", "high", "sign"),
    [
        # §2.1.1: with the start beyond POS_LIMIT the limit is raised to the maximum of start
        # and POS: Z starts at 50, goes to POS = 10 at the start (special case 1); after the
        # error it goes back up to 50, not to the ineffective 30
        ("G01 X0 Y0 Z50 F6000\nZ[LIFT_START POS=10 POS_LIMIT=30]\nG01 X100\nX200\n"
         "X250 Q1 oops\nX300\nZ[LIFT_END]\nM30\n", 10, 50, 1.0),
        # DOWN (Advanced Lifting only): a lowering depth of 5 above POS = 2 has no effect; Z
        # goes to 2 at the start and stays there after an error, never back up toward 5
        ("G01 X0 Y0 Z10 F6000\nZ[LIFT_START DOWN POS=2 POS_LIMIT=5]\nG01 X100\nX150 Q1 oops\n"
         "X200\nZ[LIFT_END]\nM30\n", 2, 2, -1.0),
    ],
    ids=["start above the limit", "down"],
)  # fmt: skip
def test_the_limit_without_effect_is_the_height_an_error_holds(
    text: str, low: float, high: float, sign: float
) -> None:
    ch = make_channel()
    task, snaps = run_task(ch, text, max_time=5.0)
    assert snaps[-1].state is ChannelState.ERROR
    lifted = [s.positions[2] for s in snaps if s.lift_active]
    assert min(lifted) == pytest.approx(low * MM, abs=1e-9)  # it went to POS first
    z = sign * _after_error(task, snaps, ch)
    assert np.all(np.diff(z) >= -1e-12)  # never toward the part
    assert z[-1] == pytest.approx(sign * high * MM, abs=1e-9)
    assert fd_ratios(ch, snaps).max() <= 1.0 + 1e-6
