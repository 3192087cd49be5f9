"""More constraints within the braking distance than the tracker plans at once
(`constraints.MAX_CANDIDATES`, 24): each one beyond is bounded by the table's per-run minima
and the end of its run (`Constraints._cut_bound`), never taken as a stop (issue 36, known
deviation 1 of docs/geo-core.md)."""

from __future__ import annotations

import dataclasses

from tests.support.motion_check import check_motion
from tests.unit.cnc.path.test_no_invented_stops import lowest_between, run, shipped


def alternating(blocks: int, step_mm: float, high: int, low: int) -> str:
    """Collinear blocks whose feed alternates: a feed drop at every second boundary."""
    lines = ["G01 X0 Y0 F600"]
    for i in range(blocks):
        lines.append(f"G01 X{(i + 1) * step_mm:.4f} F{high if i % 2 else low}")
    return "\n".join([*lines, "M30"]) + "\n"


def test_the_24th_feed_drop_in_reach_is_not_a_stop() -> None:
    """400 blocks of 0.2 mm at F30000 / F60000 (a drop every 0.4 mm), look-ahead 200: at
    500 mm/s the path needs ~17 mm to brake, 40 drops are in reach. With the 24th counted as a
    stop (9.6 mm ahead) the path ran at 313.9 mm/s, came to rest at 49.6 mm (boundary 247)
    and took 0.382 s; it runs at the low feed now and takes 0.262 s."""
    ch = dataclasses.replace(shipped(), look_ahead_blocks=200, cycle_time=1e-3)
    rec = run(alternating(400, 0.2, 60000, 30000), ch)
    found = check_motion(rec.program, rec.table, 200, ch.cycle_time, rec.samples)
    assert found == []
    assert lowest_between(rec, 20.0, 50.0) >= 0.999 * 500.0
