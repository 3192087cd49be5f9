"""Seeded random programs in the shapes CAM systems write (issue 36): lines and tangent arcs,
S-curves, small and large corners, short and long blocks, feed changes up and down by any
ratio (in a motion block or an F-only block), G00/G01 hand-overs, a short stretch at a low
feed inside a high one, sometimes an Advanced lift range around a few blocks; run at a
constant override of 10–200 % or with override steps. Used by bench/bench_cam_motion.py
(thousands), bench/bench_reference.py (the reference profile) and, with a derandomised
sample, by tests/unit/cnc/path/test_cam_motion.py."""

from __future__ import annotations

import math
import random

from liftd.cnc.params import AxisParams, ChannelParams, LiftMethod, MSync, SlopeType
from liftd.cnc.plc import Schedule
from tests.support.scenarios import Scenario

X_RANGE = (20.0, 2900.0)  # mm: inside the axes' software limits
Y_RANGE = (20.0, 1400.0)
LENGTHS = (0.2, 0.5, 1.0, 2.0, 5.0, 10.0, 30.0, 100.0)  # mm
CORNERS = (0.0, 0.0, 0.0, 0.5, 2.0, 5.0, 10.0, 30.0, 45.0, 90.0, 135.0)  # degrees
RADII = (2.0, 5.0, 20.0, 50.0, 200.0)  # mm
FEEDS = (600, 1500, 3000, 6000, 9000, 12000, 24000, 30000, 60000)  # mm/min


def cam_channel(rng: random.Random) -> ChannelParams:
    """The demo machine's axes (X 10 m/s², 500 m/s³; Y 8 m/s², 400 m/s³) with a random cycle
    time and look-ahead."""
    return ChannelParams(
        channel_id=1,
        axes=(
            AxisParams("X", 1, 1.5, 10.0, 500.0, -0.001, 3.01),
            AxisParams("Y", 2, 1.5, 8.0, 400.0, -0.001, 1.51),
            AxisParams("Z", 3, 1.0, 10.0, 500.0, -0.005, 0.15),
        ),
        lift_axis="Z",
        lift_method=LiftMethod.ADVANCED,
        cycle_time=rng.choice([1e-3, 1e-3, 1e-3, 5e-4, 2e-3]),
        slope=SlopeType.TRAPEZ,
        look_ahead_blocks=rng.choice([3, 8, 30, 120, 120, 200]),
        m_synch=((4, MSync.MVS_SVS), (5, MSync.MOS)),
    )


class _Writer:
    """Keeps the position and heading of the program being written (mm, radians)."""

    def __init__(self, rng: random.Random) -> None:
        self.rng = rng
        self.x = rng.uniform(200.0, 2500.0)
        self.y = rng.uniform(200.0, 1200.0)
        self.heading = rng.uniform(-math.pi, math.pi)
        self.feed = rng.choice(FEEDS)
        self.lines = [f"G00 X{self.x:.4f} Y{self.y:.4f}", f"G01 F{self.feed}"]

    def _inside(self, x: float, y: float) -> bool:
        return X_RANGE[0] <= x <= X_RANGE[1] and Y_RANGE[0] <= y <= Y_RANGE[1]

    def _arc_inside(self, cx: float, cy: float, r: float, phi0: float, sweep: float) -> bool:
        """Whether the whole arc from angle phi0 through `sweep` (radians, signed) about
        (cx, cy) lies inside the table: its end and every axis-extreme point (angle a multiple
        of 90°) within the swept angle. Its ends and centre alone let an arc bulge beyond Y's
        software limit (seeds 342, 364: error 50042)."""
        end = phi0 + sweep
        if not self._inside(cx + r * math.cos(end), cy + r * math.sin(end)):
            return False
        lo, hi = (phi0, end) if sweep >= 0.0 else (end, phi0)
        k = math.ceil(lo / (math.pi / 2.0))
        while k * math.pi / 2.0 <= hi:
            a = k * math.pi / 2.0
            if not self._inside(cx + r * math.cos(a), cy + r * math.sin(a)):
                return False
            k += 1
        return True

    def turn(self, degrees: float) -> None:
        self.heading += math.radians(degrees) * self.rng.choice([1.0, -1.0])

    def feed_word(self) -> str:
        """A new feed (any ratio) in one block of five, else nothing."""
        if self.rng.random() < 0.2:
            ratio = math.exp(self.rng.uniform(math.log(0.1), math.log(10.0)))
            self.feed = int(min(max(self.feed * ratio, 300), 60000))
            return f" F{self.feed}"
        return ""

    def line(self, length: float, rapid: bool = False) -> None:
        x = self.x + length * math.cos(self.heading)
        y = self.y + length * math.sin(self.heading)
        if not self._inside(x, y):  # turn toward the middle of the table
            self.heading = math.atan2(700.0 - self.y, 1400.0 - self.x)
            x = self.x + length * math.cos(self.heading)
            y = self.y + length * math.sin(self.heading)
        word = "G00" if rapid else "G01"
        self.lines.append(f"{word} X{x:.4f} Y{y:.4f}{'' if rapid else self.feed_word()}")
        self.x, self.y = x, y

    def arc(self, radius: float, sweep_deg: float, left: bool) -> None:
        """A tangent arc (G03 to the left, G02 to the right) of `sweep_deg` degrees."""
        sign = 1.0 if left else -1.0
        nx, ny = -math.sin(self.heading) * sign, math.cos(self.heading) * sign
        cx, cy = self.x + radius * nx, self.y + radius * ny
        phi0 = math.atan2(self.y - cy, self.x - cx)
        # the centre inside too, as before, so that only the programs whose arc bulged change
        sweep = sign * math.radians(sweep_deg)
        if not self._inside(cx, cy) or not self._arc_inside(cx, cy, radius, phi0, sweep):
            self.line(radius)
            return
        x, y = cx + radius * math.cos(phi0 + sweep), cy + radius * math.sin(phi0 + sweep)
        word = "G03" if left else "G02"
        i, j = cx - self.x, cy - self.y
        self.lines.append(f"{word} X{x:.4f} Y{y:.4f} I{i:.4f} J{j:.4f}{self.feed_word()}")
        self.x, self.y = x, y
        self.heading += sign * math.radians(sweep_deg)


