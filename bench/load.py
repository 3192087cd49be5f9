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

LIFT_SYMBOLS = ("GEO.ch1.Z.lift_active", "GEO.ch1.Z.lift_suppressed")
NOTIFY_SYMBOLS = [
    "GEO.ch1.Z.lift_active",
    "GEO.ch1.Z.lift_suppressed",
    "GEO.ch1.X.lift_active",
    "GEO.ch1.X.lift_suppressed",
    "GEO.ch1.Y.lift_active",
    "GEO.ch1.Y.lift_suppressed",
    "GEO.ch1.X.command_position",
    "GEO.ch1.Y.command_position",
    "GEO.ch1.Z.command_position",
    "GEO.ch1.state",
    "GEO.ch1.line",
    "GEO.ch1.block",
    "GEO.ch1.override",
    "GEO.ch1.feed_hold",
    "GEO.ch1.path_velocity",
    "GEO.ch1.Z.lift_phase",
    "GEO.ch1.error_id",
    "GEO.ch1.m_pending",
    "GEO.timing.exceeded",
    "GEO.cycle",
]
TYPES = {
    "lift_active": pyads.PLCTYPE_BOOL,
    "lift_suppressed": pyads.PLCTYPE_BOOL,
    "feed_hold": pyads.PLCTYPE_BOOL,
    "command_position": pyads.PLCTYPE_DINT,
    "path_velocity": pyads.PLCTYPE_LREAL,
    "cycle": pyads.PLCTYPE_ULINT,
    "override": pyads.PLCTYPE_UINT,
    "lift_phase": pyads.PLCTYPE_UINT,
    "m_pending": pyads.PLCTYPE_DINT,
}


def _type(symbol: str) -> Any:
    return TYPES.get(symbol.rsplit(".", 1)[1], pyads.PLCTYPE_UDINT)


def percentiles_us(ns: np.ndarray) -> dict[str, float]:
    if not len(ns):
        return {}
    q = np.percentile(ns, [50, 99, 99.9]) / 1e3
    return {
        "p50": round(q[0], 1),
        "p99": round(q[1], 1),
        "p99.9": round(q[2], 1),
        "max": round(float(ns.max()) / 1e3, 1),
    }


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
    out.put(
        {
            "kind": "poller",
            "reads": n,
            "errors": errors,
            "rate": n / wall,
            "latency_us": percentiles_us(lat[: min(n, len(lat))]),
        }
    )


OVERRIDE_STEPS = (600, 800, 1000, 1500, 2000)  # 0.1 %


def override_writer(
    net_id: str, address: str, period_s: float, duration_s: float, out: Any
) -> None:
    """A PLC that writes a new override (cycling 60/80/100/150/200 %) every period_s."""
    plc = pyads.Connection(net_id, 551, address)
    plc.open()
    n = errors = 0
    end = time.perf_counter() + duration_s
    next_t = time.perf_counter()
    try:
        for value in itertools.cycle(OVERRIDE_STEPS):
            next_t += period_s
            wait = next_t - time.perf_counter()
            if wait > 0:
                time.sleep(wait)
            if time.perf_counter() >= end:
                break
            try:
                plc.write_by_name("PLC.ch1.override", value, pyads.PLCTYPE_UINT)
            except pyads.ADSError:
                errors += 1
            n += 1
        plc.write_by_name("PLC.ch1.override", 1000, pyads.PLCTYPE_UINT)
    finally:
        plc.close()
    out.put({"kind": "override_writer", "writes": n, "errors": errors})


