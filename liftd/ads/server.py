"""The ADS/AMS TCP server: the only module of liftd.ads with sockets and asyncio.

Per connection (reference/ads.md §4.5, §8): an incremental framer; every request answered on
the connection it came on (addresses swapped, same invoke id); AMS errors 0x7 (foreign NetId),
0x6 (port not hosted), 0x8 (unknown command), 0xE (AMS length ≠ TCP length); the access policy
(peer IP ranges and source NetIds: close, or answer 0x723; writes only from write NetIds, else
0x704); TCP_NODELAY; one writer, and when the peer does not read, a bounded queue, then close.
Notifications of all connections are polled by one task at their cycle; objects read once per
poll and shared between subscribers.
"""

from __future__ import annotations

import asyncio
import contextlib
import ipaddress
import socket
import time
from collections import deque
from dataclasses import dataclass, field
from typing import Any

from liftd.ads import wire
from liftd.ads.constants import (
    RESPONSE_FLAGS,
    AdsErr,
    AmsError,
    Command,
    IndexGroup,
    StateFlag,
)
from liftd.ads.errors import AdsError, FramingError
from liftd.ads.framing import AmsFramer
from liftd.ads.notifications import Outgoing
from liftd.ads.service import STATIC_HANDLE_BIT, AdsService, Session

IpNetwork = ipaddress.IPv4Network | ipaddress.IPv6Network
SERVED = frozenset(int(c) for c in Command if c not in (Command.INVALID, Command.NOTIFICATION))
_RESPONSE_BIT = int(StateFlag.RESPONSE)  # plain ints on the hot path (IntFlag & costs ~3 µs)
_NOTIFICATION = int(Command.NOTIFICATION)
_ADD_NOTIFICATION = int(Command.ADD_NOTIFICATION)
IDLE_POLL_S = 0.1  # notification task wake-up when nothing is due (incomplete-frame checks)


@dataclass(frozen=True, slots=True)
class ServerConfig:
    host: str = "127.0.0.1"
    port: int = 48898
    net_ids: frozenset[bytes] = frozenset({bytes([127, 0, 0, 1, 1, 1])})
    ams_ports: frozenset[int] = frozenset({551})
    max_connections: int = 64
    max_frame_bytes: int = 1 << 20
    write_queue_frames: int = 1024
    incomplete_frame_timeout_s: float = 10.0
    allow_ips: tuple[IpNetwork, ...] = ()  # empty: every peer
    allow_net_ids: frozenset[bytes] = frozenset()  # empty: every source NetId
    write_net_ids: frozenset[bytes] = frozenset()  # empty: every allowed source may write
    reject: str = "close"  # or "error": answer ADS 0x723


class RateLimiter:
    """At most one log line per key and interval; counts what it held back."""

    def __init__(self, interval_s: float = 1.0) -> None:
        self.interval_s = interval_s
        self._last: dict[str, float] = {}
        self.suppressed: dict[str, int] = {}

    def allow(self, key: str) -> tuple[bool, int]:
        now = time.monotonic()
        if now - self._last.get(key, -1e18) < self.interval_s:
            self.suppressed[key] = self.suppressed.get(key, 0) + 1
            return False, 0
        if len(self._last) > 10_000:  # keys are peers: bounded under a flood of them
            self._last.clear()
        self._last[key] = now
        return True, self.suppressed.pop(key, 0)


@dataclass
class Counters:
    connections: int = 0
    rejected_connections: int = 0
    requests: int = 0
    notifications_sent: int = 0
    closed_for_errors: int = 0
    internal_errors: int = 0


