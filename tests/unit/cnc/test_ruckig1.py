"""The one ruckig wrapper: the native evaluation of a profile (`Phases`, `Evaluator`) gives
what ruckig's own `at_time` gives, bit for bit."""

from __future__ import annotations

import itertools
import random

from ruckig import Trajectory

from liftd.cnc.ruckig1 import (
    Evaluator,
    Phases,
    ProfileError,
    Ruckig1,
    highest_between,
    state_at,
    travel_after,
)


def _profiles(n: int, seed: int = 1) -> list[Trajectory]:
    """Random profiles of both interfaces: from states within and beyond the limits (a brake
    pre-trajectory), to rest and to a velocity, time-optimal and stretched."""
    calc, rng = Ruckig1(), random.Random(seed)
    out: list[Trajectory] = []
    while len(out) < n:
        v_max, a_max, j_max = rng.uniform(0.1, 2.0), rng.uniform(1.0, 30.0), rng.uniform(50, 3000)
        p0, v0, a0 = (
            rng.uniform(-0.1, 0.1),
            rng.uniform(-1.5, 1.5) * v_max,
            rng.uniform(-1.5, 1.5) * a_max,
        )
        try:
            if len(out) % 3 == 0:
                traj = calc.velocity(p0, v0, a0, rng.uniform(0.0, v_max), a_max, j_max)
            else:
                stretch = rng.choice([None, None, rng.uniform(0.0, 1.0)])
                traj = calc.position(
                    p0,
                    v0,
                    a0,
                    rng.uniform(-0.1, 0.1),
                    rng.choice([0.0, rng.uniform(0, v_max)]),
                    v_max,
                    a_max,
                    j_max,
                    forward_only=False,
                    min_duration=stretch,
                )
        except ProfileError:
            continue
        out.append(traj)
    return out


def test_the_native_evaluation_is_ruckigs_own_bit_for_bit() -> None:
    rng = random.Random(2)
    braked = 0
    for traj in _profiles(2000):
        ph = Phases(traj)
        prof = traj.profiles[0][0]
        braked += prof.brake.duration > 0.0
        starts = [prof.brake.duration + sum(prof.t[:i]) for i in range(8)]  # phase boundaries
        dur = traj.duration
        for t in [0.0, dur, dur + 0.01, *starts, *(rng.uniform(0.0, dur) for _ in range(20))]:
            p, v, a = traj.at_time(t)
            assert ph.at(t) == (p[0], v[0], a[0]), (t, dur)
    assert braked > 100  # profiles that start beyond the limits were among them


def test_travel_after_bounds_what_is_left_of_a_profile_and_is_tight() -> None:
    """`travel_after` (the lift's landing rule: Z stays within 1 µm of POS for what is left of
    its descent) is an upper bound of the distance the profile still moves, brake pieces
    included, and not far above it: each piece's largest |v| times its time, against the
    path length summed over 400 samples."""
    rng = random.Random(3)
    ratios = []
    for traj in _profiles(300, seed=4):
        dur = traj.duration
        t = rng.uniform(0.0, dur) if rng.random() < 0.8 else 0.0
        ph = Phases(traj)
        n = 400
        times = [t + (dur - t) * i / n for i in range(n + 1)]
        ps = [ph.at(x)[0] for x in times]
        moved = sum(abs(b - a) for a, b in itertools.pairwise(ps))
        bound = travel_after(ph, t)
        assert bound >= moved * (1 - 1e-9) - 1e-15, (bound, moved)
        if moved > 1e-6:
            ratios.append(bound / moved)
    assert travel_after(ph, dur) == 0.0 and travel_after(ph, dur + 1.0) == 0.0
    assert ratios and sorted(ratios)[len(ratios) // 2] < 1.5  # a bound, but not a loose one


def test_highest_between_is_the_profiles_peak_velocity_over_the_interval() -> None:
    """`highest_between` (the tracker's test that a profile speeds up again above a block's
    ceiling after its boundary) is the highest velocity over [t0, t1], brake pieces and the
    constant velocity after the end included: never below the highest of 2 000 samples, and
    above it no more than the samples' spacing allows."""
    rng = random.Random(5)
    inside = 0
    for traj in _profiles(300, seed=6):
        dur = traj.duration
        ph = Phases(traj)
        t0 = rng.uniform(0.0, dur) if rng.random() < 0.8 else 0.0
        t1 = rng.choice([rng.uniform(t0, dur), dur, dur + 0.01])
        n = 2000
        vs = [ph.at(t0 + (t1 - t0) * i / n)[1] for i in range(n + 1)]
        top = highest_between(ph, t0, t1)
        sampled = max(vs)
        assert top >= sampled - 1e-12, (top, sampled)
        # between two samples v rises at most |a| dt + j dt²/2 above the higher of them
        step = (t1 - t0) / n
        slack = max(abs(ph.at(t0 + step * i)[2]) for i in range(n + 1)) * step + 3000 * step**2
        assert top <= sampled + slack + 1e-12, (top, sampled, slack)
        inside += top > max(vs[0], vs[-1]) + 1e-9  # a peak inside, not at an end
    assert inside > 20  # profiles whose peak lies inside the interval were among them


def test_an_evaluator_answers_as_state_at_from_its_first_call_on() -> None:
    """Clamped to [0, duration] like `state_at`; the binding answers the first call, the
    profile's pieces (read at the second) every later one."""
    for traj in _profiles(200, seed=3):
        ev = Evaluator(traj)
        dur = traj.duration
        times = [0.3 * dur, -1.0, 0.0, dur, 2 * dur, 0.7 * dur]
        assert [ev.at(t) for t in times] == [state_at(traj, t) for t in times]
        assert ev.phases is not None and ev.dur == dur


def test_a_forward_only_target_below_zero_is_refused_as_ruckig_refuses_it() -> None:
    """The wrapper refuses such a target itself (ruckig's refusal goes through a C++
    exception that formats the whole input, the costliest thing a cycle did): the same
    inputs, the same verdict, and ruckig's reason in the message of the ones it refuses."""
    from ruckig import ControlInterface, InputParameter, Ruckig, RuckigError  # noqa: PLC0415

    def ruckig_refuses(v1: float) -> bool:
        inp = InputParameter(1)
        inp.control_interface = ControlInterface.Position
        inp.current_position, inp.current_velocity, inp.current_acceleration = [0.0], [0.3], [0.0]
        inp.target_position, inp.target_velocity, inp.target_acceleration = [0.05], [v1], [0.0]
        inp.max_velocity, inp.max_acceleration, inp.max_jerk = [1.0], [10.0], [500.0]
        inp.min_velocity = [0.0]
        try:
            Ruckig(1).calculate(inp, Trajectory(1))
        except RuckigError:
            return True
        return False

    calc = Ruckig1()
    for v1 in (-1e-17, -1e-300, -1e-9, -0.2, -0.0, 0.0, 1e-17, 0.1):
        try:
            calc.position(0.0, 0.3, 0.0, 0.05, v1, 1.0, 10.0, 500.0)
            refused = False
        except ProfileError:
            refused = True
        assert refused == ruckig_refuses(v1) == (v1 < 0.0), v1
    try:  # a refusal ruckig makes itself says why, not "" (its message starts with a newline)
        calc.position(0.0, 1.0, 0.0, 1e-4, 0.0, 1.0, 10.0, 500.0)
    except ProfileError as exc:
        assert str(exc).startswith("[ruckig] error in step 1"), str(exc)
    else:
        raise AssertionError("ruckig accepted a stop from 1 m/s within 0.1 mm")
