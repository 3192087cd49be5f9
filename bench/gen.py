"""Generated NC programs for benchmarks and tests: nesting jobs of many small parts."""

from __future__ import annotations

import math


def nesting_program(parts: int, lines_per_part: int = 6, arcs: bool = True) -> str:
    """A job of `parts` small parts on a grid: each part is cut (G01/G03), then Z lifts over a
    cross-block travel of two blocks to the next part. Roughly (lines_per_part + 6) blocks/part."""
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
            out.append(f"G01 X{x0 + i * step:.3f} Y{y0:.3f} F6000")
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
