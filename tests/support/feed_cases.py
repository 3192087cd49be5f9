"""Seeded random programs of short blocks whose feed changes block by block (issue 36): falling
feeds (each block 2–20 % below the last, now and then back up), a saw of feeds between F3000
and F60000, and drops to F1200–F6000 every 12 blocks before a corner or an M00; blocks of
0.1–2 mm along a line that bends a little, a look-ahead of 3–200 blocks, cycles of 0.5–2 ms,
and in most runs an override step sequence (10–200 %) or a feed hold where the short blocks
are. The shapes the cold reviews of the seventh and eighth rounds wrote their programs in
(their generator, seed for seed); the look-ahead meets the feed drops at every distance, late
ones included (known deviations 13 and 14 of docs/geo-core.md).

Each program starts with a 316 mm line from the origin at F3000 (6.3 s), so the short blocks
and the input changes come after a corner. Used by bench/bench_cam_motion.py (--kind feeds)
and, with the seeds fixed so far, by tests/unit/cnc/path/test_cam_motion.py."""

from __future__ import annotations

import dataclasses
import math
import random

from liftd.cnc.geo_task import GeoTask
from liftd.cnc.plc import Schedule, SimPlc, parse_override_spec
from liftd.sim.simulate import run_cycles
from tests.support.channel import shipped
from tests.support.scenarios import Scenario

KINDS = ("fall", "fall", "dropcorner", "dropm00", "saw")
HIGH = (12000, 24000, 30000, 45000, 60000)  # mm/min
LOOK_AHEAD = (3, 8, 30, 60, 120, 200)
# override steps, in seconds after the short blocks begin (T0) : percent
OVERRIDES = (
    "", "", "0.05:150,0.12:40,0.2:200", "0.03:60,0.06:180,0.3:100", "0.08:30,0.1:200",
    "0.02:10,0.2:100", "0.1:200,0.15:20,0.4:120",
)  # fmt: skip
CYCLES = (1e-3, 2e-3, 5e-4)  # s


def _feed(rng: random.Random, kind: str, f: int, i: int) -> int:
    if kind == "fall":
        f = max(600, int(f * rng.uniform(0.8, 0.98)))
        if rng.random() < 0.05:
            f = rng.choice(HIGH[:4])
        return f
    if kind == "saw":
        return rng.choice((3000, 6000, *HIGH))
    if i % 12 == 10:
        return rng.choice((1200, 3000, 6000))
    if i % 12 == 0:
        return rng.choice(HIGH)
    return f


def feed_program(rng: random.Random) -> tuple[str, str]:
    """(kind, program text)."""
    lines = ["G01 X100 Y300 F3000"]
    x, y = 100.0, 300.0
    n = rng.choice((40, 80, 150))
    step = rng.choice((0.1, 0.2, 0.5, 1.0, 2.0))
    f = rng.choice(HIGH)
    kind = rng.choice(KINDS)
    ang = 0.0
    for i in range(n):
        f = _feed(rng, kind, f, i)
        if kind == "dropcorner" and i % 12 == 11:
            ang = max(-1.4, min(1.4, ang + rng.choice((0.5, 1.2, 1.57, -0.8, 0.05, -1.5))))
        elif rng.random() < 0.1:
            ang += rng.uniform(-0.05, 0.05)
        x += step * math.cos(ang)
        y += step * math.sin(ang)
        fword = f" F{f}" if rng.random() < 0.9 else ""
        if rng.random() < 0.1 and fword:
            lines.append(f"F{f}")  # the new feed in an F-only block
            fword = ""
        lines.append(f"G01 X{x:.4f} Y{y:.4f}{fword}")
        if kind == "dropm00" and i % 12 == 11:
            lines.append("M00")
    lines.append("M30")
    return kind, "\n".join(lines) + "\n"


def feed_scenario(seed: int) -> Scenario:
    """A program of `feed_program` on the shipped machine's path axes (Y 8 m/s², 400 m/s³)."""
    rng = random.Random(seed)
    _, text = feed_program(rng)
    look_ahead = rng.choice(LOOK_AHEAD)
    spec = rng.choice(OVERRIDES)
    held = rng.random() < 0.2  # a feed hold of 50 ms
    t0 = 6.3 + rng.uniform(0.0, 0.3)  # the short blocks begin after about 6.3 s
    holds: tuple[tuple[float, float], ...] = ((0.1 + t0, 0.15 + t0),) if held else ()
    if spec:
        steps = (p.split(":") for p in spec.split(","))
        spec = ",".join(f"{float(t) + t0:.4f}:{pc}" for t, pc in steps)
    cycle = rng.choice(CYCLES)
    ch = dataclasses.replace(shipped(), look_ahead_blocks=look_ahead, cycle_time=cycle)
    overrides = tuple(parse_override_spec(spec)) if spec else ()
    return Scenario(seed, ch, text, Schedule(overrides, holds))


# Programs of their own (tests/unit/cnc/path/test_run_brakes.py, test_motion_check.py): feeds
# falling block by block into a corner, an M00 or the program end


def falling_feeds(step_mm: float, feeds: tuple[int, ...], end: str) -> str:
    """A 100-block-long line at the first feed, then one block of `step_mm` at each of the
    others, then `end` (a corner block, or an M00 and a block after it)."""
    x = 100 * step_mm
    lines = ["G01 X0 Y0 F600", f"G01 X{x:.4f} F{feeds[0]}"]
    for f in feeds[1:]:
        x += step_mm
        lines.append(f"G01 X{x:.4f} F{f}")
    lines += [end, f"G01 X{x + 5.0:.4f} F6000"] if end == "M00" else [end]
    return "\n".join([*lines, "M30"]) + "\n"


