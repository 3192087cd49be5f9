"""Seeded random lift scenarios: a channel, an NC program and a PLC schedule from a seed (the
test suite runs a few seeds, bench/bench_lift_safety.py thousands; checked by
`tests.support.cycle_check.violations`). Moved from bench/stress_cases.py (issue 40)."""

from __future__ import annotations

import dataclasses
import math
import random
from dataclasses import dataclass

from liftd.cnc.params import AxisParams, ChannelParams, LiftMethod, MSync, SlopeType
from liftd.cnc.plc import Schedule


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


Z_LIMITS = (-0.05, 0.2)  # the lift axis's software limits (m)


def _channel(rng: random.Random, method: LiftMethod, *, wide: bool) -> ChannelParams:
    """X, Y and a lift axis Z of random v, a, j, a random cycle time and lift_min_dist (the
    order of the draws is the scenarios'); `wide`: a random look-ahead and an M8 MNS_SNS."""
    zv, za = rng.uniform(0.3, 1.5), rng.uniform(3.0, 20.0)
    zj = rng.uniform(100.0, 2000.0)
    cycle_time = rng.choice([1e-3, 1e-3, 1e-3, 5e-4, 2e-3])
    lift_min_dist = rng.choice([0.0, 0.0, 0.003])
    m_synch: tuple[tuple[int, MSync], ...] = ((4, MSync.MVS_SVS), (5, MSync.MOS))
    ch = ChannelParams(
        channel_id=1,
        axes=(
            AxisParams("X", 1, 1.5, 10.0, 500.0, -0.001, 3.01),
            AxisParams("Y", 2, 1.5, 8.0, 400.0, -0.001, 1.51),
            AxisParams("Z", 3, zv, za, zj, *Z_LIMITS),
        ),
        lift_axis="Z",
        lift_method=method,
        cycle_time=cycle_time,
        lift_min_dist=lift_min_dist,
        slope=SlopeType.TRAPEZ,
        m_synch=m_synch,
    )
    if not wide:
        return ch
    look = rng.choice([1, 3, 8, 30, 30, 120, 120, 190, 200])
    m_synch += ((8, MSync.MNS_SNS),)
    return dataclasses.replace(ch, look_ahead_blocks=look, m_synch=m_synch)


def scenario(seed: int, method: LiftMethod = LiftMethod.ADVANCED, flush: bool = False) -> Scenario:
    """`flush`: #FLUSH / #FLUSH WAIT after some motion blocks inside ranges."""
    rng = random.Random(seed)
    fl = _flusher(seed, flush)
    z_neg, z_pos = Z_LIMITS
    ch = _channel(rng, method, wide=False)
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
    z_neg, z_pos = Z_LIMITS
    ch = _channel(rng, method, wide=True)
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


def describe(sc: Scenario) -> str:
    """The scenario as a failing test prints it: the lift axis, the cycle, the PLC, the
    program."""
    ax = sc.channel.axes[sc.channel.lift_axis_index]
    return (
        f"seed {sc.seed}: {ax.name} {ax.v_max:.2f} m/s {ax.a_max:.1f} m/s² {ax.j_max:.0f} m/s³, "
        f"cycle {sc.channel.cycle_time * 1e3:g} ms, override {sc.schedule.override}, "
        f"hold {sc.schedule.feed_hold}\n{sc.text}"
    )


def replace_method(sc: Scenario, method: LiftMethod) -> Scenario:
    """The same scenario with the other lift method."""
    return dataclasses.replace(sc, channel=dataclasses.replace(sc.channel, lift_method=method))
