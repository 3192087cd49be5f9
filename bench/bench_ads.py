"""ADS server figures against a real `liftd run` (issue 6), one JSON line per figure.

- sequential: one pyads connection reading lift_active by IG/IO back to back
  (goal ≥ 10 000 reads/s, p99 < 1 ms);
- sum_read: ADSIGRP_SUMUP_READ (0xF080) of 100 objects, raw client; and pyads
  read_list_by_name of every distinct symbol (goal ≥ 200 000 objects/s);
- load: 10 clients × 20 on-change notifications (10 ms) + 10 clients polling at 1 kHz, each
  an OS process; every lift_active change in the run's trace must reach every notification
  client (goal: 0 lost), and the GEO loop's exceed count stays put.

Run: .venv/bin/python bench/bench_ads.py [--load-seconds 30]
"""

from __future__ import annotations

import argparse
import json
import struct
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pyads

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench import load  # noqa: E402
from liftd.ads.client import RawClient  # noqa: E402
from liftd.ads.wire import net_id_bytes  # noqa: E402
from tests.support.daemon import Daemon, write_config  # noqa: E402

LIFT = (0x121301, 0x30095)
# the IG/IO objects of channel 1 (lift status of X, Y, Z; path velocity objects)
OBJECTS = [(0x121301, (ax << 16) | el, 1) for ax in (1, 2, 3) for el in (0x94, 0x95)]
OBJECTS += [(0x121301, 0xF, 4), (0x121301, 0x10, 4), (0x121301, 0x15, 8)]


RT_ON = {"sched_fifo_priority": 80, "hold_cpu_dma_latency": True, "lock_memory": True}
RT_OFF = {"sched_fifo_priority": 0, "hold_cpu_dma_latency": False, "lock_memory": False}


def emit(rec: dict[str, object]) -> None:
    print(json.dumps(rec), flush=True)


def sequential(d: Daemon, seconds: float) -> None:
    procs, out = load.start(d.net_id, d.address, seconds, 1, 0.0, 0, 10)
    (r,) = load.collect(procs, out, seconds + 30)
    emit(
        {
            "bench": "ads_sequential_reads",
            "reads_per_s": round(r["rate"]),
            "latency_us": r["latency_us"],
            "errors": r["errors"],
            "goal": ">= 10000/s, p99 < 1000 us",
        }
    )


def sum_read(d: Daemon, seconds: float) -> None:
    c = RawClient(d.port, net_id_bytes(d.net_id), source=bytes([127, 0, 0, 1, 9, 9]))
    subs = [OBJECTS[i % len(OBJECTS)] for i in range(100)]
    payload_len = sum(n for _, _, n in subs) + 4 * len(subs)
    body = b"".join(struct.pack("<III", *s) for s in subs)
    req = struct.pack("<IIII", 0xF080, len(subs), payload_len, len(body)) + body
    lat = []
    end = time.perf_counter() + seconds
    while time.perf_counter() < end:
        a = time.perf_counter_ns()
        reply = c.request(9, req)
        lat.append(time.perf_counter_ns() - a)
        result, data = reply.payload[:4], reply.payload[8:]
        assert result == b"\0\0\0\0" and data[: 4 * len(subs)] == bytes(4 * len(subs))
    c.close()
    arr = np.array(lat)
    emit(
        {
            "bench": "ads_sum_read_100",
            "objects_per_s": round(100 * len(arr) / (arr.sum() / 1e9)),
            "requests": len(arr),
            "latency_us": load.percentiles_us(arr),
            "goal": ">= 200000 objects/s",
        }
    )
    plc = pyads.Connection(d.net_id, 551, d.address)
    plc.open()
    names = [s for s in load.NOTIFY_SYMBOLS if s != "GEO.ch1.m_pending"] * 5  # 95 sub-reads
    plc.read_list_by_name(names)  # symbol infos cached
    n, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        plc.read_list_by_name(names)
        n += 1
    wall = time.perf_counter() - t0
    plc.close()
    emit(
        {
            "bench": "ads_pyads_read_list_by_name",
            "sub_reads": len(names),
            "objects_per_s": round(n * len(names) / wall),
            "calls_per_s": round(n / wall),
        }
    )


def under_load(d: Daemon, trace: Path, seconds: float) -> None:
    before = d.read_exceeded()
    procs, out = load.start(d.net_id, d.address, seconds, 10, 1000.0, 10, 10)
    results = load.collect(procs, out, seconds + 60)
    after = d.read_exceeded()
    pollers = [r for r in results if r["kind"] == "poller"]
    notifiers = [r for r in results if r["kind"] == "notifier"]
    time.sleep(0.3)  # the trace writer drains its ring every 100 ms
    lost = load.lost_changes(notifiers, trace)
    p99 = [r["latency_us"].get("p99", 0.0) for r in pollers]
    emit(
        {
            "bench": "ads_load",
            "seconds": seconds,
            "clients": len(results),
            "pollers": len(pollers),
            "poll_rate_hz_min": round(min(r["rate"] for r in pollers)),
            "poll_rate_hz_total": round(sum(r["rate"] for r in pollers)),
            "poll_latency_p99_us_max": max(p99),
            "poll_errors": sum(r["errors"] for r in pollers),
            "notifiers": len(notifiers),
            "subscriptions": sum(r["subscriptions"] for r in notifiers),
            "notification_samples": sum(r["samples"] for r in notifiers),
            "lift_changes_per_client": [len(r["lift_active_changes_at"]) for r in notifiers],
            "lift_changes_lost": lost,
            "cycle_gap_ms_max": max(r["cycle_gap_ms"]["max"] for r in notifiers),
            "geo_exceeded_during_load": after - before,
            "goal": "0 lost",
        }
    )


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seconds", type=float, default=5.0, help="per throughput figure")
    ap.add_argument("--load-seconds", type=float, default=30.0)
    ap.add_argument("--no-rt", action="store_true", help="GEO loop without SCHED_FIFO/mlock/PM QoS")
    args = ap.parse_args()
    rt = RT_OFF if args.no_rt else RT_ON
    with tempfile.TemporaryDirectory() as tmp:
        cfg = write_config(Path(tmp), program={"repeat": True}, ads={"max_connections": 128}, rt=rt)
        trace = Path(tmp) / "run.csv"
        d = Daemon(cfg, "--trace", str(trace))
        try:
            d.ready()
            sequential(d, args.seconds)
            sum_read(d, args.seconds)
            under_load(d, trace, args.load_seconds)
        finally:
            d.stop()
        stopped = d.event("daemon.stopped", 1) or {}
        emit(
            {
                "bench": "ads_geo_timing",
                "cycles": stopped.get("cycles"),
                "exceeded": stopped.get("exceeded"),
                "lateness_us": stopped.get("lateness_us"),
                "compute_us": stopped.get("compute_us"),
                "rt": not args.no_rt,
            }
        )


if __name__ == "__main__":
    main()