def falling_to_the_end(feeds: tuple[int, ...], step_mm: float, corner: str) -> str:
    """10 mm at the first feed, then one block of `step_mm` at each of the others, then
    `corner` (a block, or nothing) and M30."""
    lines = ["G01 X100 Y300 F3000", f"G01 X110 F{feeds[0]}"]
    lines += [f"G01 X{110 + step_mm * i:.1f} F{f}" for i, f in enumerate(feeds[1:], 1)]
    return "\n".join([*lines, *([corner] if corner else []), "M30"]) + "\n"


def short_drop(first: int, rising: int) -> tuple[str, int]:
    """0.2 mm blocks over rounding kinks of 0.1° (every boundary a run boundary: known
    deviation 0): 20 at F`first`, `rising` at F60000, one at F6000 collinear with the next,
    three more at F60000, one at F6000 and ten at F60000; and the boundary where the first
    F6000 block begins (the shape of feeds seed 942)."""
    lines = [f"G01 X0 Y0 F{first}"]
    x = y = heading = 0.0
    seq = [first] * 20 + [60000] * rising + [6000, 60000, 60000, 60000, 6000] + [60000] * 10
    short = 20 + rising
    for i, f in enumerate(seq):
        if i != short + 1:  # the short block and the one after it are collinear
            heading += math.radians(0.1)
        x += 0.2 * math.cos(heading)
        y += 0.2 * math.sin(heading)
        lines.append(f"G01 X{x:.4f} Y{y:.4f} F{f}")
    return "\n".join([*lines, "M30"]) + "\n", short


def short_drop_scenario(
    first: int, rising: int, before_mm: float, low: float, look_ahead: int, cycle: float
) -> Scenario:
    """`short_drop` on the shipped machine, the override 100 % → `low` in the first cycle
    in which the path, run without that drop, is within `before_mm` of the F6000 block."""
    text, short = short_drop(first, rising)
    ch = dataclasses.replace(shipped(), look_ahead_blocks=look_ahead, cycle_time=cycle)
    task = GeoTask(ch, text)
    s_drop = task.prog.table.s[short] - before_mm * 1e-3
    t_drop = next(
        snap.t
        for snap in run_cycles(task, SimPlc(0.02), Schedule((), ()), cycle, 60.0)
        if task.interp.s >= s_drop
    )
    return Scenario(short, ch, text, Schedule(((t_drop, low),), ()))


def moved_steps(sc: Scenario, shift: float, keep: bool = True) -> Scenario:
    """`sc` with every override step moved by `shift` seconds (−0.02: a cold review's variant
    of the drops corpus, its drop 20 ms earlier), or without them (`keep` false); feed holds
    as they were."""
    steps = sc.schedule.override if keep else ()
    moved = tuple((t + shift, ov) for t, ov in steps)
    return dataclasses.replace(sc, schedule=Schedule(moved, sc.schedule.feed_hold))


def drop_scenario(seed: int) -> Scenario:
    """A cold review's random programs (eighteenth round): 20 mm at F3000, then 8–16 blocks
    of 0.05–0.5 mm at F1200–F60000, each bending by 0°, 0.1° or 2°, and a 2 mm corner
    block; look-ahead 3–30, 1 or 2 ms; the override drops to 10–80 % between 0.40 and
    0.55 s, as the short blocks come (in a fifth of the runs a second step, to 50–150 %,
    5–50 ms later)."""
    rng = random.Random(seed)
    lines = ["G01 X0 Y0 F3000", "G01 X20 Y0"]
    x, y, heading = 20.0, 0.0, 0.0
    for _ in range(rng.randint(8, 16)):
        length = rng.choice((0.05, 0.1, 0.2, 0.3, 0.5))
        feed = rng.choice((1200, 2400, 3000, 4800, 6000, 9000, 24000, 60000))
        heading += math.radians(rng.choice((0.0, 0.0, 0.0, 0.1, 2.0)))
        x += length * math.cos(heading)
        y += length * math.sin(heading)
        lines.append(f"G01 X{x:.5f} Y{y:.5f} F{feed}")
    lines.append(f"G01 X{x:.5f} Y{y + 2:.5f} F3000")
    look_ahead = rng.choice((3, 8, 10, 30))
    cycle = rng.choice((1e-3, 2e-3))
    low = rng.choice((0.1, 0.2, 0.3, 0.4, 0.6, 0.8))
    t = 0.40 + rng.random() * 0.15
    steps: tuple[tuple[float, float], ...] = ((t, low),)
    if rng.random() < 0.2:
        steps = ((t, low), (t + rng.uniform(0.005, 0.05), rng.choice((0.5, 1.0, 1.5))))
    ch = dataclasses.replace(shipped(), look_ahead_blocks=look_ahead, cycle_time=cycle)
    return Scenario(seed, ch, "\n".join([*lines, "M30"]) + "\n", Schedule(steps, ()))


FALL_A = (20000, 16000, 13000, 11000, 9000, 7500, 6000, 4800, 3800, 3000)
FALL_B = (24000, 18000, 15000, 12000, 10000, 8000, 6500, 5000, 4000)
FALL_C = (30000, 24000, 18000, 14000, 11000, 9000, 7000, 5200, 4300, 3800)


__all__ = [
    "FALL_A", "FALL_B", "FALL_C", "drop_scenario", "falling_feeds", "falling_to_the_end",
    "feed_program", "feed_scenario", "short_drop", "short_drop_scenario",
]  # fmt: skip
