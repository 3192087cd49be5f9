"""Seeded random lift scenarios and their checks (used by bench/bench_lift_safety.py and, with
fewer seeds, by the test suite)."""

from __future__ import annotations

import dataclasses
import math
import random
from dataclasses import dataclass

import numpy as np

from liftd.cnc.params import AxisParams, ChannelParams, LiftMethod, MSync, SlopeType
from liftd.cnc.plc import Schedule
from tests.support.closed_loop import limit_problems

POS_TOL = 1e-7  # 0.1 µm


@dataclass
class Scenario:
    seed: int
    channel: ChannelParams
    text: str
    schedule: Schedule


def _flusher(seed: int, on: bool) -> random.Random | None:
    """Where #FLUSH / #FLUSH WAIT go inside ranges (issue 37 item 2): a generator of its own,
    so that a seed's program without them stays the one it always was."""
    return random.Random(seed * 7919 + 37) if on else None


def _flush(fl: random.Random | None, lines: list[str], share: float = 0.15) -> None:
    if fl is not None and fl.random() < share:
        lines.append(fl.choice(["#FLUSH", "#FLUSH WAIT"]))


def scenario(seed: int, method: LiftMethod = LiftMethod.ADVANCED, flush: bool = False) -> Scenario:
    """`flush`: #FLUSH / #FLUSH WAIT after some motion blocks inside ranges."""
    rng = random.Random(seed)
    fl = _flusher(seed, flush)
    zv, za = rng.uniform(0.3, 1.5), rng.uniform(3.0, 20.0)
    zj = rng.uniform(100.0, 2000.0)
    z_neg, z_pos = -0.05, 0.2
    ch = ChannelParams(
        channel_id=1,
        axes=(
            AxisParams("X", 1, 1.5, 10.0, 500.0, -0.001, 3.01),
            AxisParams("Y", 2, 1.5, 8.0, 400.0, -0.001, 1.51),
            AxisParams("Z", 3, zv, za, zj, z_neg, z_pos),
        ),
        lift_axis="Z",
        lift_method=method,
        cycle_time=rng.choice([1e-3, 1e-3, 1e-3, 5e-4, 2e-3]),
        lift_min_dist=rng.choice([0.0, 0.0, 0.003]),
        slope=SlopeType.TRAPEZ,
        m_synch=((4, MSync.MVS_SVS), (5, MSync.MOS)),
    )
    z = rng.uniform(0.0, 0.03)
    x, y = 10.0, 10.0
    lines = [f"G01 X{x} Y{y} Z{z * 1e3:.3f} F6000"]
    for _ in range(rng.randint(1, 3)):
        down = method is LiftMethod.ADVANCED and rng.random() < 0.2
        pos = min(max(z + rng.uniform(-0.02, 0.03), 0.0), 0.12)
        if down:
            limit = min(z, pos) - rng.uniform(0.0, 0.04)
            limit = max(limit, z_neg + 0.001)
        else:
            limit = min(max(z, pos) + rng.uniform(-0.005, 0.09), z_pos - 0.001)
        word = "LIFT_START DOWN" if down else "LIFT_START"
        lines.append(f"Z[{word} POS={pos * 1e3:.3f} POS_LIMIT={limit * 1e3:.3f}]")
        for _ in range(rng.randint(1, 5)):
            x = min(x + rng.choice([0.5, 2.0, 20.0, 80.0, 250.0]) * rng.random(), 2900.0)
            y = min(max(y + rng.uniform(-40.0, 40.0), 1.0), 1400.0)
            lines.append(f"G01 X{x:.3f} Y{y:.3f} F{rng.choice([3000, 12000, 24000, 60000])}")
            _flush(fl, lines)
            if rng.random() < 0.1:
                lines.append(f"G04 {rng.uniform(0.01, 0.2):.3f}")
        lines.append("Z[LIFT_END]")
        z = pos
        x = min(x + 5.0, 2900.0)
        lines.append(f"G01 X{x:.3f} F6000")
    lines.append("M30")
    steps = tuple(
        sorted((rng.uniform(0.1, 2.0), rng.uniform(0.3, 2.0)) for _ in range(rng.randint(0, 3)))
    )
    holds = tuple(
        sorted(
            (t, t + rng.uniform(0.02, 0.3))
            for t in (rng.uniform(0.1, 2.0) for _ in range(rng.randint(0, 2)))
        )
    )
    return Scenario(seed, ch, "\n".join(lines) + "\n", Schedule(steps, holds))


