"""Interop figures (issue 16), one JSON line per figure:

- pyads_vs_testserver: one pyads connection reading a BOOL by IG/IO back to back, against
  `liftd run` and against pyads' own AdsTestServer (BasicHandler, in its own process) in the
  same run, alternating, best of --rounds; the ratio is liftd / AdsTestServer (the machine's
  speed cancels out);
- ads_client_read_value: Node ads-client `readValue` of GEO.ch1.Z.lift_active in a loop
  (default mode: symbol info and data type cached by the client, one Read per value);
- upload: a full symbol + data-type upload as ads-rs and ads-client do it (0xF00F 64 bytes,
  0xF00E, 0xF00B over one raw connection), median and p99 of --uploads repetitions, and
  ads-client getSymbols() + getDataTypes();
- crowded: max_connections (64) idle sockets held open from two loopback addresses, then a
  pyads client connects and reads (issue bound: within 1 s);
- log_pipe: a daemon whose stdout/stderr are 4 KiB pipes nobody reads, a peer opens and closes
  3 000 connections from 200 addresses, then pyads reads (issue bound: within 100 ms).

Run: .venv/bin/python bench/bench_interop.py [--seconds 3] [--rounds 3]
"""

from __future__ import annotations

import argparse
import fcntl
import json
import os
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import pyads

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench import load  # noqa: E402
from liftd.ads.client import RawClient  # noqa: E402
from liftd.ads.wire import net_id_bytes  # noqa: E402
from tests.support.daemon import Daemon, Notify, write_config  # noqa: E402

NODE_DIR = ROOT / "tests" / "interop" / "node"
TESTSERVER = """
import sys
from pyads.testserver import AdsTestServer, BasicHandler
server = AdsTestServer(BasicHandler(), ip_address="127.0.0.1", port=int(sys.argv[1]), logging=False)
server.start()
server.join()
"""


def emit(rec: dict[str, object]) -> None:
    print(json.dumps(rec), flush=True)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def sequential(net_id: str, address: str, seconds: float) -> dict[str, Any]:
    procs, out = load.start(net_id, address, seconds, 1, 0.0, 0, 10)
    (r,) = load.collect(procs, out, seconds + 30)
    return r


def pyads_vs_testserver(d: Daemon, seconds: float, rounds: int) -> None:
    port = free_port()
    server = subprocess.Popen([sys.executable, "-c", TESTSERVER, str(port)])
    try:
        end = time.monotonic() + 10
        while time.monotonic() < end:
            try:
                socket.create_connection(("127.0.0.1", port), 0.2).close()
                break
            except OSError:
                time.sleep(0.05)
        runs: dict[str, list[dict[str, Any]]] = {"liftd": [], "testserver": []}
        for _ in range(rounds):
            runs["liftd"].append(sequential(d.net_id, d.address, seconds))
            runs["testserver"].append(sequential("127.0.0.1.1.1", f"127.0.0.1:{port}", seconds))
    finally:
        server.kill()
        server.wait()
    best = {k: max(v, key=lambda r: r["rate"]) for k, v in runs.items()}
    emit(
        {
            "bench": "pyads_vs_testserver",
            "seconds": seconds,
            "rounds": rounds,
            "liftd_reads_per_s": round(best["liftd"]["rate"]),
            "testserver_reads_per_s": round(best["testserver"]["rate"]),
            "ratio": round(best["liftd"]["rate"] / best["testserver"]["rate"], 2),
            "liftd_latency_us": best["liftd"]["latency_us"],
            "testserver_latency_us": best["testserver"]["latency_us"],
            "errors": sum(r["errors"] for v in runs.values() for r in v),
        }
    )


def node(d: Daemon, *args: str) -> dict[str, Any]:
    run = subprocess.run(
        ["node", "session.mjs", *args[:1], str(d.port), d.net_id, *args[1:]],
        cwd=NODE_DIR,
        capture_output=True,
        text=True,
        timeout=120,
        check=True,
    )
    result: dict[str, Any] = json.loads(run.stdout.strip().splitlines()[-1])
    return result


def ads_client_read_value(d: Daemon, seconds: float) -> None:
    r = node(d, "bench", str(seconds))
    emit(
        {
            "bench": "ads_client_read_value",
            "ads_client": r["version"],
            "read_value_per_s": round(r["read_value_per_s"]),
            "reads": r["reads"],
        }
    )


