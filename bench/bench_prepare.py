"""What a PLC command costs the GEO cycle (issue 41), one JSON line per figure:

* `prepare_start` — the step time of a START after a RESET, with the caches cold (64 MiB
  written just before the step, as bench_step.py --cold): the run built in the START's cycle
  as before issue 41 (`in_cycle`), the run built off the cycle and offered as the GEO process
  does now (`prepared`), and a repeat START of the same program (`repeat`), min/p50/max µs.
* `prepare_burst` — the GEO loop reading 256 PLC writes queued at once: µs of each cycle that
  read some (INPUTS_PER_CYCLE a cycle), and of all of them read in one call as before.
* `prepare_gaps` — the preparation of a program (decode, plan, a run's state) in the
  preparer's thread: its CPU time and the longest stretch between two pause points
  (liftd/cnc/pause.py), thread CPU µs; the preparer's slice ends MARGIN before a deadline.

Run: .venv/bin/python bench/bench_prepare.py [--runs N]   (~2 min)
"""

from __future__ import annotations

import argparse
import gc
import json
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.gen import count_blocks, nesting_program  # noqa: E402
from liftd.cnc import pause as pause_points  # noqa: E402
from liftd.cnc.geo_task import GeoTask  # noqa: E402
from liftd.cnc.params import ChannelParams  # noqa: E402
from liftd.cnc.plc import (  # noqa: E402
    Schedule,
    SimPlc,
)
from liftd.cnc.snapshot import ChannelState, Command, GeoInputs, GeoSnapshot, PlcSignal  # noqa: E402
from liftd.settings import load_settings  # noqa: E402


def channel() -> ChannelParams:
    return load_settings(str(ROOT / "config" / "liftd.toml")).channel


def _stats(values: list[float]) -> dict[str, float]:
    v = sorted(values)
    return {"min": round(v[0], 1), "p50": round(statistics.median(v), 1), "max": round(v[-1], 1)}


def _run_until(task: GeoTask, plc: SimPlc, k: int, last: GeoSnapshot | None, stop: float,
               cmd: Command = Command.NONE) -> tuple[int, GeoSnapshot]:  # fmt: skip
    """Step `task` with the automatic PLC until time `stop` (or READY after a command)."""
    dt = task.dt
    first = True
    while True:
        k += 1
        inputs = plc.inputs(last, k * dt, Schedule())
        if first and cmd is not Command.NONE:
            inputs = GeoInputs(inputs.override, inputs.feed_hold, cmd, inputs.m_ack)
        first = False
        last = task.step(inputs, k * dt)
        if cmd is Command.NONE and k * dt >= stop:
            return k, last
        if cmd is not Command.NONE and last.state is ChannelState.READY:
            return k, last


