"""The lift guard: every set-point checked, ruckig refusals reported as events."""

from __future__ import annotations

import pytest

from liftd.cnc.lift.guard import LiftGuard
from liftd.cnc.lift.profile import LiftProfiles, ProfileError
from tests.support.channel import make_channel
from tests.support.closed_loop import events, fd_ratios, run_task


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


def test_ruckig_failure_inside_a_lift_falls_back_safely(monkeypatch: pytest.MonkeyPatch) -> None:
    ch = make_channel()
    calls = {"n": 0}
    real = LiftProfiles.to_rest

    def flaky(self: LiftProfiles, *args: float, **kw: float | None) -> object:
        calls["n"] += 1
        if 120 <= calls["n"] < 124:
            raise ProfileError("injected")
        return real(self, *args, **kw)

    monkeypatch.setattr(LiftProfiles, "to_rest", flaky)
    text = "G01 X10 Y10 Z1 F6000\nZ[LIFT_START POS=1 POS_LIMIT=60]\nG01 X300 F24000\nZ[LIFT_END]\nM30\n"
    task, snaps = run_task(ch, text)
    assert events(snaps, "lift.fallback"), "the guard must report the fallback"
    assert not events(snaps, "lift.guard_clamped") and not events(snaps, "lift.late")
    assert max(s.positions[2] for s in snaps) <= 0.06 + 1e-7
    assert fd_ratios(ch, snaps).max() <= 1 + 1e-9
    assert task.lift.records[0].arrival_error <= 1e-6
