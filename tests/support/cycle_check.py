"""The specification's checker of a closed-loop run, cycle by cycle: every promise a run of the
GEO task keeps, whatever its program and PLC (the channel READY at the end; every axis within
its v, a, j by finite differences; Z within its software limits and, in each lift range, never
beyond POS_LIMIT, landing on POS with no late lift and no guard clamp). The lift axis is the
channel's (`ChannelParams.lift_axis`), a range's own axis is the one its LIFT_START names.

The tests run it on a few seeded scenarios (tests/support/scenarios.py), bench/ on thousands.
Moved from bench/stress_cases.py and bench/bench_reset.py (issue 40)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from liftd.cnc import events
from liftd.cnc.lift.controller import LiftRecord
from liftd.cnc.params import ChannelParams, LiftMethod, SlopeType
from liftd.cnc.path.limits import transition_allowance
from liftd.cnc.plc import Schedule
from liftd.cnc.snapshot import ChannelState, GeoSnapshot
from tests.support.closed_loop import limit_problems
from tests.support.scenarios import Scenario

POS_TOL = 1e-7  # 0.1 µm
Floats = npt.NDArray[np.float64]


def highest_override(schedule: Schedule) -> float:
    """The highest override the PLC requests in the run (at least 100 %)."""
    return max([1.0, *(f for _, f in schedule.override)])


def axis_limits(ch: ChannelParams, axis: int, ov: float) -> tuple[float, float, float]:
    """The v, a, j an axis keeps at the highest override `ov` of a run. Path-based Lifting's
    lift axis: within a_max and j_max at 100 % override, whatever the path does (issue 37
    item 3, lift/path_based.py `segment_cap`); an override above 100 % scales the plan's share
    with ov² (ov³): the overload band of P-AXIS-00442."""
    ax = ch.axes[axis]
    if ch.lift_method is LiftMethod.LIFTING and axis == ch.lift_axis_index:
        big = max(1.0, ov)
        return ax.v_max, ax.a_max * big * big, ax.j_max * big * big * big
    return ax.v_max, ax.a_max, ax.j_max


def _derivatives(p: Floats, dt: float) -> tuple[Floats, Floats, Floats]:
    v = np.diff(p, axis=0) / dt
    a = np.diff(v, axis=0) / dt
    return v, a, np.diff(a, axis=0) / dt


def violations(
    sc: Scenario, snaps: Sequence[GeoSnapshot], records: Sequence[LiftRecord]
) -> list[str]:
    """Every broken promise of a run, as text (empty: all good)."""
    ch = sc.channel
    out: list[str] = []
    last = snaps[-1]
    if last.state is not ChannelState.READY:
        out.append(f"ended in {last.state.name} at t={last.t}")
    p: Floats = np.array([s.positions for s in snaps], dtype=np.float64)
    dt = ch.cycle_time
    v, a, j = _derivatives(p, dt)
    ov = highest_override(sc.schedule)
    # the path axes: within their limits in a segment, within the block-transition parameters
    # over a transition (issue 36: tests/support/closed_loop.py `limit_problems`); the lift axis
    # within its own limits, except over a block transition not wholly inside a range (where it
    # moved as a path axis): there as a path axis (Z arriving at a kink at the transition's cap and
    # stopping as the range starts, issue 36's path-based seeds 174, 197)
    out += limit_problems(ch, list(snaps))
    k = ch.lift_axis_index
    ax = ch.axes[k]
    lift_lim = axis_limits(ch, k, ov)
    allow = transition_allowance(ch.axes, dt, ch.slope is not SlopeType.STEP,
                                 ch.corr_v_trans_jerk, ch.mode_trans_jerk)[k]  # fmt: skip
    seg = np.array([s.segment for s in snaps])
    t = np.array([s.t for s in snaps])
    lifting = np.zeros(len(snaps), dtype=bool)
    for rec in records:
        lifting |= (t >= rec.t_start) & (t <= rec.t_end)
    for n, (name, arr) in enumerate((("v", v), ("a", a), ("j", j))):
        width = n + 2  # samples a difference of this order spans
        spans = seg[width - 1 :] != seg[: len(seg) - width + 1]
        inside = np.convolve(lifting, np.ones(width), "valid") == width
        as_path = spans & ~inside if n else np.zeros(len(arr), dtype=bool)
        ratio = np.abs(arr[:, k]) / lift_lim[n]
        ratio[as_path] = np.abs(arr[as_path, k]) / (ax.a_max * allow[0] if n == 1 else
                                                     ax.j_max * allow[1])  # fmt: skip
        got = float(ratio.max(initial=0.0))
        if got > 1 + 1e-9:
            out.append(f"{ax.name} |{name}| ratio {got:.9f}")
    out += _lift_problems(ch, p, snaps, records)
    late = [e for s in snaps for e in s.events if e.name == events.LIFT_LATE]
    if late:
        out.append(f"{len(late)} late lift(s)")
    clamped = [e for s in snaps for e in s.events if e.name == events.LIFT_GUARD_CLAMPED]
    if clamped:
        out.append(f"{len(clamped)} guard clamp(s)")
    return out


def _lift_problems(
    ch: ChannelParams, p: Floats, snaps: Sequence[GeoSnapshot], records: Sequence[LiftRecord]
) -> list[str]:
    """The lift axis within its software limits; each range's axis within POS_LIMIT (beyond
    the start or POS it has no effect) and on POS at its end."""
    out: list[str] = []
    k = ch.lift_axis_index
    zax = ch.axes[k]
    if p[:, k].max() > zax.sw_limit_pos + POS_TOL or p[:, k].min() < zax.sw_limit_neg - POS_TOL:
        out.append("software limit")
    names = [ax.name for ax in ch.axes]
    dt = ch.cycle_time
    t = np.array([s.t for s in snaps])
    for rec in records:
        spec = rec.range.start
        mask = (t >= rec.t_start) & (t <= rec.t_end)
        if not mask.any():
            continue
        axis = names.index(spec.axis)
        z = p[:, axis]
        seg = z[mask]
        top = max(spec.pos_limit, spec.target, rec.z_start)
        bottom = min(spec.pos_limit, spec.target, rec.z_start)
        tol = POS_TOL
        if rec.range.direct:  # Z may enter moving with the path: allow its stopping distance
            first = int(np.argmax(mask))
            vz = abs(z[first] - z[first - 1]) / dt if first > 0 else 0.0
            ax = ch.axes[axis]
            tol += vz * vz / (2 * ax.a_max) + vz * ax.a_max / ax.j_max
        if (not spec.down and seg.max() > top + tol) or (spec.down and seg.min() < bottom - tol):
            out.append(f"POS_LIMIT exceeded in lift line {spec.line}")
        if rec.arrival_error > 1e-6:
            out.append(f"arrival error {rec.arrival_error * 1e6:.3f} µm line {spec.line}")
    return out


def lift_axis_ratio(sc: Scenario, snaps: Sequence[GeoSnapshot]) -> float:
    """The largest |v|/v_max, |a|/a_max, |j|/j_max of the channel's lift axis over the
    snapshots. Path-based Lifting's Z, following the braking path, as `violations` bounds it
    (v, and a up to a_max·(1 + P442/1000·override²); its jerk is not bounded by the method)."""
    ch = sc.channel
    k = ch.lift_axis_index
    z: Floats = np.array([s.positions[k] for s in snaps], dtype=np.float64)
    ax = ch.axes[k]
    v, a, j = _derivatives(z, ch.cycle_time)
    limits = [(v, ax.v_max), (a, ax.a_max), (j, ax.j_max)]
    if ch.lift_method is LiftMethod.LIFTING:
        ov = highest_override(sc.schedule)
        limits = [(v, ax.v_max), (a, ax.a_max * (1.0 + ax.dyn_a_err * ov * ov))]
    return max(float(np.abs(x).max(initial=0.0)) / lim for x, lim in limits)
