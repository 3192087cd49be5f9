"""A PLC RESET inside a lift range, at a random moment of a random range, over the scenarios
of `bench_lift_safety.py --wide`: READY must come within 3 s with the lift ended (flags FALSE,
phase NONE), and from the RESET on Z within its own v, a, j (finite differences). Prints one
JSON line: runs, failures, the longest wait from RESET to READY.

With --nc-error an NC error takes the RESET's place: an unknown word in a random block of a
random range (vendor §2.4: Z rises to POS_LIMIT and stays). ERROR must come, and `simulate`'s
driver end with Z at rest at the range's maximum lift height (POS_LIMIT, or the start or POS
beyond it: §2.1.1, issue 37), never moving toward the part from the error on, within its v, a,
j (before e53490e Z lost the motion between the path's stop and its own last cycle in one
cycle).

Run: .venv/bin/python bench/bench_reset.py [--nc-error] [RUNS [FIRST_SEED [advanced|lifting]]]
"""

from __future__ import annotations

import json
import random
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench.cli import parser
from bench.stress_cases import Scenario, wide_scenario
from liftd.cnc.geo_task import GeoTask
from liftd.cnc.params import LiftMethod
from liftd.cnc.plc import SimPlc
from liftd.cnc.snapshot import ChannelState, Command, GeoSnapshot
from tests.support.closed_loop import run_task


def reset_in_a_range(
    seed: int, method: LiftMethod
) -> tuple[float, float | None, GeoSnapshot, float] | None:
    """(t of the RESET, t of READY or None, the last snapshot, Z's largest v/a/j ratio from
    the RESET on); None without a lift range."""
    sc = wide_scenario(seed, method)
    ref, _ = run_task(sc.channel, sc.text, sc.schedule, max_time=300)
    rnd = random.Random(seed)
    if not ref.lift.records:
        return None
    rec = rnd.choice(ref.lift.records)
    t_reset = rec.t_start + rnd.uniform(0.0, rec.t_end - rec.t_start)
    dt = sc.channel.cycle_time
    task, plc = GeoTask(sc.channel, sc.text), SimPlc(0.02)
    last: GeoSnapshot | None = None
    sent = False
    after: list[GeoSnapshot] = []  # from three cycles before the RESET on
    for k in range(1, round((t_reset + 3.0) / dt) + 2):
        t = k * dt
        inputs = plc.inputs(last, t, sc.schedule)
        if not sent and t >= t_reset:
            inputs, sent = inputs._replace(command=Command.RESET), True
        last = task.step(inputs, t)
        if t >= t_reset - 3.5 * dt:
            after.append(last)
        if sent and last.state is ChannelState.READY:
            return t_reset, t, last, z_ratio(sc, after)
    assert last is not None
    return t_reset, None, last, z_ratio(sc, after)


def z_ratio(sc: Scenario, snaps: list[GeoSnapshot]) -> float:
    """The largest |v|/v_max, |a|/a_max, |j|/j_max of Z over the snapshots; path-based
    Lifting's Z, following the braking path, as `stress_cases.violations` bounds it (v, and a
    up to a_max·(1 + P442/1000·override²); its jerk is not bounded by the method)."""
    z = np.array([s.positions[2] for s in snaps])
    ax, dt = sc.channel.axes[2], sc.channel.cycle_time
    v = np.diff(z) / dt
    a = np.diff(v) / dt
    j = np.diff(a) / dt
    limits = [(v, ax.v_max), (a, ax.a_max), (j, ax.j_max)]
    if sc.channel.lift_method is LiftMethod.LIFTING:
        ov = max([1.0, *(f for _, f in sc.schedule.override)])
        limits = [(v, ax.v_max), (a, ax.a_max * (1.0 + ax.dyn_a_err * ov * ov))]
    return max(float(np.abs(x).max(initial=0.0)) / lim for x, lim in limits)


