"""A generated library of CAM-shaped nesting jobs for `liftd study` (bench_study.py).

Each job is what a laser post-processor writes: one local subroutine per part shape (a
plate with a rounded corner cut with kerf compensation, a round hole, a slot), the part
origin in P1/P2, and a lift range over every travel between parts (a rapid, a cross-block
travel at F24000, or a single-block `Z[LIFT ..]`), POS_LIMIT chosen per job; now and then
a micro-joint hop shorter than lift_min_dist (suppressed). Job sizes are log-uniform from
MIN_PARTS to MAX_PARTS parts, so the library mixes a few large jobs with many small ones.
Deterministic: the same seed writes the same files.

Run: .venv/bin/python bench/gen_library.py DIR [N] [SEED]
"""

from __future__ import annotations

import math
import random
import sys
from pathlib import Path

MIN_PARTS, MAX_PARTS = 2, 16
SHEET_X, SHEET_Y = 1400.0, 900.0

SHAPES = {
    "plate": """%L plate
( plate P5 x P6 with one rounded corner R8, tool right = outside, lead-in from the left )
N1 M04
N2 G42 G01 X[P1] Y[P2+P6/2] F6000
N3 Y[P2]
N4 X[P1+P5]
N5 Y[P2+P6-8]
N6 G03 X[P1+P5-8] Y[P2+P6] I-8 J0
N7 G01 X[P1]
N8 Y[P2+P6/2]
N9 G40 X[P1-2] Y[P2+P6/2]
N10 M05
N11 M17
""",
    "hole": """%L hole
( hole of radius P7 around P1/P2, radial lead-in )
N20 M04
N21 G01 X[P1+P7] Y[P2] F3000
N22 G02 I-[P7] J0
N23 G01 X[P1] Y[P2]
N24 M05
N25 M17
""",
    "slot": """%L slot
( slot P5 long, P6 wide, semicircular ends )
N30 M04
N32 G01 X[P1+P5] F5000
N33 G03 X[P1+P5] Y[P2+P6] I0 J[P6/2]
N34 G01 X[P1]
N35 G03 X[P1] Y[P2] I0 J-[P6/2]
N36 M05
N37 M17
""",
}


def cam_job(index: int, rng: random.Random) -> str:
    parts = round(math.exp(rng.uniform(math.log(MIN_PARTS), math.log(MAX_PARTS))))
    limit = rng.choice((20, 30, 40, 60, 80))
    w, h = rng.choice(((40, 20), (60, 30), (80, 40), (30, 30)))
    pitch_x, pitch_y = w + rng.uniform(8, 40), h + rng.uniform(8, 40)
    cols = max(1, int(SHEET_X // pitch_x))
    out = [f"( generated nesting job {index}: {parts} parts, POS_LIMIT {limit} mm )"]
    out += SHAPES.values()
    out += [
        f"%job_{index:04d}",
        "N100 G90 G17 G71 G94",
        "N110 #SLOPE[TYPE=TRAPEZ]",
        "N120 D1",
        f"N130 P5={w} P6={h} P7=6",
        "N140 G00 X0 Y0 Z1",
    ]
    n = 200
    for k in range(parts):
        x = 30.0 + (k % cols) * pitch_x
        y = 20.0 + ((k // cols) * pitch_y) % (SHEET_Y - h - 20)  # a new sheet when full
        shape = rng.choices(("plate", "hole", "slot"), (6, 2, 2))[0]
        entry_x, entry_y = (x - 2, y + h / 2) if shape == "plate" else (x, y)
        n += 10
        out.append(f"N{n} P1={x:.3f} P2={y:.3f}")
        travel = rng.choices(("rapid", "cross", "single"), (4, 4, 2))[0]
        if k == 0:
            out.append(f"N{n + 1} G00 X{entry_x:.3f} Y{entry_y:.3f}")
        elif travel == "single":
            out.append(
                f"N{n + 1} G01 X{entry_x:.3f} Y{entry_y:.3f} F24000 Z[LIFT POS=1 POS_LIMIT={limit}]"
            )
        else:
            out.append(f"N{n + 1} Z[LIFT_START POS=1 POS_LIMIT={limit}]")
            if travel == "rapid":
                out.append(f"N{n + 2} G00 X{entry_x:.3f} Y{entry_y:.3f}")
            else:  # over two blocks, around the part just cut
                out.append(f"N{n + 2} G01 X{entry_x - 15:.3f} Y{entry_y + 12:.3f} F24000")
                out.append(f"N{n + 3} X{entry_x:.3f} Y{entry_y:.3f}")
            out.append(f"N{n + 4} Z[LIFT_END]")
        out.append(f"N{n + 5} LL {shape}")
        if shape == "plate" and rng.random() < 0.25:  # a micro-joint hop along the edge
            out.append(f"N{n + 6} G00 X{x + 4:.3f} Y{y:.3f}")
            out.append(f"N{n + 7} Z[LIFT_START POS=1 POS_LIMIT=20]")
            out.append(f"N{n + 8} G01 X{x + 7:.3f} F24000")
            out.append(f"N{n + 9} Z[LIFT_END]")
    out.append(f"N{n + 10} M30")
    return "\n".join(line.rstrip("\n") for line in out) + "\n"


def write_library(directory: Path, count: int, seed: int = 18) -> list[Path]:
    directory.mkdir(parents=True, exist_ok=True)
    rng = random.Random(seed)
    paths = []
    for i in range(count):
        path = directory / f"job_{i:04d}.nc"
        path.write_text(cam_job(i, rng))
        paths.append(path)
    return paths


if __name__ == "__main__":
    target = Path(sys.argv[1])
    n = int(sys.argv[2]) if len(sys.argv) > 2 else 200
    seed = int(sys.argv[3]) if len(sys.argv) > 3 else 18
    written = write_library(target, n, seed)
    print(f"{len(written)} programs in {target}")
