"""The Advanced-Lifting set-point generator alone, against a path at constant feed.

Reference values: docs/reference/lift-algorithm.md §4 (closed form and LP oracle, limits
v 0.8 m/s, a 10 m/s², j 500 m/s³, POS_LIMIT 50 mm)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from liftd.cnc.lift.advanced import AdvancedLift
from liftd.cnc.lift.profile import LiftProfiles
from liftd.cnc.snapshot import LiftPhase
from tests.support.pure_core import PureCore

DT = 1e-3
V, A, J = 0.8, 10.0, 500.0


def fly(
    t_path: float,
    target: float = 0.0,
    limit: float = 0.05,
    z0: float = 0.0,
    down: bool = False,
    ov_steps: tuple[tuple[float, float], ...] = (),
    limits: tuple[float, float, float] = (V, A, J),
    t_end: float | None = None,
) -> tuple[np.ndarray, np.ndarray, AdvancedLift]:
    """Path of length t_path (at 100 %) with override steps (t, factor); returns (t, z)."""
    gen = AdvancedLift(LiftProfiles(*limits), DT)
    gen.start(0.0, z0, 0.0, 0.0, target, limit, down, direct=False)
    s_left = t_path  # path "time units" left at 100 %
    ov = 1.0
    ts, zs = [0.0], [z0]
    t = 0.0
    horizon = t_end if t_end is not None else 3 * t_path + 1
    while t < horizon:
        for t_step, factor in ov_steps:
            if abs(t - t_step) < DT / 2:
                ov = factor
        t_rem = s_left / ov if ov > 0 else math.inf
        t += DT
        gen.step(t, t_rem)
        s_left = max(0.0, s_left - DT * ov)
        ts.append(t)
        zs.append(gen.z)
        if s_left == 0.0 and gen.done and t_end is None:
            break
    return np.array(ts), np.array(zs), gen


def fd(z: np.ndarray) -> tuple[float, float, float]:
    v = np.diff(z) / DT
    a = np.diff(v) / DT
    j = np.diff(a) / DT
    return float(abs(v).max() / V), float(abs(a).max() / A), float(abs(j).max() / J)


@pytest.mark.parametrize(
    ("t_path", "peak_mm"),
    [(0.10, 3.0484), (0.20, 19.084), (0.30, 47.834), (0.50, 50.0)],
)
def test_peak_matches_the_oracle(t_path: float, peak_mm: float) -> None:
    t, z, gen = fly(t_path)
    assert z.max() * 1e3 >= peak_mm * 0.995
    assert z.max() <= 0.05 + 1e-7
    assert abs(z[-1]) <= 1e-9 and gen.done


def test_closed_form_case_c4_mean_clearance() -> None:
    # v_p solves v²/a + v·a/j = d; t_r = 2(v_p/a + a/j); mean = d (T − t_r) / T
    d, T = 0.05, 0.5
    v_p = (-(A * A / J) + math.sqrt((A * A / J) ** 2 + 4 * d * A)) / 2
    t_r = 2 * (v_p / A + A / J)
    t, z, _ = fly(T)
    mask = t <= T + 1e-12
    mean = np.trapezoid(z[mask], t[mask]) / T
    assert mean == pytest.approx(d * (T - t_r) / T, rel=2e-3)


def test_lands_exactly_when_the_path_arrives() -> None:
    t, z, gen = fly(0.37, target=0.02, limit=0.06)
    k = int(round(0.37 / DT))
    assert abs(z[k] - 0.02) <= 1e-6  # at LIFT_END
    assert np.all(np.abs(z[k:] - 0.02) <= 1e-9)
    assert max(fd(z)) <= 1 + 1e-9


def test_down_is_mirrored() -> None:
    t_up, z_up, _ = fly(0.25, target=0.01, limit=0.03, z0=0.0)
    t_dn, z_dn, _ = fly(0.25, target=-0.01, limit=-0.03, z0=0.0, down=True)
    assert z_dn == pytest.approx(-z_up, abs=1e-12)
    assert z_dn.min() >= -0.03 - 1e-7


def test_infinite_remaining_time_rises_to_the_limit_and_holds() -> None:
    gen = AdvancedLift(LiftProfiles(V, A, J), DT)
    gen.start(0.0, 0.0, 0.0, 0.0, 0.0, 0.05, False, direct=False)
    for k in range(1, 600):
        gen.step(k * DT, math.inf)
    assert gen.z == pytest.approx(0.05, abs=1e-9) and gen.phase is LiftPhase.UP


def test_override_lowered_while_descending_rises_again_and_still_lands() -> None:
    t, z, gen = fly(0.3, ov_steps=((0.24, 0.5),))
    k_switch = int(round(0.24 / DT))
    assert np.all(np.diff(z[k_switch - 20 : k_switch]) < 0)  # it was descending
    assert (np.diff(z[k_switch:]) > 1e-9).any()  # then brakes and rises again
    k_end = int(round((0.24 + 0.06 / 0.5) / DT))  # the path now arrives at 0.36 s
    assert abs(z[k_end]) <= 1e-6 and abs(z[k_end - 20]) > 1e-4  # lands then, not earlier
    assert max(fd(z)) <= 1 + 1e-9


def test_direct_move_when_no_time() -> None:
    gen = AdvancedLift(LiftProfiles(V, A, J), DT)
    gen.start(0.0, 0.0, 0.0, 0.0, 0.04, 0.03, False, direct=True)
    for k in range(1, 400):
        gen.step(k * DT, 0.0)
    assert gen.done and gen.z == 0.04
    assert gen.landed == pytest.approx(
        LiftProfiles(V, A, J).to_rest(0.0, 0.0, 0.0, 0.04).duration, abs=1e-12
    )


def test_ruckig_failure_falls_back_to_a_safe_move(pure_core: PureCore) -> None:
    """Ruckig refuses three profiles in a row while Z flies: the generator falls back to a
    safe move, stays within POS_LIMIT and the axis limits, and lands at rest. The fault is
    patched into `LiftProfiles.to_rest`, which only the core run as Python allows."""
    code = """
