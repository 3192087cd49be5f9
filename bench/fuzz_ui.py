"""Black-box fuzzing of the live view of a running `liftd run` (issue 38, "Bad input"), as
bench/fuzz_daemon.py fuzzes its ADS side: `[ui] control = true` with a token, a program that
lifts every ~0.25 s, and from a process of its own

* `messages` — pages (with the page's own Origin) sending random text, random JSON, every op
  with fields of any type and value (Infinity, NaN, deep nesting), binary frames, messages over
  `max_message_bytes`, wrong and right tokens, writes of random symbols and values;
* `http` — random requests on raw sockets: random paths and methods, huge and broken headers,
  foreign Host and Origin headers, cut requests, handshakes that never read;
* `churn` — pages opened and closed as fast as the server lets them (the 16-page cap refuses
  the rest with 503).

Meanwhile a well-behaved ADS client reads `lift_active` back to back (bench/fuzz_daemon.py's
probe, in its own process), the daemon's RSS is sampled every 50 ms, and its log is searched
for tracebacks; the same probe alone before the attack is the baseline of the same run.
Prints one JSON line per surface and a summary line; afterwards a fresh page must still get
its hello and the control round trip must still work.

Run: .venv/bin/python bench/fuzz_ui.py [--seconds 60] [--seed 1]
"""

from __future__ import annotations

import argparse
import asyncio
import json
import multiprocessing as mp
import random
import socket
import sys
import tempfile
import time
from multiprocessing.synchronize import Event
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import aiohttp  # noqa: E402

from bench.fuzz_daemon import baseline, under_attack  # noqa: E402
from tests.support.daemon import Daemon  # noqa: E402
from tests.support.ui import open_page, ui_daemon, ui_url  # noqa: E402

TOKEN = "fuzz-token-0123456789"
BASELINE_S = 15.0
OPS = ["auth", "write", "seek", "play", "pause", "speed", "hello", "", "x" * 40]
FIELDS = ["token", "symbol", "value", "id", "t", "x", "op"]
SYMBOLS = ["PLC.ch1.override", "PLC.ch1.feed_hold", "PLC.ch1.start", "PLC.ch1.stop",
           "PLC.ch1.reset", "PLC.ch1.m_ack", "PLC.ch2.override", "GEO.ch1.Z.lift_active",
           "GEO.cycle", "", "P" * 200]  # fmt: skip
LITERALS = ["Infinity", "-Infinity", "NaN", "1e999", "null", "true", "[]", "{}", '"\\ud800"']


def value(r: random.Random, depth: int = 0) -> str:
    """A random JSON-ish value as text (may be invalid JSON on purpose)."""
    k = r.randrange(9 if depth < 3 else 6)
    if k == 0:
        return str(r.choice([0, 1, -1, 1000, 2000, 1 << 31, -(1 << 31) - 1, 1 << 64]))
    if k == 1:
        return repr(r.uniform(-1e6, 1e6))
    if k == 2:
        return json.dumps(r.choice([*SYMBOLS, TOKEN, "wrong"]))
    if k in (3, 4, 5):
        return r.choice(LITERALS)
    if k == 6:
        return "[" + ",".join(value(r, depth + 1) for _ in range(r.randrange(4))) + "]"
    if k == 7:
        return "{" + ",".join(f'"{r.choice(FIELDS)}":{value(r, depth + 1)}'
                              for _ in range(r.randrange(4))) + "}"  # fmt: skip
    return "[" * (n := r.randrange(500, 2000)) + "]" * n


def message(r: random.Random) -> str | bytes:
    k = r.randrange(10)
    if k == 0:
        return bytes(r.randrange(256) for _ in range(r.randrange(1, 64)))
    if k == 1:
        return "".join(chr(r.randrange(1, 0x2FFF)) for _ in range(r.randrange(64)))
    if k == 2:
        return "x" * r.choice([4097, 10_000, 60_000])  # over max_message_bytes
    if k == 3:
        return value(r)
    if k == 4:
        return json.dumps({"op": "auth", "token": r.choice([TOKEN, "wrong", ""])})
    if k == 5:
        return json.dumps({"op": "write", "id": r.randrange(100), "symbol": r.choice(SYMBOLS),
                           "value": r.choice([0, 1, True, False, 500, 1000, 2000, -5])})  # fmt: skip
    fields = ",".join(f'"{r.choice(FIELDS)}":{value(r)}' for _ in range(r.randrange(4)))
    return '{"op":' + json.dumps(r.choice(OPS)) + ("," + fields if fields else "") + "}"


async def messages(url: str, r: random.Random, end: float, stats: dict[str, int]) -> None:
    while time.monotonic() < end:
        try:
            page = await open_page(url)
        except (TimeoutError, aiohttp.ClientError, OSError, AssertionError):
            stats["refused"] += 1
            await asyncio.sleep(0.05)
            continue
        try:
            for _ in range(r.randrange(1, 200)):
                m = message(r)
                await (page.ws.send_bytes(m) if isinstance(m, bytes) else page.ws.send_str(m))
                stats["messages"] += 1
                got = await page.receive(2.0)
                while got["op"] == "frames":
                    got = await page.receive(2.0)
                if got["op"] == "closed":
                    stats["closed_by_server"] += 1
                    break
                stats["replies"] += 1
        except (TimeoutError, aiohttp.ClientError, OSError, ConnectionError):
            stats["closed_by_server"] += 1
        finally:
            await page.close()


