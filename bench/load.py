"""Client load against a running `liftd run`, one OS process per client (AdsLib shares one TCP
connection among all pyads Connections of a process, so separate clients need processes).

- poller: reads lift_active by IG/IO on a fixed period (1 kHz = a PLC task polling every
  cycle) and records each request's latency;
- notifier: subscribes K on-change notifications (lift status, positions, counters) and
  records every lift_active sample and the gaps between GEO.cycle samples.

Each returns a dict through a queue; the benches aggregate them.
"""

from __future__ import annotations

import csv
import ctypes
import itertools
import multiprocessing as mp
import queue
import time
from pathlib import Path
from typing import Any

import numpy as np
import pyads

NOTIFY_SYMBOLS = [
    "GEO.ch1.Z.lift_active", "GEO.ch1.Z.lift_suppressed", "GEO.ch1.X.lift_active",
    "GEO.ch1.X.lift_suppressed", "GEO.ch1.Y.lift_active", "GEO.ch1.Y.lift_suppressed",
    "GEO.ch1.X.command_position", "GEO.ch1.Y.command_position", "GEO.ch1.Z.command_position",
    "GEO.ch1.state", "GEO.ch1.line", "GEO.ch1.block", "GEO.ch1.override", "GEO.ch1.feed_hold",
    "GEO.ch1.path_velocity", "GEO.ch1.Z.lift_phase", "GEO.ch1.error_id", "GEO.ch1.m_pending",
    "GEO.timing.exceeded", "GEO.cycle",
]  # fmt: skip
TYPES = {"lift_active": pyads.PLCTYPE_BOOL, "lift_suppressed": pyads.PLCTYPE_BOOL,
         "feed_hold": pyads.PLCTYPE_BOOL, "command_position": pyads.PLCTYPE_DINT,
         "path_velocity": pyads.PLCTYPE_LREAL, "cycle": pyads.PLCTYPE_ULINT,
         "override": pyads.PLCTYPE_UINT, "lift_phase": pyads.PLCTYPE_UINT,
         "m_pending": pyads.PLCTYPE_DINT}  # fmt: skip


def _type(symbol: str) -> Any:
    return TYPES.get(symbol.rsplit(".", 1)[1], pyads.PLCTYPE_UDINT)


def percentiles_us(ns: np.ndarray) -> dict[str, float]:
    if not len(ns):
        return {}
    q = np.percentile(ns, [50, 99, 99.9]) / 1e3
    return {"p50": round(q[0], 1), "p99": round(q[1], 1), "p99.9": round(q[2], 1),
            "max": round(float(ns.max()) / 1e3, 1)}  # fmt: skip


def poller(net_id: str, address: str, period_s: float, duration_s: float, out: Any) -> None:
    plc = pyads.Connection(net_id, 551, address)
    plc.open()
    lat = np.zeros(int(duration_s / (period_s or 20e-6)) + 10, dtype=np.int64)
    n = errors = 0
    t0 = time.perf_counter()
    next_t = t0
    try:
        while True:
            now = time.perf_counter()
            if now - t0 >= duration_s:
                break
            a = time.perf_counter_ns()
            try:
                plc.read(0x121301, 0x30095, pyads.PLCTYPE_BOOL)
            except pyads.ADSError:
                errors += 1
            if n < len(lat):
                lat[n] = time.perf_counter_ns() - a
            n += 1
            if period_s:
                next_t += period_s
                wait = next_t - time.perf_counter()
                if wait > 0:
                    time.sleep(wait)
                else:
                    next_t = time.perf_counter()
    finally:
        plc.close()
    wall = time.perf_counter() - t0
    out.put({"kind": "poller", "reads": n, "errors": errors, "rate": n / wall,
             "latency_us": percentiles_us(lat[: min(n, len(lat))])})  # fmt: skip