def wide_scenario(
    seed: int, method: LiftMethod = LiftMethod.ADVANCED, flush: bool = False
) -> Scenario:
    """The whole input space of issue 14: 1–4 ranges of few blocks, of long polylines (up to
    400 short blocks, longer than every look-ahead), of slightly bent polylines and without path
    motion; ranges back to back; waits (G04, synchronised M) before and inside ranges; every
    look-ahead size; override steps (0–200 %) at random moments and feed holds. `flush`:
    #FLUSH / #FLUSH WAIT inside ranges too."""
    rng = random.Random(seed)
    fl = _flusher(seed, flush)
    zv, za = rng.uniform(0.3, 1.5), rng.uniform(3.0, 20.0)
    zj = rng.uniform(100.0, 2000.0)
    z_neg, z_pos = -0.05, 0.2
    ch = ChannelParams(
        channel_id=1,
        axes=(
            AxisParams("X", 1, 1.5, 10.0, 500.0, -0.001, 3.01),
            AxisParams("Y", 2, 1.5, 8.0, 400.0, -0.001, 1.51),
            AxisParams("Z", 3, zv, za, zj, z_neg, z_pos),
        ),
        lift_axis="Z",
        lift_method=method,
        cycle_time=rng.choice([1e-3, 1e-3, 1e-3, 5e-4, 2e-3]),
        lift_min_dist=rng.choice([0.0, 0.0, 0.003]),
        slope=SlopeType.TRAPEZ,
        look_ahead_blocks=rng.choice([1, 3, 8, 30, 30, 120, 120, 190, 200]),
        m_synch=((4, MSync.MVS_SVS), (5, MSync.MOS), (8, MSync.MNS_SNS)),
    )
    z = rng.uniform(0.0, 0.03)
    x, y = 10.0, 10.0 + rng.uniform(0.0, 400.0)
    lines = [f"G01 X{x} Y{y:.3f} Z{z * 1e3:.3f} F6000"]
    joined = False  # the last range ended on the boundary where the next one starts
    for _ in range(rng.randint(1, 4)):
        if not joined and rng.random() < 0.2:
            lines.append(rng.choice(["G04 0.05", "M04", "M08"]))  # a wait before the range
        down = method is LiftMethod.ADVANCED and rng.random() < 0.15
        pos = min(max(z + rng.uniform(-0.02, 0.03), 0.0), 0.12)
        if down:
            limit = max(min(z, pos) - rng.uniform(0.0, 0.04), z_neg + 0.001)
        else:
            limit = min(max(z, pos) + rng.uniform(-0.005, 0.09), z_pos - 0.001)
        word = "LIFT_START DOWN" if down else "LIFT_START"
        lines.append(f"Z[{word} POS={pos * 1e3:.3f} POS_LIMIT={limit * 1e3:.3f}]")
        kind = rng.choice(["few", "few", "polyline", "polyline", "bent", "none"])
        feed = rng.choice([3000, 12000, 24000, 30000, 60000])
        if kind == "few":
            for _ in range(rng.randint(1, 5)):
                x = min(x + rng.choice([0.5, 2.0, 20.0, 80.0, 250.0]) * rng.random(), 2900.0)
                y = min(max(y + rng.uniform(-40.0, 40.0), 1.0), 1400.0)
                lines.append(f"G01 X{x:.3f} Y{y:.3f} F{rng.choice([3000, 12000, 24000, 60000])}")
                _flush(fl, lines)
                if rng.random() < 0.1:
                    lines.append(rng.choice(["G04 0.03", "M04", "M08"]))
        elif kind in ("polyline", "bent"):
            step = rng.choice([0.2, 0.5, 1.0, 2.0])
            n = rng.randint(20, 400)
            angle = rng.uniform(-0.3, 0.3)
            bend = rng.uniform(0.003, 0.03) if kind == "bent" else 0.0
            lines.append(f"F{feed}")
            a = angle
            for i in range(n):
                if kind == "bent":  # wiggles of ≤ 1.7° per block, never turning back
                    a = min(max(a + bend * rng.choice([1.0, 1.0, -1.0]), -1.2), 1.2)
                x = min(x + step * math.cos(a), 2900.0)
                y = min(max(y + step * math.sin(a), 1.0), 1400.0)
                lines.append(f"G01 X{x:.4f} Y{y:.4f}")
                _flush(fl, lines, 0.01)
                if i == n // 2 and rng.random() < 0.1:
                    lines.append(rng.choice(["G04 0.03", "M04"]))
        lines.append("Z[LIFT_END]")
        z = pos
        joined = rng.random() < 0.25
        if not joined:
            x = min(x + 5.0, 2900.0)
            lines.append(f"G01 X{x:.3f} F6000")
    lines.append(f"G01 X{min(x + 5.0, 2900.0):.3f} F6000")
    lines.append("M30")
    steps = sorted(
        (rng.uniform(0.0, 3.0), rng.choice([0.0, 0.1, 0.5, 0.8, 1.0, 1.2, 1.5, 2.0]))
        for _ in range(rng.randint(0, 6))
    )
    if steps and steps[-1][1] < 0.5:  # the program must end: the PLC turns it back up
        steps.append((steps[-1][0] + rng.uniform(0.05, 0.5), rng.choice([0.5, 1.0, 2.0])))
    holds = tuple(
        sorted(
            (t, t + rng.uniform(0.01, 0.3))
            for t in (rng.uniform(0.05, 3.0) for _ in range(rng.randint(0, 3)))
        )
    )
    return Scenario(seed, ch, "\n".join(lines) + "\n", Schedule(tuple(steps), holds))


