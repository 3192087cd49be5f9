"""One run of a scenario through the per-cycle motion check and the cycle checker (`check`),
and the GEO core's program time on its own interpolator (`core_time`): what
bench/bench_cam_motion.py and bench/bench_reference.py count over thousands of programs and
tests/unit/cnc/path/ over a derandomised sample (issue 36). Moved from bench/ (issue 40: the
tests hold the checker, bench imports it)."""

from __future__ import annotations

from liftd.cnc.geo_task import GeoTask
from liftd.cnc.path.interpolator import Interpolator
from liftd.cnc.plc import SimPlc
from liftd.cnc.snapshot import GeoSnapshot
from liftd.sim.simulate import run_cycles
from tests.support.cycle_check import violations
from tests.support.motion_check import Recorder
from tests.support.scenarios import Scenario


def check(sc: Scenario) -> tuple[int, list[str], list[str], int]:
    """(cycles, hard problems, slowdowns, tracker errors) of one run."""
    task = GeoTask(sc.channel, sc.text)
    rec = Recorder(task)
    snaps: list[GeoSnapshot] = []
    for snap in run_cycles(task, SimPlc(0.02), sc.schedule, sc.channel.cycle_time, 300.0):
        rec(snap)
        snaps.append(snap)
    found = rec.check()
    hard = [p for p in found if p.startswith(("rest", "stopped"))]
    hard += violations(sc, snaps, task.lift.records)
    if task.interp.plan_errors:
        hard.append(f"{task.interp.plan_errors} tracker errors: {task.interp.last_plan_error}")
    slow = [p for p in found if not p.startswith(("rest", "stopped"))]
    return len(snaps), hard, slow, task.interp.plan_errors


def core_time(task: GeoTask, ov: float) -> tuple[float, int]:
    """(seconds from the start to the program's end, tracker errors) of the core's path."""
    prog = task.prog
    ch = task.ch
    ip = Interpolator(prog.path, prog.table, ch.look_ahead_blocks, ch.cycle_time, 300)
    ip.set_inputs(ov, False)
    ip.resume(0.0)
    end = prog.table.n
    t = 0.0
    k = 0
    while k < 10_000_000:
        k += 1
        t = k * ch.cycle_time
        for c in ip.advance(t):
            if c.boundary == end:
                return c.t, ip.plan_errors
        if ip.stopped_at is not None and ip.stopped_at != end:
            ip.resume(t)  # a wait (none in the corpus but the end): go on at once
    return float("inf"), ip.plan_errors