def notifier(
    net_id: str,
    address: str,
    cycle_ms: int,
    duration_s: float,
    out: Any,
    subscriptions: int = len(NOTIFY_SYMBOLS),
) -> None:
    plc = pyads.Connection(net_id, 551, address)
    plc.open()
    lift: dict[str, list[tuple[int, bool]]] = {s: [] for s in LIFT_SYMBOLS}  # (cycle, value)
    cycle_t: list[float] = []
    count = [0]
    last_cycle = [0]
    first_cycle = [0]

    def on(symbol: str) -> Any:
        plc_type = _type(symbol)

        def callback(notification: Any, _name: str) -> None:
            _, _, value = plc.parse_notification(notification, plc_type)
            count[0] += 1
            if symbol in lift:  # tagged with the GEO cycle notified last
                lift[symbol].append((last_cycle[0], bool(value)))
            elif symbol == "GEO.cycle":
                cycle_t.append(time.perf_counter())
                last_cycle[0] = int(value)
                first_cycle[0] = first_cycle[0] or int(value)

        return callback

    handles = []
    symbols = [*NOTIFY_SYMBOLS[: subscriptions - 1], "GEO.cycle"]
    for symbol in dict.fromkeys(symbols):
        attr = pyads.NotificationAttrib(
            ctypes.sizeof(_type(symbol)), trans_mode=pyads.ADSTRANS_SERVERONCHA, cycle_time=cycle_ms
        )
        handles.append(plc.add_device_notification(symbol, attr, on(symbol)))
    time.sleep(duration_s)
    for h in handles:
        plc.del_device_notification(*h)
    plc.close()
    changes = {
        sym: [(c, b) for (_, a), (c, b) in itertools.pairwise(samples) if a != b]
        for sym, samples in lift.items()
    }
    gaps = np.diff(np.array(cycle_t)) * 1e3 if len(cycle_t) > 1 else np.zeros(1)
    out.put(
        {
            "kind": "notifier",
            "subscriptions": len(handles),
            "samples": count[0],
            "lift_active_samples": len(lift[LIFT_SYMBOLS[0]]),
            "lift_active_changes_at": [c for c, _ in changes[LIFT_SYMBOLS[0]]],
            "lift_changes": changes,
            "cycles_seen": [first_cycle[0], last_cycle[0]],
            "cycle_gap_ms": {
                "p50": round(float(np.median(gaps)), 2),
                "p99": round(float(np.percentile(gaps, 99)), 2),
                "max": round(float(gaps.max()), 2),
            },
        }
    )


def start(
    net_id: str,
    address: str,
    duration_s: float,
    pollers: int,
    poll_hz: float,
    notifiers: int,
    cycle_ms: int,
    subscriptions: int = len(NOTIFY_SYMBOLS),
    override_every_s: float = 0.0,
) -> tuple[list[mp.Process], Any]:
    ctx = mp.get_context("spawn")
    out = ctx.Queue()
    procs = [
        ctx.Process(
            target=poller, args=(net_id, address, 1 / poll_hz if poll_hz else 0.0, duration_s, out)
        )
        for _ in range(pollers)
    ]
    procs += [
        ctx.Process(
            target=notifier, args=(net_id, address, cycle_ms, duration_s, out, subscriptions)
        )
        for _ in range(notifiers)
    ]
    if override_every_s:
        procs.append(
            ctx.Process(
                target=override_writer, args=(net_id, address, override_every_s, duration_s, out)
            )
        )
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


def trace_transitions(trace: Path, dt: float = 1e-3) -> dict[str, list[tuple[int, bool]]]:
    """(GEO cycle, new value) of every lift_active / lift_suppressed change in a run's trace."""
    out: dict[str, list[tuple[int, bool]]] = {s: [] for s in LIFT_SYMBOLS}
    prev: dict[str, str] = {}
    with trace.open() as f:
        for row in csv.DictReader(f):
            k = round(float(row["t"]) / dt)
            for sym in LIFT_SYMBOLS:
                v = row[sym.rsplit(".", 1)[1]]
                if sym in prev and v != prev[sym]:
                    out[sym].append((k, v == "1"))
                prev[sym] = v
    return out


def mismatches(notifiers: list[dict[str, Any]], trace: Path, margin: int = 25) -> dict[str, int]:
    """Transitions of the lift status (Z lift_active and lift_suppressed) in the trace that a
    notification client did not see (`lost`), and ones it saw that the trace does not have at
    that cycle with that value (`extra`), summed over clients and over the GEO cycles each client
    covered. A sample is tagged with the GEO.cycle notified before it, so a change observed at
    cycle c matches a trace change to the same value within ±margin cycles."""
    truth = trace_transitions(trace)
    lost = extra = matched = 0
    for r in notifiers:
        first, last = r["cycles_seen"]
        lo, hi = first + margin, last - margin
        for sym, seen_all in r["lift_changes"].items():
            expected = [(k, v) for k, v in truth[sym] if lo <= k <= hi]
            seen = [(c, v) for c, v in seen_all if lo <= c <= hi]
            used = [False] * len(seen)
            for k, v in expected:
                j = next(
                    (
                        j
                        for j, (c, w) in enumerate(seen)
                        if not used[j] and w == v and abs(c - k) <= margin
                    ),
                    None,
                )
                if j is None:
                    lost += 1
                else:
                    used[j] = True
                    matched += 1
            extra += used.count(False)
    return {"matched": matched, "lost": lost, "extra": extra}


def lost_changes(notifiers: list[dict[str, Any]], trace: Path) -> int:
    """Lift status changes lost or invented by the notification clients (0 = all match)."""
    m = mismatches(notifiers, trace)
    return m["lost"] + m["extra"]