def violations(sc: Scenario, snaps: list, records: list) -> list[str]:  # type: ignore[type-arg]
    """Every broken promise of a run, as text (empty: all good)."""
    ch = sc.channel
    out: list[str] = []
    if snaps[-1].state.name != "READY":
        out.append(f"ended in {snaps[-1].state.name} at t={snaps[-1].t}")
    p = np.array([s.positions for s in snaps])
    dt = ch.cycle_time
    v = np.diff(p, axis=0) / dt
    a = np.diff(v, axis=0) / dt
    j = np.diff(a, axis=0) / dt
    coupled = ch.lift_method is LiftMethod.LIFTING
    ov = max([1.0, *(f for _, f in sc.schedule.override)])
    # the path axes: within their limits in a segment, within the block-transition parameters
    # over a transition (issue 36)
    out.extend(limit_problems(ch, snaps))
    for i, ax in enumerate(ch.axes):
        if ax.name != ch.lift_axis:
            continue
        checks = [("v", v, ax.v_max), ("a", a, ax.a_max), ("j", j, ax.j_max)]
        if coupled and ax.name == ch.lift_axis:
            # path-based Lifting: within a_max and j_max at 100 % override, whatever the path
            # does (issue 37 item 3, lift/path_based.py `segment_cap`); an override above
            # 100 % scales the plan's share with ov² (ov³): the overload band of P-AXIS-00442
            big = max(1.0, ov)
            checks = [("v", v, ax.v_max), ("a", a, ax.a_max * big * big),
                      ("j", j, ax.j_max * big * big * big)]  # fmt: skip
        for name, arr, lim in checks:
            got = float(np.abs(arr[:, i]).max()) / lim
            if got > 1 + 1e-9:
                out.append(f"{ax.name} |{name}| ratio {got:.9f}")
    z = p[:, 2]
    zax = ch.axes[2]
    if z.max() > zax.sw_limit_pos + POS_TOL or z.min() < zax.sw_limit_neg - POS_TOL:
        out.append("software limit")
    for rec in records:
        spec = rec.range.start
        mask = np.array([rec.t_start <= s.t <= rec.t_end for s in snaps])
        if not mask.any():
            continue
        seg = z[mask]
        top = max(spec.pos_limit, spec.target, rec.z_start)  # limit has no effect beyond it
        bottom = min(spec.pos_limit, spec.target, rec.z_start)
        tol = POS_TOL
        if rec.range.direct:  # Z may enter moving with the path: allow its stopping distance
            k = int(np.argmax(mask))
            vz = abs(z[k] - z[k - 1]) / dt if k > 0 else 0.0
            tol += vz * vz / (2 * zax.a_max) + vz * zax.a_max / zax.j_max
        if (not spec.down and seg.max() > top + tol) or (spec.down and seg.min() < bottom - tol):
            out.append(f"POS_LIMIT exceeded in lift line {spec.line}")
        if rec.arrival_error > 1e-6:
            out.append(f"arrival error {rec.arrival_error * 1e6:.3f} µm line {spec.line}")
    late = [e for s in snaps for e in s.events if e.name == "lift.late"]
    if late:
        out.append(f"{len(late)} late lift(s)")
    clamped = [e for s in snaps for e in s.events if e.name == "lift.guard_clamped"]
    if clamped:
        out.append(f"{len(clamped)} guard clamp(s)")
    return out


def describe(sc: Scenario) -> str:
    ax = sc.channel.axes[2]
    return (
        f"seed {sc.seed}: Z {ax.v_max:.2f} m/s {ax.a_max:.1f} m/s² {ax.j_max:.0f} m/s³, "
        f"cycle {sc.channel.cycle_time * 1e3:g} ms, override {sc.schedule.override}, "
        f"hold {sc.schedule.feed_hold}\n{sc.text}"
    )


def replace_method(sc: Scenario, method: LiftMethod) -> Scenario:
    return dataclasses.replace(sc, channel=dataclasses.replace(sc.channel, lift_method=method))


__all__ = ["Scenario", "describe", "replace_method", "scenario", "violations", "wide_scenario"]
