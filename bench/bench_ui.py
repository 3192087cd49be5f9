"""The live view's figures against a real `liftd run` (issue 38), one JSON line per figure.

- latency: a GEO flag change (GEO.ch1.Z.lift_active as pyads sees it, polling every 5 ms) to
  the page: headless Chromium's data-value (a MutationObserver's Date.now()) and, to tell the
  server from the browser, a Python WebSocket client's receipt; p50/p99/max over ≥ 200 changes
  of a program that lifts every ~0.25 s;
- load: the daemon's CPU and RSS and the GEO loop's lateness and compute (from /metrics:
  histogram deltas per phase, p50/p99 by bucket upper bound, exceeded and >25 % counts) with
  0, 1 and 10 open pages (Python WebSocket clients in another process that take every
  update), phases alternated in one run (A/B: this is a shared 2-vCPU VM), while a pyads
  client polls lift_active at 1 kHz (the ADS server's rate and latency in each phase).

- rss: the daemon's RSS with [ui] off and on (no page), alternated.
- reconnect (`--reconnect N`, alone): ADS round trips (read of lift_active every 10 ms) on a
  program of N lift ranges, quiet and while two threads open /ws and close it in a loop,
  alternated; how many handshakes were answered 101 and 429 (review #1 of issue 38).

Run: .venv/bin/python bench/bench_ui.py [--rt] [--changes 200] [--phase-seconds 20] [--rounds 2]
     .venv/bin/python bench/bench_ui.py --reconnect 40000 [--phase-seconds 15] [--rounds 2]
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench import load as ads_load  # noqa: E402

LIFT = "GEO.ch1.Z.lift_active"
RT_OFF = {
    "sched_fifo_priority": 0,
    "hold_cpu_dma_latency": False,
    "lock_memory": False,
    "stall_timeout_ms": 20000,
}
RT_ON = {
    "sched_fifo_priority": 80,
    "hold_cpu_dma_latency": True,
    "lock_memory": True,
    "stall_timeout_ms": 20000,
}


def emit(rec: dict[str, Any]) -> None:
    print(json.dumps(rec), flush=True)


def percentile(xs: list[float], q: float) -> float:
    s = sorted(xs)
    return s[min(len(s) - 1, round(q * (len(s) - 1)))]


# -- pages in another process ---------------------------------------------------------------
async def _pages(url: str, n: int, seconds: float) -> int:
    import aiohttp  # noqa: PLC0415

    frames = 0

    async def one() -> None:
        nonlocal frames
        async with (
            aiohttp.ClientSession() as s,
            s.ws_connect(url + "ws", headers={"Origin": url.rstrip("/")}) as ws,
        ):
            end = time.monotonic() + seconds
            while time.monotonic() < end:
                try:
                    await ws.receive(max(0.01, end - time.monotonic()))
                except TimeoutError:
                    break
                frames += 1

    await asyncio.gather(*(one() for _ in range(n)))
    return frames


def pages_child(url: str, n: int, seconds: float) -> None:
    print(json.dumps({"frames": asyncio.run(_pages(url, n, seconds))}), flush=True)


# -- latency --------------------------------------------------------------------------------
def poll_child(net_id: str, address: str, changes: int, timeout: float) -> None:
    """pyads, polling lift_active every 5 ms (a PLC task), until `changes` changes."""
    import pyads  # noqa: PLC0415

    plc = pyads.Connection(net_id, 551, address)
    plc.open()
    seen: list[tuple[float, bool]] = []
    last = None
    end = time.monotonic() + timeout
    while len(seen) <= changes and time.monotonic() < end:
        v = bool(plc.read_by_name(LIFT, pyads.PLCTYPE_BOOL))
        if v != last:
            seen.append((time.time(), v))
            last = v
        time.sleep(0.005)
    plc.close()
    print(json.dumps(seen[1:]), flush=True)


def ws_child(url: str, seconds: float) -> None:
    """A page as a plain WebSocket client: when each lift_active change arrived (a JSON line
    each, as it comes: the parent ends it)."""
    from tests.support.ui import open_page  # noqa: PLC0415

    async def go() -> None:
        page = await open_page(url)
        last = page.values.get(LIFT)
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            try:
                m = await page.receive(max(0.05, end - time.monotonic()))
            except TimeoutError:
                break
            for f in m.get("frames", []):
                if LIFT in f["c"] and f["c"][LIFT] != last:
                    last = f["c"][LIFT]
                    print(json.dumps([time.time(), bool(last)]), flush=True)
        await page.close()

    asyncio.run(go())


def _lags(plc: list[list[Any]], got: list[tuple[float, bool]]) -> tuple[list[float], int]:
    lags, missed = [], 0
    for t_plc, v in plc:
        match = next((t for t, w in got if w == v and t >= t_plc - 0.05), None)
        if match is None:
            missed += 1
        else:
            lags.append((match - t_plc) * 1e3)
    return lags, missed


def latency(d: Any, url: str, changes: int) -> None:
    from tests.support.browser import OBSERVE, browser, chromium_version  # noqa: PLC0415

    budget = 600.0
    with browser() as ctx:
        tab = ctx.new_page()
        tab.goto(url)
        tab.wait_for_selector("body[data-ready=true]")
        tab.evaluate(OBSERVE, LIFT)
        ws = subprocess.Popen(
            [sys.executable, __file__, "--ws-child", url, str(budget)],
            stdout=subprocess.PIPE,
            text=True,
        )
        time.sleep(1.0)
        poll = subprocess.Popen(
            [
                sys.executable,
                __file__,
                "--poll-child",
                d.net_id,
                d.address,
                str(changes),
                str(budget),
            ],
            stdout=subprocess.PIPE,
            text=True,
        )
        while poll.poll() is None:
            tab.wait_for_timeout(200)
        assert poll.stdout is not None
        plc = json.loads(poll.stdout.read())
        tab.wait_for_timeout(1000)  # the last changes reach the pages
        ws.terminate()
        shown = [(t / 1000.0, v == "true") for t, v in tab.evaluate("window.__changes")[1:]]
        version = chromium_version()
    ws_out, _ = ws.communicate(timeout=30)
    ws_seen = [tuple(json.loads(x)) for x in ws_out.splitlines() if x.strip()]
    for name, got in (("chromium", shown), ("ws_client", ws_seen)):
        lags, missed = _lags(plc, got)  # type: ignore[arg-type]
        emit(
            {
                "bench": "ui_flag_latency",
                "client": name,
                "changes": len(plc),
                "missed": missed,
                "p50_ms": round(statistics.median(lags), 1),
                "p99_ms": round(percentile(lags, 0.99), 1),
                "max_ms": round(max(lags), 1),
                "within_100ms": sum(x <= 100 for x in lags),
                "browser": version,
                "loadavg_1min": round(os.getloadavg()[0], 2),
                "note": "vs pyads polling every 5 ms in its own process (its own lag: 0..5 ms "
                "+ one request)",
            }
        )


# -- load -----------------------------------------------------------------------------------
def scrape(port: int) -> dict[str, float]:
    with urllib.request.urlopen(f"http://127.0.0.1:{port}/metrics", timeout=10) as r:
        text = r.read().decode()
    out = {}
    for line in text.splitlines():
        m = re.match(r"^([a-zA-Z0-9_:]+(?:\{[^}]*\})?) ([0-9.e+-]+|\+Inf)$", line)
        if m:
            out[m.group(1)] = float(m.group(2))
    return out


def hist(before: dict[str, float], after: dict[str, float], name: str) -> dict[str, float]:
    edges = sorted(
        (float(k.split('le="')[1].rstrip('"}')), k)
        for k in after
        if k.startswith(f"liftd_geo_{name}_seconds_bucket") and "+Inf" not in k
    )
    total = after[f"liftd_geo_{name}_seconds_count"] - before[f"liftd_geo_{name}_seconds_count"]
    res: dict[str, float] = {}
    for q in (0.5, 0.99, 0.999):
        for le, key in edges:
            if after[key] - before.get(key, 0.0) >= q * total:
                res[f"p{q * 100:g}_us_le"] = round(le * 1e6, 1)
                break
        else:
            res[f"p{q * 100:g}_us_le"] = float("inf")
    return res


def load(d: Any, url: str, metrics_port: int, phase_s: float, rounds: int, rt: bool) -> None:
    results: dict[int, list[dict[str, float]]] = {0: [], 1: [], 10: []}
    for _ in range(rounds):
        for pages in (0, 10, 1):
            child = None
            if pages:
                child = subprocess.Popen(
                    [sys.executable, __file__, "--pages-child", url, str(pages), str(phase_s + 2)],
                    stdout=subprocess.PIPE,
                    text=True,
                )
                time.sleep(1.5)  # connected
            procs, out = ads_load.start(d.net_id, d.address, phase_s, 1, 1000.0, 0, 10)
            a = scrape(metrics_port)
            time.sleep(phase_s)
            b = scrape(metrics_port)
            (poll,) = ads_load.collect(procs, out, phase_s + 30)
            frames = 0
            if child is not None:
                out, _ = child.communicate(timeout=60)
                frames = json.loads(out.strip().splitlines()[-1])["frames"]
            cpu = b["process_cpu_seconds_total"] - a["process_cpu_seconds_total"]
            rec = {
                "loadavg_1min": round(os.getloadavg()[0], 2),
                "daemon_cpu_pct": round(100 * cpu / phase_s, 2),
                "daemon_rss_mb": round(b["process_resident_memory_bytes"] / 2**20, 1),
                "geo_cpu_pct": round(
                    100
                    * (
                        b["liftd_geo_process_cpu_seconds_total"]
                        - a["liftd_geo_process_cpu_seconds_total"]
                    )
                    / phase_s,
                    2,
                ),
                "exceeded": b["liftd_geo_exceeded_total"] - a["liftd_geo_exceeded_total"],
                "compute_over_25pct": b["liftd_geo_compute_over_25pct_total"]
                - a["liftd_geo_compute_over_25pct_total"],
                "cycles": b["liftd_geo_cycles_total"] - a["liftd_geo_cycles_total"],
                "frames_received": frames,
                "pyads_1khz_reads_per_s": round(poll["rate"]),
                "pyads_latency_us": poll["latency_us"],
                **{f"lateness_{k}": v for k, v in hist(a, b, "lateness").items()},
                **{f"compute_{k}": v for k, v in hist(a, b, "compute").items()},
            }
            results[pages].append(rec)
    for pages, recs in results.items():
        emit({"bench": "ui_load", "pages": pages, "phase_s": phase_s, "rt": rt, "phases": recs})


def rss_without_and_with_ui(rounds: int = 2) -> None:
    """The daemon's RSS 5 s after READY with [ui] off and on (no page), alternated."""
    from tests.support.daemon import Daemon, write_config  # noqa: PLC0415

    def rss_mb(pid: int) -> float:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS"):
                return int(line.split()[1]) / 1024
        return float("nan")

    got: dict[bool, list[float]] = {False: [], True: []}
    for _ in range(rounds):
        for ui in (False, True):
            with tempfile.TemporaryDirectory() as tmp:
                cfg = write_config(
                    Path(tmp), program={"repeat": True}, ui={"enabled": ui, "port": 0}, rt=RT_OFF
                )
                d = Daemon(cfg)
                try:
                    d.ready()
                    time.sleep(5)
                    got[ui].append(round(rss_mb(d.proc.pid), 1))
                finally:
                    d.stop()
    emit({"bench": "ui_daemon_rss", "ui_off_mb": got[False], "ui_on_mb": got[True]})


