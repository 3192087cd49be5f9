"""A cap that rises with the look-ahead window (issue 36, known deviation 3 of
docs/geo-core.md): how fast could any motion that keeps each window's stop reachable pass the
boundary? Wide seed 74, boundary 7 (0.2 mm blocks, a kink each, look-ahead 8) by default.

From the path's state at the run boundary before (as the GEO core passed it), a path steps
every DT with the highest jerk (+J, 0, −J) after which the boundary's cap under the window of
the segment it is in stays reachable with zero acceleration (the core's closed forms in
liftd/cnc/path/velocity.py); windows move as it enters each segment. Prints one JSON line:
the boundary's caps by window end, the velocity this greedy path reaches at the boundary and
the core's (v_path in the first cycle past it).

Run: .venv/bin/python bench/probe_window_rise.py [SEED BOUNDARY]
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from liftd.cnc.geo_task import GeoTask
from liftd.cnc.path import velocity as vel
from liftd.cnc.path.constraints import Constraints
from liftd.cnc.plc import SimPlc
from liftd.sim.simulate import run_cycles
from tests.support.scenarios import wide_scenario

DT = 2e-6  # s


def main() -> None:
    seed = int(sys.argv[1]) if len(sys.argv) > 1 else 74
    b = int(sys.argv[2]) if len(sys.argv) > 2 else 7
    sc = wide_scenario(seed)
    task = GeoTask(sc.channel, sc.text)
    tb = task.prog.table
    la = sc.channel.look_ahead_blocks
    start = max(k for k in range(b) if tb.gate[k])  # the run boundary before b
    state = None
    core_v = None
    for snap in run_cycles(task, SimPlc(0.02), sc.schedule, sc.channel.cycle_time, 600.0):
        ip = task.interp
        if state is None and ip.segment >= start and ip.s >= tb.s[start]:
            state = (ip.s, ip.v, ip.a, ip.override, set(ip.lift_stops), set(ip.acked_conditional))
        if ip.segment >= b:
            core_v = snap.v_path
            break
    assert state is not None
    s, v, a, ov, stops, acked = state
    con = Constraints(tb, la, stops, acked)
    con.ov = ov
    caps: dict[int, float] = {}
    for seg in range(start, b):
        con.seg = seg
        cands = con.collect(tb.s[seg] + 1e-9, seg, 1.0)
        i = next(k for k, c in enumerate(cands) if c[0] == b)
        caps[seg] = con.target_cap(cands, i)
    a_max, j_max = con.limits(b - 1)
    seg = start
    while s < tb.s[b]:
        while seg + 1 < b and tb.s[seg + 1] <= s:
            seg += 1
        for jerk in (j_max, 0.0, -j_max):
            a1 = min(max(a + jerk * DT, -a_max), a_max)
            v1 = v + 0.5 * (a + a1) * DT
            s1 = s + v * DT + (2.0 * a + a1) / 6.0 * DT * DT
            d = tb.s[b] - s1
            k = seg if seg + 1 >= b or tb.s[seg + 1] > s1 else seg + 1
            lo = vel.lowest_reachable_from(v1, a1, max(d, 0.0), a_max, j_max)
            if d <= 0.0 or (lo <= caps[k] * (1 + 1e-9)
                            and vel.brake_distance(v1, a1, lo, a_max, j_max) <= d + 1e-12):  # fmt: skip
                break
        s, v, a = s1, v1, a1
    print(json.dumps({
        "bench": "probe_window_rise", "seed": seed, "boundary": b,
        "caps_mm_s_by_window_end": {str(k + la): round(c * 1e3, 3) for k, c in caps.items()},
        "greedy_mm_s": round(v * 1e3, 3), "greedy_a": round(a, 4),
        "core_mm_s": round((core_v or 0.0) * 1e3, 3),
    }))  # fmt: skip


if __name__ == "__main__":
    main()