import json
from liftd.cnc.lift.profile import LiftProfiles, ProfileError
from tests.unit.cnc.lift.test_advanced_generator import fd, fly

calls = {"n": 0}
real = LiftProfiles.to_rest
def flaky(self, *args, **kw):
    calls["n"] += 1
    if 40 <= calls["n"] < 43:
        raise ProfileError("injected")
    return real(self, *args, **kw)
LiftProfiles.to_rest = flaky
t, z, gen = fly(0.4, target=0.0, limit=0.05)
print(json.dumps({"calls": calls["n"], "fallbacks": gen.fallbacks, "z_max": float(z.max()),
                  "z_end": float(z[-1]), "fd_max": max(fd(z))}))
"""
    res = json.loads(pure_core.run(code))
    assert res["calls"] >= 43, "the fault must be injected"
    assert res["fallbacks"] >= 1
    assert res["z_max"] <= 0.05 + 1e-7 and abs(res["z_end"]) <= 1e-9
    assert res["fd_max"] <= 1 + 1e-9


@pytest.mark.parametrize(
    ("z0", "target", "limit", "down"),
    [
        (0.001, 0.001, 0.05, False),  # rise and land where it started
        (0.0, 0.02, 0.05, False),  # POS above the start
        (0.04, 0.01, 0.0, True),  # a downward lift (mirrored coordinates)
    ],
)
def test_a_prepared_first_rise_gives_the_cycle_the_same_set_points(
    z0: float, target: float, limit: float, down: bool
) -> None:
    """GeoProgram prepares each range's rise from Z at rest at its start (one ruckig solve
    less in the lift start's GEO cycle); the generator started with it follows it from there,
    and every set-point is the one it computes without it, bit for bit, also through an
    override step; a rise prepared for another start is not used."""
    from liftd.cnc.lift.advanced import FirstRise  # noqa: PLC0415

    prof = LiftProfiles(V, A, J)
    sign = -1.0 if down else 1.0
    q0 = sign * z0
    prepared = FirstRise(q0, prof.to_rest(q0, 0.0, 0.0, max(sign * limit, sign * target)))
    runs = []
    for rise in (None, prepared, FirstRise(q0 + 1e-9, prepared.traj)):
        gen = AdvancedLift(LiftProfiles(V, A, J), DT)
        gen.start(0.0, z0, 0.0, 0.0, target, limit, down, direct=False, rise=rise)
        assert (gen.rise is prepared.traj) == (rise is prepared)
        states, t_rem, t = [], 0.3, 0.0
        for k in range(600):
            t += DT
            gen.step(t, t_rem if k < 100 else t_rem / 1.5)
            t_rem = max(0.0, t_rem - DT * (1.0 if k < 100 else 1.5))
            states.append((gen.z, gen.vz, gen.az, gen.phase))
        runs.append(states)
    assert runs[1] == runs[0] and runs[2] == runs[0]
    assert max(sign * s[0] for s in runs[0]) > sign * z0 + 0.005  # it did lift