def upload(d: Daemon, repetitions: int) -> None:
    c = RawClient(d.port, net_id_bytes(d.net_id))
    times, sizes = [], (0, 0)
    try:
        for _ in range(repetitions):
            t0 = time.perf_counter_ns()
            _, info = c.read(0xF00F, 0, 64)
            sym_bytes, type_bytes = (
                struct.unpack_from("<I", info, 4)[0],
                struct.unpack_from("<I", info, 12)[0],
            )
            code_t, types = c.read(0xF00E, 0, type_bytes)
            code_s, symbols = c.read(0xF00B, 0, sym_bytes)
            times.append(time.perf_counter_ns() - t0)
            assert code_t == code_s == 0
            sizes = (len(symbols), len(types))
    finally:
        c.close()
    ns = np.array(times)
    r = node(d, "upload")
    emit(
        {
            "bench": "symbol_and_data_type_upload",
            "symbol_bytes": sizes[0],
            "data_type_bytes": sizes[1],
            "symbols": struct.unpack_from("<I", info)[0],
            "data_types": struct.unpack_from("<I", info, 8)[0],
            "raw_ms": {
                "p50": round(float(np.percentile(ns, 50)) / 1e6, 3),
                "p99": round(float(np.percentile(ns, 99)) / 1e6, 3),
            },
            "ads_client_get_symbols_and_data_types_ms": r["upload_ms"],
        }
    )


def timed_pyads_read(net_id: str, address: str) -> tuple[float, float]:
    """(seconds for open + first read, seconds for a second read)"""
    t0 = time.perf_counter()
    plc = pyads.Connection(net_id, 551, address)
    plc.open()
    try:
        plc.read(0x121301, 0x30095, pyads.PLCTYPE_BOOL)
        t1 = time.perf_counter()
        plc.read(0x121301, 0x30095, pyads.PLCTYPE_BOOL)
        return t1 - t0, time.perf_counter() - t1
    finally:
        plc.close()


def crowded(d: Daemon) -> None:
    idle = []
    for i in range(64):
        s = socket.socket()
        s.bind((f"127.0.0.{1 + i % 2}", 0))
        s.connect(("127.0.0.1", d.port))
        idle.append(s)
    time.sleep(0.2)
    first, second = timed_pyads_read(d.net_id, d.address)
    for s in idle:
        s.close()
    emit(
        {
            "bench": "pyads_with_64_idle_sockets",
            "open_and_first_read_ms": round(first * 1e3, 2),
            "next_read_ms": round(second * 1e3, 3),
            "bound": "< 1 s",
        }
    )


def log_pipe(tmp: Path) -> None:
    port = free_port()
    cfg = write_config(
        tmp,
        program={"repeat": True},
        ads={"port": port},
        log={"format": "json", "queue_lines": 100},
    )
    notify = Notify(tmp)
    pipes = [os.pipe() for _ in range(2)]
    for _, w in pipes:
        fcntl.fcntl(w, fcntl.F_SETPIPE_SZ, 4096)
    proc = subprocess.Popen(
        [sys.executable, "-m", "liftd", "run", "-c", str(cfg)],
        stdout=pipes[0][1],
        stderr=pipes[1][1],
        cwd=ROOT,
        env={**os.environ, "NOTIFY_SOCKET": notify.path},
    )
    for _, w in pipes:
        os.close(w)
    try:
        end = time.monotonic() + 20
        while "READY=1" not in "".join(notify.drain()) and time.monotonic() < end:
            time.sleep(0.02)
        t0 = time.perf_counter()
        for i in range(3000):
            with socket.socket() as s:
                s.bind((f"127.0.0.{2 + i % 200}", 0))
                s.connect(("127.0.0.1", port))
        churn = time.perf_counter() - t0
        net_id = next(
            line.split('"')[1] for line in cfg.read_text().splitlines() if line.startswith("net_id")
        )
        first, second = timed_pyads_read(net_id, f"127.0.0.1:{port}")
        plc = pyads.Connection(net_id, 551, f"127.0.0.1:{port}")
        plc.open()
        dropped = plc.read_by_name("GEO.ads.log_dropped", pyads.PLCTYPE_ULINT)
        plc.close()
        emit(
            {
                "bench": "pyads_with_unread_log_pipe_after_3000_connections",
                "connections_s": round(churn, 2),
                "open_and_first_read_ms": round(first * 1e3, 2),
                "next_read_ms": round(second * 1e3, 3),
                "log_lines_dropped": dropped,
                "bound": "< 100 ms",
            }
        )
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.wait(20)
        for r, _ in pipes:
            os.close(r)
        notify.close()


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seconds", type=float, default=3.0)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--uploads", type=int, default=200)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        cfg = write_config(Path(tmp), program={"repeat": True}, log={"format": "json"})
        d = Daemon(cfg)
        try:
            d.ready()
            pyads_vs_testserver(d, args.seconds, args.rounds)
            ads_client_read_value(d, args.seconds)
            upload(d, args.uploads)
            crowded(d)
        finally:
            d.stop()
        log_pipe(Path(tmp))


if __name__ == "__main__":
    main()
