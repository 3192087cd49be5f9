"""Vendor §2.4 "Restrictions and behaviour on errors" (both methods), and where liftd follows
a method's own passage instead (issue 37)."""

from __future__ import annotations

import numpy as np
import pytest

from liftd.cnc.params import LiftMethod
from liftd.cnc.snapshot import ChannelState
from tests.fidelity.helpers import MM, flush_run, on_return
from tests.support.channel import make_channel
from tests.support.closed_loop import run_task

BOTH = [LiftMethod.ADVANCED, LiftMethod.LIFTING]


@pytest.mark.parametrize("method", BOTH)
def test_s2_4_program_end_without_lift_end_acts_as_lift_end(method: LiftMethod) -> None:
    """§2.4: "If the end of the program is reached during LIFT without an explicit LIFT_END,
    the LIFT motion is executed as if LIFT_END were programmed at the end of the program."""
    ch = make_channel(method)
    text = "G01 X0 Y0 Z1 F6000\nZ[LIFT_START POS=5 POS_LIMIT=40]\nG01 X150 F12000\nM30\n"
    task, snaps = run_task(ch, text)
    assert snaps[-1].state is ChannelState.READY
    (rec,) = task.lift.records
    assert rec.peak > 20 * MM and rec.arrival_error <= 1e-9
    assert snaps[-1].positions[2] == pytest.approx(5 * MM, abs=1e-9)


@pytest.mark.parametrize("method", BOTH)
def test_s2_4_an_error_leaves_z_at_the_maximum_lift_height(method: LiftMethod) -> None:
    """§2.4: "If a programming error occurs during the LIFT motion, the LIFT motion is executed
    up to the error location and the axis stays at the maximum lift height (POS_LIMIT)":
    the error comes while Z still rises; it goes on up to POS_LIMIT and stays."""
    ch = make_channel(method)
    text = (
        "G01 X0 Y0 Z1 F6000\nZ[LIFT_START POS=1 POS_LIMIT=60]\nG01 X8 F24000\nQ1 error\n"
        "X300\nZ[LIFT_END]\nM30\n"
    )
    _, snaps = run_task(ch, text, max_time=5.0)
    assert snaps[-1].state is ChannelState.ERROR and snaps[-1].error_line == 4
    k = next(i for i, s in enumerate(snaps) if s.state is ChannelState.ERROR)
    z = np.array([s.positions[2] for s in snaps[k:]])
    assert np.all(np.diff(z) >= -1e-12) and z[-1] == pytest.approx(60 * MM, abs=1e-9)


@pytest.mark.parametrize("method", BOTH)
def test_s2_4_flush_in_a_range_is_decided_by_each_methods_own_passage(method: LiftMethod) -> None:
    """§2.4 says for both methods that a flush "interrupts the current lift motion (an implicit
    LIFT_END and LIFT_START); the programmed target position is reached briefly in the block
    the #FLUSH is programmed in". The method-specific passages disagree: §2.1.3 case 3 (no
    influence on the lift profile) and §2.2.3 case 2 (the first part ends at POS_LIMIT = 40).
    liftd follows those, and they keep Z up: one range, Z at POS_LIMIT at the flush, not at
    POS = 12 (issue 37 item 2)."""
    _, snaps = flush_run(make_channel(method), "N40 X150\nN50 X140\nN60 #FLUSH\nN70 X90\nN80 X40\n")
    assert on_return(snaps, 0.14).positions[2] == pytest.approx(40 * MM, abs=1e-6)
