"""Path velocity on straight polylines of short blocks against the look-ahead bound (issue 14
item 6): blocks of 0.2, 0.5 and 2 mm at F12000 … F60000 under every look-ahead setting
(FCT_LOOK_AHEAD_LOW 30, STANDARD 120, HIGH 190 blocks; CUSTOM at its vendor maximum 200).

The bound is min(F, the axis caps of the table, the velocity from which the path can stop
within the look-ahead: the window ends `look_ahead` segments after the current one, so from
a block boundary at least (look_ahead − 1) blocks lie ahead of the path). Figure to reach:
the lowest path velocity in the middle of the 300 mm line ≥ 95 % of the bound. Also prints
the worst |v|, |a|, |j| / limit of any axis (finite differences) per run.

Run: .venv/bin/python bench/bench_velocity.py   (~1 min)
"""

from __future__ import annotations

import dataclasses
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.cli import parser  # noqa: E402
from liftd.cnc.path.velocity import reach_velocity  # noqa: E402
from liftd.settings import load_settings  # noqa: E402
from tests.support.closed_loop import fd_ratios, run_task  # noqa: E402

LOOK_AHEAD = {"LOW": 30, "STANDARD": 120, "HIGH": 190, "CUSTOM-200": 200}
STEPS_MM = (0.2, 0.5, 2.0)
FEEDS = (12000, 24000, 36000, 48000, 60000)
LINE_M = 0.3


def main() -> None:
    parser(__doc__).parse_args()
    base = load_settings(str(ROOT / "config" / "liftd.toml")).channel
    worst = 1e9
    for setting, look in LOOK_AHEAD.items():
        ch = dataclasses.replace(base, look_ahead_blocks=look)
        for step in STEPS_MM:
            n = round(LINE_M * 1e3 / step)
            for feed in FEEDS:
                text = (
                    "G90 G17 G94\nG01 X10 Y10 Z1 F6000\n"
                    + f"G01 X{10 + step:.4f} F{feed}\n"
                    + "".join(f"X{10 + (i + 1) * step:.4f}\n" for i in range(1, n))
                    + "M30\n"
                )
                task, snaps = run_task(ch, text, max_time=60)
                tb = task.prog.table
                k = 5  # a segment of the line (they are all alike)
                a_max, j_max = tb.run_a[tb.run[k]], tb.run_j[tb.run[k]]
                stop = reach_velocity(0.0, (look - 1) * step * 1e-3, a_max, j_max)
                bound = min(feed / 60_000, tb.cap[k], stop)
                lo, hi = 0.010 + LINE_M / 3, 0.010 + 2 * LINE_M / 3
                mid = [s.v_path for s in snaps if s.segment >= 2 and lo < s.positions[0] < hi]
                ratio = min(mid) / bound
                worst = min(worst, ratio)
                print(
                    json.dumps(
                        {
                            "bench": "velocity",
                            "look_ahead": setting,
                            "blocks_ahead": look,
                            "block_mm": step,
                            "feed_mm_min": feed,
                            "bound_mm_s": round(bound * 1e3, 2),
                            "bound_by": (
                                "feed"
                                if bound == feed / 60_000
                                else "axes"
                                if bound == tb.cap[k]
                                else "look-ahead"
                            ),
                            "v_min_mid_mm_s": round(min(mid) * 1e3, 2),
                            "ratio": round(ratio, 4),
                            "limits_max": round(float(fd_ratios(ch, snaps).max()), 9),
                        }
                    ),
                    flush=True,
                )
    print(
        json.dumps(
            {
                "bench": "velocity_summary",
                "runs": len(LOOK_AHEAD) * 15,
                "worst_ratio": round(worst, 4),
                "target": 0.95,
            }
        )
    )


if __name__ == "__main__":
    main()
