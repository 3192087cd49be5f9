"""The page's server (aiohttp on the daemon's event loop): `/` and its static files, `/ws` the
WebSocket of one page, `/drawing/<channel index>/<version>` a program's drawing (encoded once
per program version, never in a hello). What it refuses, and why:

* a Host header that is neither an IP literal, `localhost` nor one of `[ui] hosts` (421): a
  name an attacker's DNS points at 127.0.0.1 would otherwise make his page same-origin;
* a WebSocket whose `Origin` is not this page's own (403): no other site's page may read or
  control it (a client without Origin is not a browser and has no site to speak for);
* more than `MAX_HANDSHAKES_PER_S` WebSocket handshakes a second from one IP address (429: a
  page's hello is its whole state, a peer reconnecting in a loop must not keep the event loop
  the ADS server shares busy), more than `[ui] max_connections` WebSockets (503), a message
  over `[ui] max_message_bytes` (closed, 1009), binary or malformed messages (answered; the
  connection is closed after `MAX_BAD` of them), more than `MAX_MESSAGES_PER_S` messages a
  second (closed, 1008), a page that does not take what it is sent within `SEND_TIMEOUT_S`
  (aborted);
* a control message unless `[ui] control`, the access policy admits the peer and the page sent
  the token (`auth`; the connection is closed after `MAX_AUTH_FAILURES` wrong ones).
Every response carries a Content-Security-Policy that allows only this origin's scripts,
styles and WebSocket, no framing, no inline code.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import hmac
import json
import socket
import time
from collections import deque
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from importlib import resources
from typing import Any, Protocol

from aiohttp import WSMsgType, web

from liftd.ui.feed import encode
from liftd.ui.guard import host_allowed, http_logger, origin_allowed

CSP = (
    "default-src 'none'; script-src 'self'; style-src 'self'; img-src 'self' data:; "
    "connect-src 'self'; font-src 'self'; base-uri 'none'; form-action 'none'; "
    "frame-ancestors 'none'"
)
HEADERS = {
    "Content-Security-Policy": CSP,
    "X-Content-Type-Options": "nosniff",
    "X-Frame-Options": "DENY",
    "Referrer-Policy": "no-referrer",
    "Cache-Control": "no-store",
    "Cross-Origin-Opener-Policy": "same-origin",
    "Cross-Origin-Resource-Policy": "same-origin",
}
STATIC = {"index.html": "text/html", "app.js": "text/javascript", "style.css": "text/css"}
SEND_TIMEOUT_S = 5.0
SOCKET_BUFFER = 1 << 15  # a page takes ~20-50 KB/s: room for a second of it
MAX_BAD = 20
MAX_AUTH_FAILURES = 3
MAX_MESSAGES_PER_S = 100
MAX_WRITES_PER_S = 50
MAX_SYMBOL_CHARS = 80
MAX_HANDSHAKES_PER_S = 10  # per peer IP (a page reconnects once a second)
PEERS_KEPT = 1024  # peer IPs whose handshakes are counted (bounded: a flood of sources)


class Refused(Exception):
    """A control write the GEO task's input path refused (the ADS error's text)."""


Writer = Callable[[str, bool | int], None]  # symbol, value: raises Refused
PeerPolicy = Callable[[str], str]  # peer IP → "" when it may control, else why not
Drawings = Callable[[int, int], bytes | None]  # channel index, version → the encoded drawing


class Session(Protocol):
    """One page's data: the live hub's or a trace player's."""

    period: float | None  # the page's own update period (trace), None: woken by the hub

    def hello(self) -> dict[str, Any]: ...
    def take(self) -> list[str] | None: ...  # frames since the last take; None: send hello
    def command(self, msg: dict[str, Any]) -> dict[str, Any] | None: ...  # None: not one
    def attach(self, wake: asyncio.Event) -> None: ...
    def detach(self, wake: asyncio.Event) -> None: ...


@dataclass(frozen=True, slots=True)
class WebConfig:
    host: str = "127.0.0.1"
    port: int = 8551
    control: bool = False
    token: str | None = None
    hosts: tuple[str, ...] = ()
    max_connections: int = 16
    max_message_bytes: int = 4096
    mode: str = "live"  # or "trace"
    handshakes_per_s: int = MAX_HANDSHAKES_PER_S


@dataclass
class Counters:
    pages: int = 0  # WebSockets opened
    refused: int = 0  # handshakes refused (Host, Origin, too many)
    bad_messages: int = 0
    writes: int = 0
    writes_refused: int = 0


