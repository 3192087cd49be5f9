"""The lift guard: every set-point checked, ruckig refusals reported as events."""

from __future__ import annotations

import json

import pytest

from liftd.cnc.lift.guard import LiftGuard
from tests.support.channel import make_channel
from tests.support.pure_core import PureCore


def test_guard_bounds_and_clamp() -> None:
    g = LiftGuard(make_channel().axis("Z"))
    g.arm(0.001, 0.002, 0.04, down=False, direct=False, stop_margin=0.0)
    assert g.check(0.03, 0) == (0.03, [])
    z, findings = g.check(0.0405, 0)
    assert z == pytest.approx(0.04 + 1e-7) and findings[0].name == "lift.guard_clamped"
    _, findings = g.check(0.02, 2)
    assert [f.name for f in findings] == ["lift.fallback"]
    g.arm(0.001, 0.02, 0.0, down=True, direct=False, stop_margin=0.0)  # DOWN: to POS_LIMIT 0
    assert g.check(0.0, 2)[1] == [] and g.check(0.021, 2)[1][0].name == "lift.guard_clamped"


def test_ruckig_failure_inside_a_lift_falls_back_safely(pure_core: PureCore) -> None:
    """Ruckig refuses four profiles in a row in the middle of a lift: the guard reports the
    fallback, Z stays within POS_LIMIT and the axis limits and still lands. The fault is
    patched into `LiftProfiles.to_rest`, which only the core run as Python allows."""
    code = """
import json
from liftd.cnc.lift.profile import LiftProfiles, ProfileError
from tests.support.channel import make_channel
from tests.support.closed_loop import events, fd_ratios, run_task

calls = {"n": 0}
real = LiftProfiles.to_rest
def flaky(self, *args, **kw):
    calls["n"] += 1
    if 120 <= calls["n"] < 124:
        raise ProfileError("injected")
    return real(self, *args, **kw)
LiftProfiles.to_rest = flaky
ch = make_channel()
text = "G01 X10 Y10 Z1 F6000\\nZ[LIFT_START POS=1 POS_LIMIT=60]\\nG01 X300 F24000\\nZ[LIFT_END]\\nM30\\n"
task, snaps = run_task(ch, text)
print(json.dumps({
    "calls": calls["n"],
    "fallback": len(events(snaps, "lift.fallback")),
    "clamped": len(events(snaps, "lift.guard_clamped")),
    "late": len(events(snaps, "lift.late")),
    "z_max": max(s.positions[2] for s in snaps),
    "fd_max": float(fd_ratios(ch, snaps).max()),
    "arrival_error": task.lift.records[0].arrival_error,
}))
"""
    res = json.loads(pure_core.run(code))
    assert res["calls"] >= 124, "the fault must be injected"
    assert res["fallback"] >= 1, "the guard must report the fallback"
    assert res["clamped"] == 0 and res["late"] == 0
    assert res["z_max"] <= 0.06 + 1e-7
    assert res["fd_max"] <= 1 + 1e-9
    assert res["arrival_error"] <= 1e-6