def notifier(net_id: str, address: str, cycle_ms: int, duration_s: float, out: Any,
             subscriptions: int = len(NOTIFY_SYMBOLS)) -> None:  # fmt: skip
    plc = pyads.Connection(net_id, 551, address)
    plc.open()
    lift: list[tuple[int, bool]] = []  # (the GEO cycle last notified, lift_active)
    cycle_t: list[float] = []
    count = [0]
    last_cycle = [0]
    first_cycle = [0]

    def on(symbol: str) -> Any:
        plc_type = _type(symbol)

        def callback(notification: Any, _name: str) -> None:
            _, _, value = plc.parse_notification(notification, plc_type)
            count[0] += 1
            if symbol == "GEO.ch1.Z.lift_active":
                lift.append((last_cycle[0], bool(value)))
            elif symbol == "GEO.cycle":
                cycle_t.append(time.perf_counter())
                last_cycle[0] = int(value)
                first_cycle[0] = first_cycle[0] or int(value)

        return callback

    handles = []
    symbols = [*NOTIFY_SYMBOLS[: subscriptions - 1], "GEO.cycle"]
    for symbol in dict.fromkeys(symbols):
        attr = pyads.NotificationAttrib(ctypes.sizeof(_type(symbol)),
                                        trans_mode=pyads.ADSTRANS_SERVERONCHA,
                                        cycle_time=cycle_ms)  # fmt: skip
        handles.append(plc.add_device_notification(symbol, attr, on(symbol)))
    time.sleep(duration_s)
    for h in handles:
        plc.del_device_notification(*h)
    plc.close()
    changes = [c for (_, a), (c, b) in itertools.pairwise(lift) if a != b]
    gaps = np.diff(np.array(cycle_t)) * 1e3 if len(cycle_t) > 1 else np.zeros(1)
    out.put({"kind": "notifier", "subscriptions": len(handles), "samples": count[0],
             "lift_active_samples": len(lift), "lift_active_changes_at": changes,
             "cycles_seen": [first_cycle[0], last_cycle[0]],
             "cycle_gap_ms": {"p50": round(float(np.median(gaps)), 2),
                              "p99": round(float(np.percentile(gaps, 99)), 2),
                              "max": round(float(gaps.max()), 2)}})  # fmt: skip


def start(
    net_id: str, address: str, duration_s: float, pollers: int, poll_hz: float,
    notifiers: int, cycle_ms: int, subscriptions: int = len(NOTIFY_SYMBOLS),
) -> tuple[list[mp.Process], Any]:  # fmt: skip
    ctx = mp.get_context("spawn")
    out = ctx.Queue()
    procs = [ctx.Process(target=poller, args=(net_id, address, 1 / poll_hz if poll_hz else 0.0,
                                              duration_s, out)) for _ in range(pollers)]  # fmt: skip
    procs += [ctx.Process(target=notifier, args=(net_id, address, cycle_ms, duration_s, out,
                                                 subscriptions)) for _ in range(notifiers)]  # fmt: skip
    for p in procs:
        p.start()
    return procs, out


def collect(procs: list[mp.Process], out: Any, timeout_s: float) -> list[dict[str, Any]]:
    results = []
    end = time.monotonic() + timeout_s
    while len(results) < len(procs) and time.monotonic() < end:
        try:
            results.append(out.get(timeout=1.0))
        except queue.Empty:
            continue
    for p in procs:
        p.join(5)
        if p.is_alive():
            p.kill()
    return results


def lift_changes(trace: Path, first: int, last: int, dt: float = 1e-3) -> int:
    """lift_active changes in the trace between two GEO cycles."""
    changes, prev = 0, None
    with trace.open() as f:
        for row in csv.DictReader(f):
            k = round(float(row["t"]) / dt)
            if k < first:
                prev = row["lift_active"]
                continue
            if k > last:
                break
            changes += prev is not None and row["lift_active"] != prev
            prev = row["lift_active"]
    return changes


def lost_changes(notifiers: list[dict[str, Any]], trace: Path) -> int:
    """lift_active changes in the trace that a notification client did not see (or saw extra),
    summed over clients, over the GEO cycles each client covered."""
    lost = 0
    for r in notifiers:
        first, last = r["cycles_seen"]
        margin = 25  # a lift sample is tagged with the GEO.cycle notified before it (±10 ms)
        seen = sum(1 for c in r["lift_active_changes_at"] if first + margin <= c <= last - margin)
        lost += abs(lift_changes(trace, first + margin, last - margin) - seen)
    return lost