def _round_trips(d: Any, seconds: float) -> list[float]:
    from liftd.ads.client import RawClient  # noqa: PLC0415
    from liftd.ads.wire import net_id_bytes  # noqa: PLC0415

    c = RawClient(d.port, net_id_bytes(d.net_id))
    out: list[float] = []
    end = time.monotonic() + seconds
    try:
        while time.monotonic() < end:
            a = time.perf_counter()
            c.read_by_name(LIFT, 1)
            out.append((time.perf_counter() - a) * 1e3)
            time.sleep(0.01)
    finally:
        c.close()
    return out


def _reconnecting(url: str, stop: Any, got: dict[int, int]) -> None:
    import base64  # noqa: PLC0415
    import socket  # noqa: PLC0415

    host, port = url.split("//")[1].rstrip("/").rsplit(":", 1)
    while not stop.is_set():
        with socket.create_connection((host, int(port))) as s:
            key = base64.b64encode(os.urandom(16)).decode()
            s.sendall(
                f"GET /ws HTTP/1.1\r\nHost: {host}:{port}\r\nUpgrade: websocket\r\n"
                f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n"
                "Sec-WebSocket-Version: 13\r\n\r\n".encode()
            )
            head = s.recv(256)
            status = int(head.split()[1]) if len(head.split()) > 1 else 0
            got[status] = got.get(status, 0) + 1