def start_after_reset(name: str, text: str, runs: int) -> dict[str, object]:
    """RESET half a second into the program, then START: timed with the run built in the
    START's cycle, and with it built off the cycle and offered; a repeat START for scale; and
    the cycles of a PLC STOP and of a RESET in the program."""
    import numpy as np  # noqa: PLC0415

    ch = channel()
    flush = np.zeros((64 << 20) // 8)
    clock = time.perf_counter_ns
    times: dict[str, list[float]] = {"in_cycle": [], "prepared": [], "repeat": [],
                                     "reset": [], "stop": []}  # fmt: skip

    def timed(task: GeoTask, k: int, cmd: Command, kind: str) -> GeoSnapshot:
        gc.collect()
        gc.disable()
        flush[:] += 1.0
        c0 = clock()
        snap = task.step(GeoInputs(command=cmd), k * ch.cycle_time)
        times[kind].append((clock() - c0) / 1e3)
        gc.enable()
        return snap

    for r in range(runs):
        for how in ("in_cycle", "prepared"):
            task, plc = GeoTask(ch, text), SimPlc(0.02)
            k, last = _run_until(task, plc, 0, None, 0.5 + 0.01 * r)
            if how == "in_cycle":  # the PLC's STOP and RESET, each in a cycle of their own
                last = timed(task, k + 1, Command.STOP, "stop")
                k, last = _run_until(task, plc, k + 1, last, 0.6 + 0.01 * r)
                last = timed(task, k + 1, Command.RESET, "reset")
                k, last = _run_until(task, plc, k + 1, last, 0.0, Command.NONE)
                while last.state is not ChannelState.READY:
                    k += 1
                    last = task.step(GeoInputs(), k * ch.cycle_time)
            else:
                k, last = _run_until(task, plc, k, last, 0.0, Command.RESET)
            if how == "prepared":
                start = task.wants_run()
                assert start is not None
                task.offer_run(task.build_run(start))
            gc.collect()
            gc.disable()
            flush += 1.0
            k += 1
            c0 = clock()
            last = task.step(GeoInputs(command=Command.START), k * ch.cycle_time)
            times[how].append((clock() - c0) / 1e3)
            gc.enable()
            assert last.state is ChannelState.ACTIVE
        # a repeat START: the program run to its end with the next run built ahead
        task, plc = GeoTask(ch, text, autostart=False), SimPlc(0.02)
        task.prepare_next_run()
        k, last = 1, task.step(GeoInputs(command=Command.START), ch.cycle_time)
        while last.state is not ChannelState.READY:
            k += 1
            last = task.step(plc.inputs(last, k * ch.cycle_time, Schedule()), k * ch.cycle_time)
        for _ in range(400):  # the run after it is built a piece per cycle meanwhile
            k += 1
            last = task.step(GeoInputs(), k * ch.cycle_time)
        gc.collect()
        gc.disable()
        flush += 1.0
        k += 1
        c0 = clock()
        task.step(GeoInputs(command=Command.START), k * ch.cycle_time)
        times["repeat"].append((clock() - c0) / 1e3)
        gc.enable()
    return {"bench": "prepare_start", "program": name, "blocks": count_blocks(text),
            "runs": runs, "cold": True,
            **{f"{how}_us": _stats(v) for how, v in times.items()}}  # fmt: skip


def burst(n: int = 256, rounds: int = 20) -> dict[str, object]:
    """256 override writes queued in the input ring (one sum write), read by the loop."""
    from liftd.cnc.snapshot import PlcWrite  # noqa: PLC0415
    from liftd.runtime import geo_loop  # noqa: PLC0415
    from liftd.runtime.loop_config import ChannelConfig, LoopConfig  # noqa: PLC0415
    from liftd.runtime.records import pack_input  # noqa: PLC0415
    from liftd.runtime.shared import INPUT_CAPACITY, Shared  # noqa: PLC0415

    ch = channel()
    text = (ROOT / "config" / "programs" / "demo.nc").read_text()
    shared = Shared(len(ch.axes))
    cfg = LoopConfig(channels=(ChannelConfig(ch, text, "demo"),))
    loop = geo_loop.GeoLoop(shared, cfg, geo_loop._Events(shared.events), -1)
    per_cycle: list[float] = []
    all_at_once: list[float] = []
    clock = time.perf_counter_ns
    try:
        assert n <= INPUT_CAPACITY
        for r in range(rounds):
            for k in range(n):
                shared.inputs.put(pack_input(PlcWrite(PlcSignal.OVERRIDE, (500 + k + r) / 1000)))
            total, calls = 0, 0
            while True:
                c0 = clock()
                read = loop.read_inputs(1.0)
                took = clock() - c0
                if not read:
                    break
                calls += 1
                total += took
                per_cycle.append(took / 1e3)
                shared.events.take()  # the daemon's side
            all_at_once.append(total / 1e3)
            assert calls == -(-n // geo_loop.INPUTS_PER_CYCLE), calls
    finally:
        loop.preparer.close()
        shared.close()
    return {"bench": "prepare_burst", "writes": n, "rounds": rounds,
            "per_cycle": geo_loop.INPUTS_PER_CYCLE,
            "cycle_us": _stats(per_cycle), "all_in_one_cycle_us": _stats(all_at_once)}  # fmt: skip


def gaps(name: str, text: str) -> dict[str, object]:
    """The preparation of the run from a RESET position, as the preparer's thread runs it
    (here in the calling thread): its CPU time and the longest stretches between pauses."""
    ch = channel()
    task = GeoTask(ch, text, autostart=False)
    start = tuple(0.0005 for _ in ch.axes)
    clock = time.thread_time_ns
    stretches: list[int] = []
    last = [0]

    def hook() -> None:
        now = clock()
        stretches.append(now - last[0])
        last[0] = clock()

    gc.collect()
    gc.disable()
    pause_points.hook = hook
    try:
        c0 = last[0] = clock()
        run = task.build_run(start)  # kept: freeing it is not the preparation's work
        total = clock() - c0
        hook()
    finally:
        pause_points.hook = None
        gc.enable()
    del run
    stretches.sort()
    return {"bench": "prepare_gaps", "program": name, "blocks": count_blocks(text),
            "cpu_ms": round(total / 1e6, 1), "pauses": len(stretches),
            "stretch_us": {"p50": round(stretches[len(stretches) // 2] / 1e3, 1),
                           "p99": round(stretches[int(0.99 * (len(stretches) - 1))] / 1e3, 1),
                           "max": round(stretches[-1] / 1e3, 1)}}  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=20)
    args = ap.parse_args()
    demo = (ROOT / "config" / "programs" / "demo.nc").read_text()
    nest = nesting_program(500)
    for name, text in (("demo", demo), ("nesting-500", nest)):
        print(json.dumps(start_after_reset(name, text, args.runs)), flush=True)
    print(json.dumps(burst()), flush=True)
    for name, text in (
        ("demo", demo),
        ("nesting-500", nest),
        ("nesting-5000", nesting_program(5000)),
    ):
        print(json.dumps(gaps(name, text)), flush=True)


if __name__ == "__main__":
    main()
