"""Generated NC programs for the tests and the benchmarks: nesting jobs of many small parts
(bench/ imports them from here; moved from bench/gen.py, issue 40)."""

from __future__ import annotations

import math


def nesting_program(
    parts: int, lines_per_part: int = 6, arcs: bool = True, cut_feed: int = 6000
) -> str:
    """A job of `parts` small parts on a grid: each part is cut (G01/G03, F`cut_feed` mm/min),
    then Z lifts over a cross-block travel of two blocks to the next part. Roughly
    (lines_per_part + 6) blocks/part."""
    out = ["%gen", "N1 G90 G17 G94", "#SLOPE[TYPE=TRAPEZ]", "G00 X10 Y10 Z1"]
    cols = max(1, min(160, int(math.sqrt(parts * 3))))
    pitch = 18.0
    for k in range(parts):
        x0 = 10.0 + (k % cols) * pitch
        y0 = 10.0 + (k // cols) * pitch
        if k:
            out.append("M05")
            out.append("Z[LIFT_START POS=1 POS_LIMIT=30]")
            out.append(f"G01 X{x0 - 5:.3f} Y{y0 + 2:.3f} F24000")
            out.append(f"X{x0:.3f} Y{y0:.3f}")
            out.append("Z[LIFT_END]")
        out.append("M04")
        step = 12.0 / lines_per_part
        for i in range(1, lines_per_part + 1):
            out.append(f"G01 X{x0 + i * step:.3f} Y{y0:.3f} F{cut_feed}")
        if arcs:
            out.append(f"G03 X{x0 + 12:.3f} Y{y0 + 10:.3f} R5")
        else:
            out.append(f"G01 X{x0 + 12:.3f} Y{y0 + 10:.3f}")
        out.append(f"G01 X{x0:.3f} Y{y0:.3f}")
    out.append("M05")
    out.append("M30")
    return "\n".join(out) + "\n"


def count_blocks(text: str) -> int:
    return sum(1 for line in text.splitlines() if line and not line.startswith(("%", "(")))


PART_SUBROUTINE = """%L part
( one part at P1/P2; the caller travels to the pierce point X[P1-2] Y[P2+P3/2] )
( pierce, contour with a rounded corner and a radius; P3..P6 the part's dimensions )
N1 M04
N2 G01 X[P1] Y[P2+P3/2] F6000
N3 Y[P2+P3-P4]
N4 G02 X[P1+P4] Y[P2+P3] I[P4] J0
N5 G01 X[P1+P3]
N6 Y[P2]
N7 X[P1+P5]
N8 G03 X[P1+P5+2*P6] Y[P2] R[P6]
N9 G01 X[P1]
N10 Y[P2+P3/2]
N11 X[P1+2] Y[P2+P3/2+1]
N12 M05
N13 M17
"""
KERF = {"N2 G01": "N2 G41 G01", "N11 X": "N11 G40 X"}  # the same part, kerf-compensated


def _part(kerf: bool) -> str:
    text = PART_SUBROUTINE
    if kerf:
        for old, new in KERF.items():
            text = text.replace(old, new)
    return text


def subroutine_program(parts: int, kerf: bool = False) -> str:
    """A CAM-shaped nesting job: one local subroutine per part shape, called once per
    placement with the position in P1/P2 (expressions in every coordinate), a lifted
    travel to each pierce point; `kerf`: the contour under G41/G40 with D1. 15 executed
    blocks per placement from 6 main-program lines."""
    cols = max(1, min(160, int(math.sqrt(parts * 3))))
    pitch = 16.0
    out = [
        _part(kerf) + "%nest",
        "N1 G90 G17 G71 G94",
        "#SLOPE[TYPE=TRAPEZ]",
        "D1",
        "P3=10 P4=2 P5=3 P6=2",
        "G00 X5 Y5 Z1",
    ]
    for k in range(parts):
        x = 10.0 + (k % cols) * pitch
        y = 10.0 + (k // cols) * pitch
        out.append(f"P1={x:.3f} P2={y:.3f}")
        out.append("Z[LIFT_START POS=1 POS_LIMIT=30]")
        out.append("G00 X[P1-2] Y[P2+P3/2]")
        out.append("Z[LIFT_END]")
        out.append("LL part")
    out.append("M30")
    return "\n".join(out) + "\n"


def repeated_program(placements: int, kerf: bool = False) -> str:
    """The same job from a text of fixed size: one placement programmed once and repeated
    with L SEQUENCE [.. REPEAT=n], the position computed from a counter (a grid of 160 x 80
    places on the table). The expansion grows with `placements`, the text does not."""
    return (
        "\n".join(
            [
                _part(kerf) + "%grid",
                "N100 G90 G17 G71 G94",
                "N110 #SLOPE[TYPE=TRAPEZ]",
                "N120 D1 P3=10 P4=2 P5=3 P6=2 P9=0",
                "N130 G00 X5 Y5 Z1",
                "N200 P1=10+[P9 MOD 160]*16 P2=10+[INT[P9/160] MOD 80]*16",
                "N210 Z[LIFT_START POS=1 POS_LIMIT=30]",
                "N220 G00 X[P1-2] Y[P2+P3/2]",
                "N230 Z[LIFT_END]",
                "N240 LL part",
                "N250 P9=P9+1",
                f"N300 L SEQUENCE [N200 N250 REPEAT={max(1, placements - 1)}]",
                "N310 M30",
            ]
        )
        + "\n"
    )