def http_request(r: random.Random, host: str) -> bytes:
    path = r.choice(["/", "/ws", "/static/app.js", "/static/../../etc/passwd", "/%00",
                     "/static/" + "a" * 5000, "/favicon.ico", "/metrics", "/" + "?" * 300])  # fmt: skip
    method = r.choice(["GET", "POST", "PUT", "DELETE", "OPTIONS", "GARBAGE", "G\x00T"])
    headers = [f"Host: {r.choice([host, 'evil.example', '127.0.0.1.nip.io', '', host * 50])}"]
    if r.random() < 0.5:
        headers += ["Upgrade: websocket", "Connection: Upgrade",
                    "Sec-WebSocket-Key: " + r.choice(["dGhlIHNhbXBsZSBub25jZQ==", "", "x" * 99]),
                    "Sec-WebSocket-Version: " + r.choice(["13", "8", "x"])]  # fmt: skip
    if r.random() < 0.3:
        headers.append("Origin: " + r.choice(["http://evil.example", "null", f"http://{host}"]))
    if r.random() < 0.2:
        headers.append("X-Big: " + "b" * r.choice([9000, 70_000]))
    if r.random() < 0.2:
        headers.append("Content-Length: " + r.choice(["-1", "99999999999", "x", "10"]))
    raw = f"{method} {path} HTTP/1.1\r\n" + "\r\n".join(headers) + "\r\n\r\n"
    data = raw.encode("utf-8", "replace")
    if r.random() < 0.2:
        data = data[: r.randrange(len(data))]  # cut
    if r.random() < 0.1:
        data = bytes(r.randrange(256) for _ in range(r.randrange(1, 300)))
    return data


def http(port: int, r: random.Random, end: float, stats: dict[str, int]) -> None:
    host = f"127.0.0.1:{port}"
    while time.monotonic() < end:
        s = socket.create_connection(("127.0.0.1", port), timeout=2.0)
        try:
            s.sendall(http_request(r, host))
            stats["requests"] += 1
            s.settimeout(0.5)
            head = s.recv(64)
            stats["answered"] += head.startswith(b"HTTP/1.1")
        except OSError:
            stats["no_answer"] += 1
        finally:
            s.close()


async def churn(url: str, end: float, stats: dict[str, int]) -> None:
    while time.monotonic() < end:
        try:
            pages = await asyncio.gather(*(open_page(url) for _ in range(24)),
                                         return_exceptions=True)  # fmt: skip
        except Exception:  # counted as refused
            pages = []
        for p in pages:
            if isinstance(p, BaseException):
                stats["refused"] += 1
            else:
                stats["opened"] += 1
                await p.close()


def attack(url: str, seconds: float, seed: int, out: mp.Queue[list[dict[str, object]]],
           stop: Event) -> None:  # fmt: skip
    r = random.Random(seed)
    port = int(url.rstrip("/").rsplit(":", 1)[1])
    end = time.monotonic() + seconds
    st_msg = dict.fromkeys(["messages", "replies", "closed_by_server", "refused"], 0)
    st_http = dict.fromkeys(["requests", "answered", "no_answer"], 0)
    st_churn = dict.fromkeys(["opened", "refused"], 0)

    async def main() -> None:
        loop = asyncio.get_running_loop()
        await asyncio.gather(
            *(messages(url, random.Random(r.random()), end, st_msg) for _ in range(4)),
            churn(url, end, st_churn),
            loop.run_in_executor(None, http, port, random.Random(r.random()), end, st_http),
        )

    asyncio.run(main())
    out.put([{"surface": "messages", **st_msg}, {"surface": "http", **st_http},
             {"surface": "churn", **st_churn}])  # fmt: skip


async def still_serving(url: str) -> dict[str, Any]:
    page = await open_page(url)
    try:
        await page.send({"op": "auth", "token": TOKEN})
        auth = await page.reply("auth")
        await page.send({"op": "write", "id": 1, "symbol": "PLC.ch1.override", "value": 1000})
        result = await page.reply("result")
        return {"hello_after": bool(page.hello), "auth_after": auth.get("ok"),
                "write_after": result.get("ok")}  # fmt: skip
    finally:
        await page.close()


def run(d: Daemon, seconds: float, seed: int) -> None:
    url = ui_url(d)
    time.sleep(1.0)
    baseline(d, "fuzz_ui", BASELINE_S)
    a = under_attack(d, attack, (url, seconds, seed))
    after = asyncio.run(still_serving(url)) if a.alive else {}
    for row in a.rows:
        print(json.dumps({"bench": "fuzz_ui", **row}), flush=True)
    print(json.dumps({
        "bench": "fuzz_ui", "surface": "all", "seconds": round(a.seconds),
        "daemon_alive": a.alive, "rss_before_mb": round(a.rss_before_mb, 1),
        "rss_peak_mb": round(a.rss_peak_mb, 1),
        "rss_growth_mb": round(a.rss_peak_mb - a.rss_before_mb, 1), **a.probe, **after,
        "geo_exceeded": a.geo_exceeded,
        "geo_exceeded_per_min": round(a.geo_exceeded * 60 / a.seconds, 1),
        "tracebacks": sum("Traceback" in line for line in d.raw),
        "aiohttp_errors": sum("Error handling request" in line for line in d.raw),
        "ui_bad_messages_logged": d.count("ui.page_closed") + d.count("ui.auth_failed"),
    }), flush=True)  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        d = ui_daemon(Path(tmp), hops=True, control=True, token=TOKEN)
        try:
            run(d, args.seconds, args.seed)
        finally:
            d.stop()


if __name__ == "__main__":
    main()
