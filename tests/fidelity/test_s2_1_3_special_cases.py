"""Vendor §2.1.3 "Special cases" (Advanced Lifting)."""

from __future__ import annotations

import pytest

from liftd.cnc.nc import Severity
from tests.fidelity.helpers import MM, decoded, ids, run_z
from tests.support.channel import make_channel


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