def cam_program(rng: random.Random) -> str:
    w = _Writer(rng)
    lift = rng.random() < 0.25
    for _ in range(rng.randint(3, 12)):
        kind = rng.choice(["lines", "lines", "arc", "s-curve", "polyline", "rapid", "stretch",
                           "f-only"])  # fmt: skip
        if lift and rng.random() < 0.3:
            # the path's Z stays at 0: the lift lands where it started (POS = 0)
            w.lines.append(f"Z[LIFT_START POS=0 POS_LIMIT={rng.uniform(5.0, 40.0):.3f}]")
            for _ in range(rng.randint(1, 4)):
                w.turn(rng.choice(CORNERS))
                w.line(rng.choice(LENGTHS))
            w.lines.append("Z[LIFT_END]")
            lift = False
            continue
        if kind == "lines":
            for _ in range(rng.randint(1, 4)):
                w.turn(rng.choice(CORNERS))
                w.line(rng.choice(LENGTHS))
        elif kind == "arc":
            w.line(rng.choice(LENGTHS))
            w.arc(rng.choice(RADII), rng.uniform(10.0, 180.0), rng.random() < 0.5)
            w.line(rng.choice(LENGTHS))
        elif kind == "s-curve":
            r = rng.choice(RADII)
            left = rng.random() < 0.5
            w.arc(r, rng.uniform(20.0, 90.0), left)
            w.arc(rng.choice([r, r, rng.choice(RADII)]), rng.uniform(20.0, 90.0), not left)
        elif kind == "polyline":  # CAM's approximation of a curve: short blocks, small kinks
            step = rng.choice([0.2, 0.5, 1.0, 2.0])
            bend = rng.choice([0.0, 0.2, 1.0, 3.0])
            for _ in range(rng.randint(10, 80)):
                w.turn(bend)
                w.line(step)
        elif kind == "rapid":  # G00 and back to G01, collinear or not
            w.line(rng.choice(LENGTHS[3:]), rapid=True)
            w.turn(rng.choice([0.0, 0.0, 30.0, 90.0]))
            w.lines.append(f"G01 F{w.feed}")
            w.line(rng.choice(LENGTHS))
        elif kind == "stretch":  # a short stretch at a low feed inside a high one
            high, low = w.feed, max(300, int(w.feed * rng.uniform(0.1, 0.6)))
            w.line(rng.choice(LENGTHS[2:]))
            w.lines.append(f"F{low}")
            w.line(rng.choice([1.0, 2.0, 5.0]))
            w.lines.append(f"F{high}")
            w.feed = high
            w.line(rng.choice(LENGTHS[2:]))
        else:  # a feed change in a block of its own
            w.feed = rng.choice(FEEDS)
            w.lines.append(f"F{w.feed}")
            w.line(rng.choice(LENGTHS))
    w.lines.append("M30")
    return "\n".join(w.lines) + "\n"


def cam_schedule(rng: random.Random, steps: bool) -> Schedule:
    """A constant override of 10–200 %, or (with `steps`) 1–5 steps at random moments."""
    ov = round(rng.uniform(0.1, 2.0), 2)
    if not steps:
        return Schedule(((0.0, ov),), ())
    moments = sorted(rng.uniform(0.05, 2.0) for _ in range(rng.randint(1, 5)))
    return Schedule(((0.0, ov), *((t, round(rng.uniform(0.1, 2.0), 2)) for t in moments)), ())


def cam_scenario(seed: int, steps: bool | None = None) -> Scenario:
    """A CAM-shaped program on the demo machine; override steps in half the seeds unless
    `steps` says."""
    rng = random.Random(seed)
    ch = cam_channel(rng)
    text = cam_program(rng)
    with_steps = rng.random() < 0.5 if steps is None else steps
    return Scenario(seed, ch, text, cam_schedule(rng, with_steps))


__all__ = ["cam_channel", "cam_program", "cam_scenario", "cam_schedule"]