def reconnect(ranges: int, phase_s: float, rounds: int) -> None:
    import threading  # noqa: PLC0415

    from tests.support.daemon import Daemon, write_config  # noqa: PLC0415
    from tests.support.ui import QUIET_RT, hops_program, ui_url  # noqa: PLC0415

    with tempfile.TemporaryDirectory() as tmp:
        program = Path(tmp) / "hops.nc"
        program.write_text(hops_program(ranges))
        cfg = write_config(Path(tmp), program_file=str(program), program={"repeat": True},
                           ui={"enabled": True, "port": 0}, rt=QUIET_RT)  # fmt: skip
        d = Daemon(cfg)
        try:
            d.ready()
            url = ui_url(d)
            time.sleep(10)  # the drawing built (a process of its own) and published
            for r in range(rounds):
                for phase in ("quiet", "reconnecting"):
                    stop, got = threading.Event(), {}
                    threads = [
                        threading.Thread(target=_reconnecting, args=(url, stop, got))
                        for _ in range(2 if phase == "reconnecting" else 0)
                    ]
                    for t in threads:
                        t.start()
                    ms = _round_trips(d, phase_s)
                    stop.set()
                    for t in threads:
                        t.join()
                    emit({"bench": "ui_reconnect_ads_rtt", "ranges": ranges, "round": r,
                          "phase": phase, "n": len(ms), "median_ms": round(statistics.median(ms), 3),
                          "p90_ms": round(percentile(ms, 0.9), 2), "max_ms": round(max(ms), 1),
                          "handshakes": {str(k): v for k, v in sorted(got.items())}})  # fmt: skip
        finally:
            d.stop()


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "--pages-child":
        pages_child(sys.argv[2], int(sys.argv[3]), float(sys.argv[4]))
        return
    if len(sys.argv) > 1 and sys.argv[1] == "--poll-child":
        poll_child(sys.argv[2], sys.argv[3], int(sys.argv[4]), float(sys.argv[5]))
        return
    if len(sys.argv) > 1 and sys.argv[1] == "--ws-child":
        ws_child(sys.argv[2], float(sys.argv[3]))
        return
    ap = argparse.ArgumentParser()
    ap.add_argument("--changes", type=int, default=200)
    ap.add_argument("--phase-seconds", type=float, default=20.0)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--skip-latency", action="store_true")
    ap.add_argument("--skip-load", action="store_true")
    ap.add_argument("--rt", action="store_true", help="SCHED_FIFO 80, mlockall (as root)")
    ap.add_argument("--skip-rss", action="store_true")
    ap.add_argument("--reconnect", type=int, metavar="RANGES", help="only the reconnect figure")
    args = ap.parse_args()
    if args.reconnect:
        reconnect(args.reconnect, args.phase_seconds, args.rounds)
        return
    from tests.support.daemon import Daemon, free_port, write_config  # noqa: PLC0415
    from tests.support.ui import hops_program, ui_url  # noqa: PLC0415

    if not args.skip_rss:
        rss_without_and_with_ui()
    with tempfile.TemporaryDirectory() as tmp:
        program = Path(tmp) / "hops.nc"
        program.write_text(hops_program())
        metrics_port = free_port()
        cfg = write_config(
            Path(tmp),
            program_file=str(program),
            program={"repeat": True},
            ui={"enabled": True, "port": 0},
            rt=RT_ON if args.rt else RT_OFF,
            metrics={"prometheus_port": metrics_port},
        )
        d = Daemon(cfg)
        try:
            d.ready()
            url = ui_url(d)
            if not args.skip_latency:
                latency(d, url, args.changes)
            if not args.skip_load:
                load(d, url, metrics_port, args.phase_seconds, args.rounds, args.rt)
        finally:
            d.stop()


if __name__ == "__main__":
    main()
