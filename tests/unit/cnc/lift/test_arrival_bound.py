"""The remaining path time a time-based lift plans against is a lower bound that never exceeds
the path's committed arrival at the lift's horizon: Z decides its descent against it, and a
bound above the arrival would let the path reach LIFT_END before Z lands (`lift.late`).

Checked cycle by cycle on random scenarios (tests/support/scenarios.py) with the inputs held
(the committed future then only changes at a restart): `Interpolator.lower_bound` at the
override in effect against `arrival` wherever the latter is committed, and each cheap bound
`arrival_bound` gave for the horizon against the committed arrival found later from the same
committed future (no restart between)."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from liftd.cnc.geo_task import GeoTask
from liftd.cnc.plc import Schedule, SimPlc
from liftd.cnc.snapshot import ChannelState, GeoSnapshot
from tests.support.scenarios import scenario

TOL = 1e-9  # s


def bound_problems(seed: int) -> tuple[int, list[str]]:
    """(checks made, bounds above the committed arrival) over one run of scenario `seed`."""
    sc = scenario(seed)
    task = GeoTask(sc.channel, sc.text)
    plc, dt = SimPlc(0.02), sc.channel.cycle_time
    pending: dict[tuple[int, int], list[tuple[float, float]]] = {}  # (k, restarts) → (t, bound)
    problems: list[str] = []
    checks = 0
    last: GeoSnapshot | None = None
    for cycle in range(1, round(60.0 / dt)):
        t = cycle * dt
        last = task.step(plc.inputs(last, t, Schedule()), t)
        ip = task.interp
        if ip.stopped_at is None:
            for k in range(ip.segment + 1, len(ip.program.segments) + 1):
                if ip.exact(k):
                    checks += 1
                    lb = ip.lower_bound(k, task.ov_eff)
                    if lb > ip.arrival(k) + TOL:
                        problems.append(f"t={t:.4f} k={k}: lower bound {lb} > {ip.arrival(k)}")
        k = task.ahead.horizon() if task.lift.current is not None else -1
        if k > ip.segment and ip.stopped_at is None:
            key = (k, ip.restarts)
            if ip.exact(k):
                for t_b, bound in pending.pop(key, []):
                    checks += 1
                    if bound > ip.arrival(k) + TOL:
                        problems.append(f"t={t_b:.4f} k={k}: bound {bound} > {ip.arrival(k)}")
            else:
                pending.setdefault(key, []).append((t, ip.arrival_bound(k)))
        if last.state is ChannelState.READY and cycle > 1:
            break
    return checks, problems


@settings(max_examples=12)
@given(st.integers(0, 100_000))
def test_the_lift_time_bound_never_exceeds_the_committed_arrival(seed: int) -> None:
    checks, problems = bound_problems(seed)
    assert checks > 0 and problems == [], (seed, problems[:3])