class _Page:
    def __init__(self, ip: str) -> None:
        self.ip = ip
        self.authed = False
        self.auth_failures = 0
        self.bad = 0
        self.replies: deque[str] = deque()
        self.wake = asyncio.Event()
        self.window: deque[float] = deque()
        self.writes: deque[float] = deque()


def _rate_ok(window: deque[float], limit: int, now: float) -> bool:
    while window and now - window[0] > 1.0:
        window.popleft()
    window.append(now)
    return len(window) <= limit


class UiServer:
    def __init__(
        self,
        cfg: WebConfig,
        new_session: Callable[[], Session],
        log: Any,
        writer: Writer | None = None,
        policy: PeerPolicy | None = None,
        drawings: Drawings | None = None,
    ) -> None:
        self.cfg = cfg
        self.drawings = drawings
        self.new_session = new_session
        self.log = log
        self.writer = writer
        self.policy = policy
        self.counters = Counters()
        self.open = 0
        self.port = 0
        self._files = {n: (resources.files("liftd.ui") / "static" / n).read_bytes() for n in STATIC}
        self._runner: web.AppRunner | None = None
        self._handshakes: dict[str, deque[float]] = {}  # peer IP → its handshakes' times
        self._pages: set[_Page] = set()  # the open pages (a new token locks them)

    # -- lifecycle --------------------------------------------------------------------------------
    async def start(self) -> int:
        app = web.Application(middlewares=[self._guard], client_max_size=self.cfg.max_message_bytes)
        app.router.add_get("/", self._index)
        app.router.add_get("/static/{name}", self._static)
        app.router.add_get("/ws", self._ws)
        app.router.add_get("/drawing/{index:\\d+}/{version:\\d+}", self._drawing)
        app.router.add_get("/favicon.ico", self._no_icon)
        self._runner = web.AppRunner(app, access_log=None, handle_signals=False,
                                     logger=http_logger(self.log))  # fmt: skip
        await self._runner.setup()
        site = web.TCPSite(
            self._runner, self.cfg.host, self.cfg.port, backlog=64, shutdown_timeout=0.5
        )
        await site.start()
        addresses = self._runner.addresses  # the real port (port 0 = any)
        self.port = int(addresses[0][1]) if addresses else self.cfg.port
        return self.port

    def set_token(self, token: str | None) -> None:
        """A new control token (a reload): pages unlocked with the old one lose control and
        are told so; they unlock again with the new one."""
        self.cfg = dataclasses.replace(self.cfg, token=token)
        for page in self._pages:
            if page.authed:
                page.authed = False
                page.replies.append(encode(
                    {"op": "auth", "ok": False, "detail": "the token changed: enter the new one"}
                ))  # fmt: skip
                page.wake.set()

    async def close(self) -> None:
        if self._runner is not None:
            await self._runner.cleanup()

    # -- HTTP -------------------------------------------------------------------------------------
    @web.middleware
    async def _guard(
        self, request: web.Request, handler: Callable[[web.Request], Awaitable[web.StreamResponse]]
    ) -> web.StreamResponse:
        if not host_allowed(request.host, self.cfg.hosts):
            self.counters.refused += 1
            response: web.StreamResponse = web.Response(status=421, text="unknown Host\n")
        else:
            try:
                response = await handler(request)
            except web.HTTPException as exc:
                response = exc
        if not response.prepared:
            response.headers.update(HEADERS)
        return response

    async def _index(self, request: web.Request) -> web.Response:
        return web.Response(
            body=self._files["index.html"], content_type="text/html", charset="utf-8"
        )

    async def _no_icon(self, request: web.Request) -> web.Response:
        return web.Response(status=204)

    async def _static(self, request: web.Request) -> web.Response:
        name = request.match_info["name"]
        if name not in STATIC:
            raise web.HTTPNotFound()
        return web.Response(body=self._files[name], content_type=STATIC[name], charset="utf-8")

    async def _drawing(self, request: web.Request) -> web.Response:
        """A channel's drawing, encoded once per program version (not per page): 404 when the
        version is not the current one (the page gets the new one in its next frame)."""
        index, version = request.match_info["index"], request.match_info["version"]
        body = None
        if self.drawings is not None and len(index) <= 4 and len(version) <= 12:
            body = self.drawings(int(index), int(version))
        if body is None:
            raise web.HTTPNotFound()
        return web.Response(body=body, content_type="application/json")

    # -- WebSocket --------------------------------------------------------------------------------
    def _refusal(self, request: web.Request) -> web.Response | None:
        """Why a WebSocket handshake is refused (handshake rate, Origin, too many pages)."""
        ip = request.remote or "?"
        if len(self._handshakes) > PEERS_KEPT:
            self._handshakes.clear()
        window, now = self._handshakes.setdefault(ip, deque()), time.monotonic()
        while window and now - window[0] > 1.0:
            window.popleft()
        if len(window) >= self.cfg.handshakes_per_s:  # (a refused one is not counted)
            self.counters.refused += 1
            return web.Response(status=429, text="too many WebSocket handshakes\n")
        window.append(now)
        if not origin_allowed(request.headers.get("Origin"), request.host):
            self.counters.refused += 1
            self.log.warning(
                "ui.origin_refused", origin=request.headers.get("Origin"), peer=request.remote
            )
            return web.Response(status=403, text="cross-origin WebSocket refused\n")
        if self.open >= self.cfg.max_connections:
            self.counters.refused += 1
            return web.Response(status=503, text="too many pages open\n")
        return None

    async def _ws(self, request: web.Request) -> web.StreamResponse:
        refusal = self._refusal(request)
        if refusal is not None:
            return refusal
        ws = web.WebSocketResponse(
            max_msg_size=self.cfg.max_message_bytes,
            compress=False,
            heartbeat=20.0,
            writer_limit=SOCKET_BUFFER,
        )
        transport = request.transport
        sock = transport.get_extra_info("socket") if transport else None
        if sock is not None:  # fixed buffers (no autotuning to MBs): a page that does not read
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, SOCKET_BUFFER)  # is seen soon
        if transport is not None:
            transport.set_write_buffer_limits(high=SOCKET_BUFFER)
        self.open += 1
        self.counters.pages += 1
        page = _Page(request.remote or "?")
        self._pages.add(page)
        session = self.new_session()
        sender: asyncio.Task[None] | None = None
        try:
            await ws.prepare(request)
            sender = asyncio.create_task(self._send_loop(ws, request, session, page))
            async for msg in ws:
                if msg.type not in (WSMsgType.TEXT, WSMsgType.BINARY):
                    break  # ERROR (e.g. a frame over max_message_bytes: aiohttp closed it)
                if not _rate_ok(page.window, MAX_MESSAGES_PER_S, time.monotonic()):
                    await ws.close(code=1008, message=b"too many messages")
                    break
                if msg.type == WSMsgType.TEXT:
                    reply = self._message(page, session, msg.data)
                else:
                    reply = self._bad(page, "binary message")
                if reply is not None:
                    page.replies.append(encode(reply))
                    page.wake.set()
                if page.bad > MAX_BAD or page.auth_failures >= MAX_AUTH_FAILURES:
                    if sender is not None:  # the refusal first, then the close
                        sender.cancel()
                    with contextlib.suppress(Exception):
                        while page.replies:
                            await self._send(ws, request, page.replies.popleft())
                    await ws.close(code=1008, message=b"too many refused messages")
                    break
        finally:
            self.open -= 1
            self._pages.discard(page)
            if sender is not None:
                sender.cancel()
                with contextlib.suppress(asyncio.CancelledError, Exception):
                    await sender
        return ws

    async def _send_loop(
        self, ws: web.WebSocketResponse, request: web.Request, session: Session, page: _Page
    ) -> None:
        session.attach(page.wake)
        try:
            hello = {**session.hello(), "control": self._control_state(page)}
            await self._send(ws, request, encode(hello))
            while not ws.closed:
                page.wake.clear()
                while page.replies:
                    await self._send(ws, request, page.replies.popleft())
                frames = session.take()
                if frames is None:
                    hello = {**session.hello(), "control": self._control_state(page)}
                    await self._send(ws, request, encode(hello))
                elif frames:
                    await self._send(
                        ws, request, '{"op":"frames","frames":[' + ",".join(frames) + "]}"
                    )
                if session.period is None:
                    await page.wake.wait()
                else:
                    with contextlib.suppress(TimeoutError):
                        await asyncio.wait_for(page.wake.wait(), session.period)
        except Exception as exc:  # a bug must not leave a page open that shows stale values
            self.log.error("ui.page_failed", peer=page.ip, error=f"{type(exc).__name__}: {exc}")
            if request.transport is not None:
                request.transport.abort()
        finally:
            session.detach(page.wake)

    async def _send(self, ws: web.WebSocketResponse, request: web.Request, text: str) -> None:
        """Send, or end this page's sender: a page gone (closed) quietly, a page that does not
        take what it is sent within SEND_TIMEOUT_S with a reset and a log line."""
        try:
            await asyncio.wait_for(ws.send_str(text), SEND_TIMEOUT_S)
        except TimeoutError:
            self.log.warning(
                "ui.page_dropped",
                peer=page_peer(request),
                detail="the page does not take its updates",
            )
            if request.transport is not None:
                request.transport.abort()
            raise asyncio.CancelledError from None
        except (ConnectionError, RuntimeError):  # closed meanwhile
            raise asyncio.CancelledError from None

    # -- messages ---------------------------------------------------------------------------------
    def _control_state(self, page: _Page) -> dict[str, Any]:
        if self.cfg.mode != "live":
            return {"enabled": False, "detail": "a recorded trace: nothing to control"}
        if not self.cfg.control or self.writer is None:
            return {"enabled": False, "detail": "read only ([ui] control = false)"}
        why = self.policy(page.ip) if self.policy is not None else ""
        if why:
            return {"enabled": False, "detail": f"read only for this peer: {why}"}
        return {"enabled": True, "authed": page.authed, "detail": "token required"}

    def _message(self, page: _Page, session: Session, text: str) -> dict[str, Any] | None:
        try:
            msg = json.loads(text)
        except (ValueError, RecursionError):  # RecursionError: ~1 000 brackets fit in 4 KiB
            msg = None
        if not isinstance(msg, dict) or not isinstance(msg.get("op"), str):
            return self._bad(page, "a message is a JSON object with an op")
        op = msg["op"]
        if op == "auth":
            return self._auth(page, msg)
        if op == "write":
            return self._write(page, msg)
        try:
            reply = session.command(msg)
        except (TypeError, ValueError) as exc:
            return self._bad(page, f"{op}: {exc}")
        if reply is None:
            return self._bad(page, f"unknown op {op[:32]!r}")
        return reply

    def _bad(self, page: _Page, detail: str) -> dict[str, Any]:
        page.bad += 1
        self.counters.bad_messages += 1
        return {"op": "error", "detail": detail}

    def _auth(self, page: _Page, msg: dict[str, Any]) -> dict[str, Any]:
        state = self._control_state(page)
        if not state["enabled"]:
            return {"op": "auth", "ok": False, "detail": state["detail"]}
        token = msg.get("token")
        expected = (self.cfg.token or "").encode()
        given = token.encode("utf-8", "replace") if isinstance(token, str) else b""
        if not expected or not hmac.compare_digest(given, expected):
            page.auth_failures += 1
            self.log.warning("ui.auth_failed", peer=page.ip, failures=page.auth_failures)
            return {"op": "auth", "ok": False, "detail": "wrong token"}
        page.authed = True
        return {"op": "auth", "ok": True, "detail": "control unlocked"}

    def _write(self, page: _Page, msg: dict[str, Any]) -> dict[str, Any]:
        ident = msg.get("id")
        ident = ident if isinstance(ident, int) and not isinstance(ident, bool) else None

        def refuse(detail: str) -> dict[str, Any]:
            self.counters.writes_refused += 1
            return {"op": "result", "id": ident, "ok": False, "detail": detail}

        state = self._control_state(page)
        if not state["enabled"]:
            return refuse(state["detail"])
        if not page.authed:
            return refuse("no token: send auth first")
        symbol, value = msg.get("symbol"), msg.get("value")
        if not isinstance(symbol, str) or not 0 < len(symbol) <= MAX_SYMBOL_CHARS:
            return refuse("symbol: a PLC.chN.* name")
        if not isinstance(value, bool | int) or (
            not isinstance(value, bool) and not -(1 << 31) <= value < 1 << 31
        ):
            return refuse("value: true/false, or an integer in the object's ADS unit")
        if not _rate_ok(page.writes, MAX_WRITES_PER_S, time.monotonic()):
            return refuse(f"more than {MAX_WRITES_PER_S} writes a second")
        assert self.writer is not None
        try:
            self.writer(symbol, value)
        except Refused as exc:
            return refuse(str(exc))
        self.counters.writes += 1
        return {"op": "result", "id": ident, "ok": True, "symbol": symbol, "value": value}


def page_peer(request: web.Request) -> str:
    """The page's address and port (its connection, as the ADS log names a peer)."""
    peer = request.transport.get_extra_info("peername") if request.transport else None
    return f"{peer[0]}:{peer[1]}" if peer else request.remote or "?"
