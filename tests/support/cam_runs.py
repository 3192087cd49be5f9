"""One run of a scenario through the per-cycle motion check and the cycle checker (`check`),
and the GEO core's program time on its own interpolator (`core_time`): what
bench/bench_cam_motion.py and bench/bench_reference.py count over thousands of programs and
tests/unit/cnc/path/ over a derandomised sample (issue 36). Moved from bench/ (issue 40: the
tests hold the checker, bench imports it)."""

from __future__ import annotations

from liftd.cnc.geo_task import GeoTask
from liftd.cnc.path.interpolator import Interpolator
from liftd.cnc.path.table import PathTable
from liftd.cnc.plc import SimPlc
from liftd.cnc.snapshot import GeoSnapshot
from liftd.sim.simulate import run_cycles
from tests.support.cycle_check import violations
from tests.support.motion_check import Recorder
from tests.support.scenarios import Scenario

MIN_RUN_TIME = 300.0  # s: a run's time limit, at least (holds, dwells, waits for M functions)


def time_limit(tb: PathTable, sc: Scenario) -> float:
    """How long a run may take before it counts as not ending: twice the program's time at its
    ceilings (F × override, the axes' caps) under the schedule's lowest override above 0, plus
    10 s, and at least MIN_RUN_TIME. A fixed 300 s cut the CAM runs of 43–151 s programs at
    10–37 % override (seeds 260, 437, 490, 608, 642, 657, 984) before their end."""
    ov = min((f for _, f in sc.schedule.override if f > 0.0), default=1.0)
    nominal = 0.0
    for k in range(tb.n):
        v = tb.ceiling(k, ov)
        if v > 0.0:
            nominal += (tb.s[k + 1] - tb.s[k]) / v
    return max(MIN_RUN_TIME, 2.0 * nominal + 10.0)


def check(sc: Scenario) -> tuple[int, list[str], list[str], int]:
    """(cycles, hard problems, slowdowns, tracker errors) of one run."""
    task = GeoTask(sc.channel, sc.text)
    rec = Recorder(task)
    snaps: list[GeoSnapshot] = []
    limit = time_limit(task.prog.table, sc)
    for snap in run_cycles(task, SimPlc(0.02), sc.schedule, sc.channel.cycle_time, limit):
        rec(snap)
        snaps.append(snap)
    found = rec.check()
    hard = [p for p in found if p.startswith(("rest", "stopped", "overrun"))]
    hard += violations(sc, snaps, task.lift.records)
    if task.interp.plan_errors:
        hard.append(f"{task.interp.plan_errors} tracker errors: {task.interp.last_plan_error}")
    slow = [p for p in found if not p.startswith(("rest", "stopped", "overrun"))]
    return len(snaps), hard, slow, task.interp.plan_errors


def apart(hard: list[str]) -> tuple[list[str], list[str]]:
    """(the overruns, the other hard problems) of a run: tests whose run has a known overrun
    (docs/geo-core.md, known deviation 10's remainder) assert it apart from everything else."""
    over = [p for p in hard if p.startswith("overrun")]
    return over, [p for p in hard if not p.startswith("overrun")]


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