def nc_error_in_a_range(seed: int, method: LiftMethod) -> dict[str, object] | None:
    """What went wrong when an NC error stops the program inside a random range ({} for
    nothing); None without a range to put it in."""
    sc = wide_scenario(seed, method)
    ref, _ = run_task(sc.channel, sc.text, sc.schedule, max_time=300)
    ranges = [r for r in ref.lift.records if r.range.end_line > r.range.start.line + 1]
    if not ranges:
        return None
    rnd = random.Random(seed)
    rng = rnd.choice(ranges).range
    lines = sc.text.splitlines()
    at = rnd.randrange(rng.start.line, rng.end_line - 1)  # after LIFT_START, before LIFT_END
    text = "\n".join([*lines[:at], "Q1 oops", *lines[at:]]) + "\n"
    _, snaps = run_task(sc.channel, text, sc.schedule, max_time=300)
    last = snaps[-1]
    k = next((i for i, s in enumerate(snaps) if s.state is ChannelState.ERROR), None)
    problems: dict[str, object] = {}
    if k is None or last.state is not ChannelState.ERROR:
        problems["state"] = last.state.name
        return problems
    if last.lift_vz != 0.0 or last.lift_az != 0.0:
        problems["z_moving_at_end"] = (last.lift_vz, last.lift_az)
    spec = rng.start
    # the maximum lift height: POS_LIMIT, raised to the start or POS beyond it (vendor §2.1.1;
    # issue 37 item 1), mirrored for DOWN; and from the error on Z never moves toward the part
    far = min if spec.down else max
    top = far(spec.pos_limit, spec.target, spec.z_start)
    if abs(last.positions[2] - top) > 1e-9:
        problems["z_end"] = (last.positions[2], top)
    sign = -1.0 if spec.down else 1.0
    z = np.array([sign * s.positions[2] for s in snaps[k:]])
    if np.diff(z).min(initial=0.0) < -1e-12:
        problems["z_toward_the_part"] = float(np.diff(z).min())
    ratio = z_ratio(sc, snaps)
    if ratio > 1.0 + 1e-6:
        problems["z_limit_ratio"] = ratio
    return problems


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("runs", nargs="?", type=int, default=300)
    ap.add_argument("first_seed", nargs="?", type=int, default=0)
    ap.add_argument("method", nargs="?", default="advanced", choices=["advanced", "lifting"])
    ap.add_argument("--nc-error", action="store_true", help="an NC error instead of the RESET")
    args = ap.parse_args()
    method = LiftMethod(args.method)
    t0 = time.perf_counter()
    if args.nc_error:
        runs, failures = 0, []
        for seed in range(args.first_seed, args.first_seed + args.runs):
            problems = nc_error_in_a_range(seed, method)
            if problems is None:
                continue
            runs += 1
            if problems:
                failures.append({"seed": seed, **problems})
        print(json.dumps({"bench": "nc_error_in_a_range", "method": method.value, "runs": runs,
                          "failed_runs": len(failures), "first_failures": failures[:5],
                          "seconds": round(time.perf_counter() - t0, 1)}))  # fmt: skip
        return
    runs, failures, waits = 0, [], []
    for seed in range(args.first_seed, args.first_seed + args.runs):
        got = reset_in_a_range(seed, method)
        if got is None:
            continue
        runs += 1
        t_reset, t_ready, last, ratio = got
        if (t_ready is None or last.lift_active or last.lift_suppressed or last.lift_phase != 0
                or ratio > 1.0 + 1e-6):  # fmt: skip
            failures.append({"seed": seed, "t_reset": t_reset, "state": last.state.name,
                             "z_limit_ratio": ratio})  # fmt: skip
        else:
            waits.append(t_ready - t_reset)
    print(json.dumps({"bench": "reset_in_a_range", "method": method.value, "runs": runs,
                      "failed_runs": len(failures), "first_failures": failures[:5],
                      "max_wait_s": round(max(waits, default=0.0), 4),
                      "seconds": round(time.perf_counter() - t0, 1)}))  # fmt: skip


if __name__ == "__main__":
    main()