class AdsConnection(asyncio.Protocol):
    def __init__(self, server: AdsServer) -> None:
        self.server = server
        self.transport: asyncio.Transport | None = None
        self.peer = "?"
        self.framer = AmsFramer(server.config.max_frame_bytes)
        self.session: Session = server.service.new_session()
        self.queue: deque[bytes] = deque()
        self.paused = False
        self.partial_since: float | None = None
        self.closed = False

    # -- asyncio.Protocol -------------------------------------------------------------------------
    def connection_made(self, base: asyncio.BaseTransport) -> None:
        transport: asyncio.Transport = base  # type: ignore[assignment]  # uvloop's: no subclass
        self.transport = transport
        peer = transport.get_extra_info("peername")
        self.peer = f"{peer[0]}:{peer[1]}" if peer else "?"
        srv = self.server
        if len(srv.connections) >= srv.config.max_connections:
            srv.warn("ads.connection_refused", self.peer, reason="max_connections")
            srv.counters.rejected_connections += 1
            transport.abort()
            return
        if peer and not srv.ip_allowed(peer[0]):
            srv.warn("ads.connection_refused", self.peer, reason="peer IP not allowed")
            srv.counters.rejected_connections += 1
            transport.abort()
            return
        sock = transport.get_extra_info("socket")
        if sock is not None and sock.family in (socket.AF_INET, socket.AF_INET6):
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        srv.connections.add(self)
        srv.counters.connections += 1
        srv.log.info("ads.connection_opened", peer=self.peer, connections=len(srv.connections))

    def connection_lost(self, exc: Exception | None) -> None:
        self.closed = True
        if self in self.server.connections:
            self.server.connections.discard(self)
            self.server.log.info("ads.connection_closed", peer=self.peer,
                                 connections=len(self.server.connections))  # fmt: skip
        self.session.notifications.clear()
        self.session.handles.clear()
        self.queue.clear()

    def data_received(self, data: bytes) -> None:
        broken: FramingError | None = None
        try:
            frames = self.framer.feed(data)
        except FramingError as exc:  # answer what came before the break, then close
            frames, broken = exc.frames, exc
        self.partial_since = time.monotonic() if self.framer.pending else None
        for raw in frames:
            if self.closed:
                return
            self.handle(raw)
        if broken is not None and not self.closed:
            self.close_for("ads.framing_error", str(broken))

    def pause_writing(self) -> None:
        self.paused = True
        if self.transport is not None:
            self.transport.pause_reading()  # a peer that does not read gets no more answers

    def resume_writing(self) -> None:
        self.paused = False
        while self.queue and not self.paused and self.transport is not None:
            self.transport.write(self.queue.popleft())
        if not self.paused and self.transport is not None and not self.closed:
            self.transport.resume_reading()

    # -- frames ------------------------------------------------------------------------------------
    def send(self, frame: bytes) -> None:
        if self.closed or self.transport is None:
            return
        if not self.paused:
            self.transport.write(frame)
            return
        self.queue.append(frame)
        if len(self.queue) > self.server.config.write_queue_frames:
            self.close_for("ads.write_queue_full", f"{len(self.queue)} frames not read")

    def close_for(self, event: str, detail: str) -> None:
        self.server.warn(event, self.peer, detail=detail)
        self.server.counters.closed_for_errors += 1
        self.closed = True
        if self.transport is not None:
            self.transport.abort()

    def handle(self, raw: bytes) -> None:
        srv = self.server
        cfg = srv.config
        reserved = wire.TCP_HEADER.unpack_from(raw)[0]
        if reserved != 0:  # AMS router commands (port connect, …): liftd is a target
            self.close_for("ads.router_command", f"AMS/TCP command 0x{reserved:X}")
            return
        header = wire.AmsHeader._make(wire.AMS_HEADER.unpack_from(raw, wire.TCP_SIZE))
        if header.flags & _RESPONSE_BIT or header.command == _NOTIFICATION:
            return  # a stray response or a notification: nothing to answer
        srv.counters.requests += 1
        if header.length != len(raw) - wire.HEADER_SIZE:
            self.reply(header, b"", AmsError.INVALID_AMS_LENGTH)
            return
        if cfg.allow_net_ids and header.source_net_id not in cfg.allow_net_ids:
            source = wire.net_id_text(header.source_net_id)
            if cfg.reject == "close":
                self.close_for("ads.source_refused", f"source NetId {source} not allowed")
                return
            srv.warn("ads.source_refused", self.peer, detail=f"source NetId {source}")
            self.reply(header, srv.service.rejected(header.command, AdsErr.ACCESSDENIED))
            return
        if header.target_net_id not in cfg.net_ids:
            self.reply(header, b"", AmsError.TARGET_MACHINE_NOT_FOUND)
        elif header.target_port not in cfg.ams_ports:
            self.reply(header, b"", AmsError.TARGET_PORT_NOT_FOUND)
        elif header.command not in SERVED:
            self.reply(header, b"", AmsError.UNKNOWN_CMD_ID)
        else:
            may_write = not cfg.write_net_ids or header.source_net_id in cfg.write_net_ids
            payload = raw[wire.HEADER_SIZE :]
            answer = srv.service.handle(self.session, header, payload, may_write,
                                        time.monotonic_ns())  # fmt: skip
            if answer.failure is not None:
                srv.counters.internal_errors += 1
                srv.error("ads.handler_failed", self.peer, answer.failure, header.command)
            self.reply(header, answer.payload)
            if header.command == _ADD_NOTIFICATION:
                srv.wake.set()

    def reply(self, request: wire.AmsHeader, payload: bytes, ams_error: int = 0) -> None:
        header = wire.reply_header(request, RESPONSE_FLAGS, ams_error)
        self.send(wire.encode_frame(header, payload))

    def notify(self, out: Outgoing) -> None:
        header = wire.AmsHeader(out.client.net_id, out.client.port, out.server.net_id,
                                out.server.port, Command.NOTIFICATION, StateFlag.ADS_COMMAND,
                                0, 0, 0)  # fmt: skip
        self.send(wire.encode_frame(header, out.payload))
        self.server.counters.notifications_sent += 1


