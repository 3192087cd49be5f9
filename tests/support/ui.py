"""The live view from a test: the daemon's page URL, a WebSocket client (aiohttp) that speaks
the page's protocol, and a raw socket that opens a WebSocket and never reads."""

from __future__ import annotations

import asyncio
import base64
import json
import os
import re
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import aiohttp

from tests.support.daemon import Daemon, write_config

# the tests share 2 vCPUs with other sessions' suites: no RT settings, and a stall timeout that
# a busy minute does not reach (the daemon would exit 3 under the test)
QUIET_RT = {
    "sched_fifo_priority": 0,
    "hold_cpu_dma_latency": False,
    "lock_memory": False,
    "stall_timeout_ms": 20000,
}


def hops_program(parts: int = 60) -> str:
    """Cut 10 mm, lift over a 30 mm hop, again: a lift every ~0.25 s."""
    lines = ["%hops", "N10 G90 G17 G94", "#SLOPE[TYPE=TRAPEZ]", "N20 G00 X10 Y10 Z1"]
    x = 10
    for _ in range(parts):
        lines += [
            f"G01 X{x + 10} F6000",
            "Z[LIFT_START POS=1 POS_LIMIT=20]",
            f"G01 X{x + 40} F24000",
            "Z[LIFT_END]",
        ]
        x += 40
        if x > 1200:
            lines.append("G00 X10")
            x = 10
    return "\n".join([*lines, "M30", ""])


def ui_daemon(tmp: Path, *args: str, hops: bool | int = False, **ui: object) -> Daemon:
    """`liftd run` on the demo (or `hops_program`, of `hops` parts when a number), repeating,
    with the live view on a free port, ready."""
    program = None
    if hops:
        program = tmp / "hops.nc"
        program.write_text(hops_program() if hops is True else hops_program(int(hops)))
    cfg = write_config(
        tmp,
        program_file=str(program) if program else None,
        program={"repeat": True},
        ui={"enabled": True, "port": 0, **ui},
        rt=QUIET_RT,
    )
    d = Daemon(cfg, *args)
    d.ready()
    return d


def ui_url(d: Daemon) -> str:
    rec = d.event("daemon.ready")
    assert rec is not None and rec.get("ui"), "".join(d.raw)
    return str(rec["ui"])


class Page:
    """One page's WebSocket: `hello`, then `frames` folded into `values`."""

    def __init__(self, ws: aiohttp.ClientWebSocketResponse, session: aiohttp.ClientSession):
        self.ws, self.session = ws, session
        self.values: dict[str, Any] = {}
        self.hello: dict[str, Any] = {}
        self.replies: list[dict[str, Any]] = []
        self.changes: list[tuple[float, str, Any]] = []  # (monotonic, symbol, value)

    async def receive(self, timeout: float = 10.0) -> dict[str, Any]:
        msg = await self.ws.receive(timeout)
        if msg.type != aiohttp.WSMsgType.TEXT:
            return {"op": "closed", "type": msg.type, "code": self.ws.close_code}
        m: dict[str, Any] = json.loads(msg.data)
        now = time.monotonic()
        if m["op"] == "hello":
            self.hello = m
            self.values = dict(m["state"]["values"])
        elif m["op"] == "frames":
            for f in m["frames"]:
                for k, v in f["c"].items():
                    self.values[k] = v
                    self.changes.append((now, k, v))
        else:
            self.replies.append(m)
        return m

    async def reply(self, op: str, timeout: float = 10.0) -> dict[str, Any]:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            for m in self.replies:
                if m["op"] == op:
                    self.replies.remove(m)
                    return m
            m = await self.receive(max(0.1, end - time.monotonic()))
            if m["op"] == "closed":
                return m
        raise TimeoutError(op)

    async def send(self, msg: dict[str, Any]) -> None:
        await self.ws.send_str(json.dumps(msg))

    async def close(self) -> None:
        await self.ws.close()
        await self.session.close()


async def open_page(url: str, origin: str | None = "same", **kw: Any) -> Page:
    """A page of the view at `url` (origin "same": the page's own, None: no Origin header)."""
    headers = {}
    if origin == "same":
        headers["Origin"] = url.rstrip("/")
    elif origin is not None:
        headers["Origin"] = origin
    session = aiohttp.ClientSession()
    try:
        ws = await session.ws_connect(url + "ws", headers=headers, autoping=True, **kw)
    except BaseException:
        await session.close()
        raise
    page = Page(ws, session)
    m = await page.receive()
    assert m["op"] == "hello", m
    return page


def never_reading(url: str) -> socket.socket:
    """A WebSocket handshake on a small receive buffer, after which nothing is read."""
    host, port = url.split("//")[1].rstrip("/").rsplit(":", 1)
    s = socket.socket()
    s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    s.connect((host, int(port)))
    key = base64.b64encode(os.urandom(16)).decode()
    s.sendall(
        (
            f"GET /ws HTTP/1.1\r\nHost: {host}:{port}\r\nUpgrade: websocket\r\n"
            f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n"
            "Sec-WebSocket-Version: 13\r\n\r\n"
        ).encode()
    )
    head = s.recv(256)
    assert head.startswith(b"HTTP/1.1 101"), head
    return s


@contextmanager
def liftd_view(trace: Path, config: str) -> Iterator[str]:
    """`liftd view TRACE -c CONFIG` on a free port, running: its page's URL."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "liftd", "view", str(trace), "-c", config, "--port", "0"],
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stdout is not None
        line = proc.stdout.readline()
        found = re.search(r"http://\S+/", line)
        assert found is not None, line
        yield found.group(0)
    finally:
        proc.terminate()
        proc.wait(10)


def run(coro: Any) -> Any:
    return asyncio.run(coro)
