"""Vendor §3 "Programming": the lift syntax and its own examples."""

from __future__ import annotations

import pytest

from liftd.cnc.nc import ErrorId, Severity
from liftd.cnc.params import LiftMethod
from tests.fidelity.helpers import MM, decoded, ids, run_z
from tests.support.channel import make_channel

# §3 "Lifting/lowering in an NC block", the vendor's single-row example (Y values filled in):
# POS_LIMIT=300 mm on a machine whose Z ends at 150 mm (issue 15 item 3)
SINGLE_ROW = """N200 G01 X0 Y0 Z40 F6000
N240 X10 Y5 Z[LIFT POS=30 POS_LIMIT=300]
N250 X20 Y10 Z[LIFT POS=20 POS_LIMIT=300]
N260 X30 Y15 Z[LIFT POS=25 POS_LIMIT=300]
N270 X40 Y20 Z[LIFT POS=30 POS_LIMIT=300]
N280 X50 Y25 Z[LIFT POS=30 POS_LIMIT=300]
N290 M30
"""


@pytest.mark.parametrize("method", [LiftMethod.ADVANCED, LiftMethod.LIFTING])
def test_s3_single_row_example_runs_with_the_limit_at_the_software_limit(
    method: LiftMethod,
) -> None:
    """§3: "POS_LIMIT=.. Maximum lifting height": a height above the positive software limit
    cannot be reached; liftd lifts at most to the limit (min(POS_LIMIT, limit)) and warns
    once per lift command, instead of refusing the vendor's own example with 50041."""
    ch = make_channel(method=method)
    r = decoded(ch, SINGLE_ROW)
    assert ids(r, Severity.ERROR) == []
    assert ids(r, Severity.WARNING) == [(ErrorId.LIFT_LIMIT_CLAMPED, n) for n in range(2, 7)]
    starts = [b.lift_start for b in r.blocks if b.lift_start is not None]
    assert [s.pos_limit for s in starts] == [pytest.approx(150 * MM)] * 5
    assert [s.limit_programmed for s in starts] == [pytest.approx(300 * MM)] * 5
    _, z = run_z(ch, SINGLE_ROW)
    assert max(z) <= 150 * MM + 1e-9
    assert z[-1] == pytest.approx(30 * MM, abs=1e-9)


def test_s3_pos_beyond_the_software_limit_stays_an_error() -> None:
    """§3 "POS=.. Target position": a target beyond the software limit is still 50041."""
    r = decoded(make_channel(), "G01 X0 Y0 Z40 F6000\nX10 Z[LIFT POS=160 POS_LIMIT=300]\nM30\n")
    assert ids(r, Severity.ERROR) == [(ErrorId.SW_LIMIT_POS, 2)]


def test_s3_down_lowers_towards_the_negative_limit_and_is_held_there() -> None:
    """§3 "DOWN: the motion is in the direction of the negative software limit switch";
    POS_LIMIT is then the lowering depth, and a depth beyond the negative software limit
    (-5 mm here) is held at the limit like a height above the positive one."""
    text = "G01 X0 Y0 Z10 F6000\nZ[LIFT_START DOWN POS=10 POS_LIMIT=-50]\nX100\nZ[LIFT_END]\nM30\n"
    ch = make_channel()
    r = decoded(ch, text)
    assert ids(r, Severity.ERROR) == []
    assert ids(r, Severity.WARNING) == [(ErrorId.LIFT_LIMIT_CLAMPED, 2)]
    (start,) = [b.lift_start for b in r.blocks if b.lift_start is not None]
    assert start.pos_limit == pytest.approx(-5 * MM)
    _, z = run_z(ch, text)
    assert min(z) >= -5 * MM - 1e-9
    assert min(z) < 0.0  # it does lower