@dataclass
class AdsServer:
    config: ServerConfig
    service: AdsService
    log: Any  # a structlog logger (bound); the server is the IO shell that logs
    connections: set[AdsConnection] = field(default_factory=set)
    counters: Counters = field(default_factory=Counters)
    limiter: RateLimiter = field(default_factory=RateLimiter)
    wake: asyncio.Event = field(default_factory=asyncio.Event)
    port: int = 0
    _server: asyncio.Server | None = None
    _task: asyncio.Task[None] | None = None

    async def start(self, sock: socket.socket | None = None) -> int:
        """Listen (on `sock` if given, e.g. from systemd); returns the TCP port bound."""
        loop = asyncio.get_running_loop()
        if sock is not None:
            self._server = await loop.create_server(lambda: AdsConnection(self), sock=sock)
        else:
            self._server = await loop.create_server(
                lambda: AdsConnection(self), self.config.host, self.config.port, backlog=256
            )
        self.port = self._server.sockets[0].getsockname()[1]
        self._task = asyncio.create_task(self._notifications(), name="ads-notifications")
        self.log.info("ads.listening", host=self.config.host, port=self.port,
                      ams_ports=sorted(self.config.ams_ports))  # fmt: skip
        return self.port

    async def close(self) -> None:
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task
        if self._server is not None:
            self._server.close()
        for conn in list(self.connections):
            if conn.transport is not None:
                conn.transport.abort()
        if self._server is not None:
            await self._server.wait_closed()

    def ip_allowed(self, host: str) -> bool:
        if not self.config.allow_ips:
            return True
        try:
            addr = ipaddress.ip_address(host.split("%", 1)[0])
        except ValueError:
            return False
        return any(addr in net for net in self.config.allow_ips)

    def warn(self, event: str, peer: str, **kw: Any) -> None:
        ok, held = self.limiter.allow(f"{event}:{peer.rsplit(':', 1)[0]}")
        if ok:
            self.log.warning(event, peer=peer, suppressed=held, **kw)

    def error(self, event: str, peer: str, exc: BaseException, command: int) -> None:
        ok, held = self.limiter.allow(f"{event}:{type(exc).__name__}")
        if ok:
            self.log.error(event, peer=peer, command=command, suppressed=held,
                           exc_info=(type(exc), exc, exc.__traceback__))  # fmt: skip

    # -- notifications ----------------------------------------------------------------------------
    async def _notifications(self) -> None:
        while True:
            self.wake.clear()
            now = time.monotonic_ns()
            self.poll_notifications(now, time.time_ns())
            due = [
                t
                for c in self.connections
                if (t := c.session.notifications.next_wakeup()) is not None
            ]
            delay = IDLE_POLL_S if not due else max(0.0, (min(due) - time.monotonic_ns()) / 1e9)
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(self.wake.wait(), min(delay, IDLE_POLL_S))

    def poll_notifications(self, now_ns: int, unix_ns: int) -> None:
        memo: dict[tuple[int, int, int], bytes | AdsError] = {}
        timeout = self.config.incomplete_frame_timeout_s
        for conn in list(self.connections):
            if conn.partial_since is not None and time.monotonic() - conn.partial_since > timeout:
                conn.close_for("ads.incomplete_frame_timeout", f"{conn.framer.pending} bytes")
                continue
            table = conn.session.notifications
            if not table.subs:
                continue

            def read(ig: int, io: int, n: int, s: Session = conn.session) -> bytes:
                if ig == IndexGroup.SYM_VALBYHND and not io & STATIC_HANDLE_BIT:
                    return self.service.read(s, ig, io, n)  # a connection's own handle
                key = (ig, io, n)
                got = memo.get(key)
                if got is None:
                    try:
                        got = self.service.read(s, ig, io, n)
                    except AdsError as exc:
                        got = exc
                    memo[key] = got
                if isinstance(got, AdsError):
                    raise got
                return got

            for out in table.poll(now_ns, unix_ns, read):
                conn.notify(out)
