"""The ADS/AMS TCP server: the only TCP module of liftd.ads (udp.py is the UDP one).

Per connection (reference/ads.md §4.5, §8): an incremental framer; every request answered on
the connection it came on (addresses swapped, same invoke id); AMS errors 0x7 (foreign NetId),
0x6 (port not hosted), 0x8 (unknown command), 0xE (AMS length ≠ TCP length); the access policy
(peer IP ranges and source NetIds: close, or answer 0x723; writes only from write NetIds, else
0x704); TCP_NODELAY; one writer, and when the peer does not read, a bounded queue, then close.
Notifications of all connections are polled by one task at their cycle; objects read once per
poll and shared between subscribers.

As a router (router.py): AMS/TCP port connect/close and "get NetId"; frames for a port a client
registered go to that client, responses back to whoever asked. Port 10000 is the system
service (system.py).

Memory is a budget in bytes: what liftd holds for a connection (the replies, notifications
and routed frames its peer has not taken yet, in the transport's buffer and in the queue
behind it, and a request not yet complete) stays under `connection_budget_bytes`, else the
connection is closed; what it holds for all connections under `budget_bytes`, else the one
holding most is closed. Routed frames count against the receiver. A reply is never larger than
a frame (service.py refuses it with 0x70A before building it). Whatever the protocol layer
raises for one connection closes that connection (logged, counted), never the transport's
`Fatal error` path, so the others are served on.

Nobody crowds out the PLC: a connection that has sent no valid frame yet ("unidentified") is
closed after `first_frame_timeout_s`, and when the table (or the peer address's share of it)
is full, a new connection evicts the oldest unidentified one instead of being refused (sshd's
MaxStartups idea). Connection events are logged rate-limited per peer.
"""

from __future__ import annotations

import asyncio
import contextlib
import ipaddress
import socket
import struct
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from liftd.ads import wire
from liftd.ads.constants import (
    RESPONSE_FLAGS,
    SYSTEM_SERVICE_PORT,
    AdsErr,
    AmsError,
    AmsTcpCommand,
    Command,
    IndexGroup,
    StateFlag,
)
from liftd.ads.device import STATIC_HANDLE_BIT, Session
from liftd.ads.errors import AdsError, FramingError
from liftd.ads.framing import AmsFramer
from liftd.ads.notifications import Outgoing
from liftd.ads.policy import Counters, IpNetwork, RateLimiter, ServerConfig
from liftd.ads.router import PortInUse, PortTable, port_connect_reply, router_frame, wanted_port
from liftd.ads.service import AdsService
from liftd.ads.system import SystemService

SERVED = frozenset(int(c) for c in Command if c not in (Command.INVALID, Command.NOTIFICATION))
_RESPONSE_BIT = int(StateFlag.RESPONSE)  # plain ints on the hot path (IntFlag & costs ~3 µs)
_NOTIFICATION = int(Command.NOTIFICATION)
_ADD_NOTIFICATION = int(Command.ADD_NOTIFICATION)
_AMS_CMD = int(AmsTcpCommand.AMS_CMD)
__all__ = ["AdsConnection", "AdsServer", "Counters", "IpNetwork", "RateLimiter", "ServerConfig"]
# A connection flood queues in the kernel rather than having SYNs dropped: a dropped SYN costs
# the PLC ≥ 1 s (retransmit), a queued one ≈ 0.2 ms per connection ahead of it (capped by
# net.core.somaxconn, 4096 by default)
LISTEN_BACKLOG = socket.SOMAXCONN
IDLE_POLL_S = 0.1  # notification task wake-up when nothing is due (incomplete-frame checks)
LINGER_RESET = struct.pack("ii", 1, 0)  # struct linger {l_onoff 1, l_linger 0}
TURN_S = 0.00025  # a connection's frames handled at once before the others get a turn
BUDGET_STEP = 256 * 1024  # growth of a connection's held bytes that makes the server check its own


class AdsConnection(asyncio.Protocol):
    def __init__(self, server: AdsServer) -> None:
        self.server = server
        self.transport: asyncio.Transport | None = None
        self.peer = "?"
        self.framer = AmsFramer(server.config.max_frame_bytes)
        self.session: Session = server.service.new_session()
        self.queue: deque[bytes] = deque()
        self.queued = 0  # bytes in `queue`
        self.waiting_turn = False  # the frames received are handled on in a later turn
        self.next_check = BUDGET_STEP  # held bytes at which the server's budget is looked at
        self.paused = False
        self.partial_since: float | None = None
        self.closed = False
        self.identified = False  # has sent a valid frame (or registered a port)
        self.opened_at = time.monotonic()
        self.ip = "?"
        # read-only figures for the live view (AdsServer.peers): requests answered,
        # notifications sent, the source NetId of its last request
        self.requests = 0
        self.notifications = 0
        self.source = b""

    # -- asyncio.Protocol -------------------------------------------------------------------------
    def connection_made(self, base: asyncio.BaseTransport) -> None:
        transport: asyncio.Transport = base  # type: ignore[assignment]  # uvloop's: no subclass
        self.transport = transport
        peer = transport.get_extra_info("peername")
        self.peer = f"{peer[0]}:{peer[1]}" if peer else "?"
        self.ip = str(peer[0]) if peer else "?"
        srv = self.server
        refused = srv.admit(self)
        if refused:
            srv.warn("ads.connection_refused", self.peer, reason=refused)
            srv.counters.rejected_connections += 1
            self.closed = True
            transport.abort()
            return
        sock = transport.get_extra_info("socket")
        if sock is not None and sock.family in (socket.AF_INET, socket.AF_INET6):
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        srv.connections.add(self)
        srv.unidentified[self] = None
        srv.per_ip[self.ip] = srv.per_ip.get(self.ip, 0) + 1
        srv.counters.connections += 1
        srv.note("ads.connection_opened", self.peer, connections=len(srv.connections))

    def connection_lost(self, exc: Exception | None) -> None:
        self.closed = True
        srv = self.server
        if self in srv.connections:
            srv.connections.discard(self)
            srv.unidentified.pop(self, None)
            left = srv.per_ip.get(self.ip, 1) - 1
            if left > 0:
                srv.per_ip[self.ip] = left
            else:
                srv.per_ip.pop(self.ip, None)
            srv.ports.drop(self)
            srv.note("ads.connection_closed", self.peer, connections=len(srv.connections))
        self.session.notifications.clear()
        self.session.handles.clear()
        self.queue.clear()
        self.queued = 0
        self.framer.clear()

    def data_received(self, data: bytes) -> None:
        try:
            self._received(data)
        except Exception as exc:  # a bug or MemoryError: this connection only, never a traceback
            self.fail(exc)  # through asyncio's `Fatal error on transport`

    def _received(self, data: bytes) -> None:
        self.framer.add(data)
        self.grew()  # frames not handled yet, a request under way (at most a frame)
        if not self.waiting_turn and not self.closed:
            self._work()

    def _work(self) -> None:
        """Cut and handle the frames received, for TURN_S at most: then the other connections
        get a turn (asyncio's next iteration) while this one reads nothing more; a chunk of
        64 kB of small requests is ~1 500 frames, tens of ms, and one sum command of 1 000
        sub-commands a few ms, which every other client's request waited for. A broken
        stream is closed once the frames before the break are answered."""
        self.waiting_turn = False
        end = time.perf_counter() + TURN_S
        framer = self.framer
        while not self.closed:
            try:
                raw = framer.next()
            except FramingError as exc:
                self.close_for("ads.framing_error", str(exc))
                return
            if raw is None:
                break
            self.handle(raw)
            if framer.pending and time.perf_counter() > end and self._later(self._turn):
                self.waiting_turn = True
                if self.transport is not None:
                    self.transport.pause_reading()
                return
        self.partial_since = time.monotonic() if framer.pending else None
        if not self.paused and self.transport is not None and not self.closed:
            self.transport.resume_reading()

    def _turn(self) -> None:
        try:
            if not self.closed:
                self._work()
        except Exception as exc:  # as in data_received
            self.fail(exc)

    @staticmethod
    def _later(fn: Callable[[], None]) -> bool:
        """Run `fn` in the event loop's next iteration; False without a running loop (tests
        that feed a connection directly: then everything is handled at once)."""
        try:
            asyncio.get_running_loop().call_soon(fn)
        except RuntimeError:
            return False
        return True

    def fail(self, exc: BaseException) -> None:
        """Close this connection for an exception of the protocol layer."""
        srv = self.server
        srv.counters.protocol_errors += 1
        srv.error("ads.protocol_error", self.peer, exc, 0)
        if not self.closed:
            self.close_for("ads.protocol_error", f"{type(exc).__name__}: {exc}")
        self.queue.clear()
        self.queued = 0

    @property
    def held(self) -> int:
        """Bytes held for this connection: unsent output and an incomplete request."""
        buffered = self.transport.get_write_buffer_size() if self.transport is not None else 0
        return self.queued + buffered + self.framer.pending

    def pause_writing(self) -> None:
        self.paused = True
        if self.transport is not None:
            self.transport.pause_reading()  # a peer that does not read gets no more answers

    def resume_writing(self) -> None:
        self.paused = False
        while self.queue and not self.paused and self.transport is not None:
            frame = self.queue.popleft()
            self.queued -= len(frame)
            self.transport.write(frame)
        if (not self.paused and not self.waiting_turn and self.transport is not None
                and not self.closed):  # fmt: skip
            self.transport.resume_reading()

    # -- frames ------------------------------------------------------------------------------------
    def send(self, frame: bytes) -> None:
        if self.closed or self.transport is None:
            return
        if not self.paused:
            self.transport.write(frame)  # may call pause_writing: the peer does not keep up
            if not self.paused:
                return
        else:
            self.queue.append(frame)
            self.queued += len(frame)
        cfg = self.server.config
        if len(self.queue) > cfg.write_queue_frames:
            self.close_for("ads.write_queue_full", f"{len(self.queue)} frames not read")
        else:
            self.grew()

    def grew(self) -> None:
        """Hold this connection to its budget, and the server to its own each time what this
        connection holds grew by BUDGET_STEP (so a flood of small frames costs no scan of
        every connection per frame, and the total exceeds `budget_bytes` by less than a step
        per connection between two scans)."""
        cfg = self.server.config
        held = self.held
        if held > cfg.connection_budget_bytes:
            self.server.counters.over_budget += 1
            self.close_for("ads.over_budget", f"{held} bytes held "
                           f"(connection_budget_bytes {cfg.connection_budget_bytes})")  # fmt: skip
        elif held >= self.next_check:
            self.next_check = held + BUDGET_STEP
            self.server.check_budget()
        elif held + BUDGET_STEP < self.next_check:
            self.next_check = held + BUDGET_STEP

    def close_for(self, event: str, detail: str, error: bool = True) -> None:
        self.server.warn(event, self.peer, detail=detail)
        self.server.counters.closed_for_errors += error
        self.closed = True
        if self.transport is not None:
            # a reset, not a close: the kernel would keep sending what a peer that does not
            # read left in the socket's buffer (up to tcp_wmem's 4 MiB) and that peer would
            # never see the end; with SO_LINGER 0 both go at once
            sock = self.transport.get_extra_info("socket")
            with contextlib.suppress(OSError, AttributeError):
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, LINGER_RESET)
            self.transport.abort()  # drops the transport's buffer at once
        self.queue.clear()  # and what waited behind it
        self.queued = 0

    def identify(self) -> None:
        if not self.identified:
            self.identified = True
            self.server.unidentified.pop(self, None)

    def handle(self, raw: bytes) -> None:
        srv = self.server
        cfg = srv.config
        reserved = wire.TCP_HEADER.unpack_from(raw)[0]
        if reserved != _AMS_CMD:
            self.router_command(reserved, raw[wire.TCP_SIZE :])
            return
        header = wire.AmsHeader._make(wire.AMS_HEADER.unpack_from(raw, wire.TCP_SIZE))
        no_reply = header.flags & _RESPONSE_BIT or header.command == _NOTIFICATION
        if header.length != len(raw) - wire.HEADER_SIZE:
            if not no_reply:
                srv.counters.requests += 1
                self.reply(header, b"", AmsError.INVALID_AMS_LENGTH)
            return
        if cfg.allow_net_ids and header.source_net_id not in cfg.allow_net_ids:
            source = wire.net_id_text(header.source_net_id)
            if cfg.reject == "close":
                self.close_for("ads.source_refused", f"source NetId {source} not allowed")
                return
            srv.warn("ads.source_refused", self.peer, detail=f"source NetId {source}")
            if not no_reply:
                self.reply(header, srv.service.rejected(header.command, AdsErr.ACCESSDENIED))
            return
        if not self.identified:
            self.identify()
        ports = srv.ports
        owner = None
        if ports.owner_of or ports.back:  # anything routed at all (skipped on the hot path)
            owner = ports.route(header.target_net_id, header.target_port)
        if owner is not None:  # a client's registered port, or the answer to a forwarded request
            if not no_reply:
                srv.ports.remember((header.source_net_id, header.source_port), self)
            srv.counters.routed += 1
            owner.send(raw)
            return
        if no_reply:
            return  # a stray response or a notification: nothing to answer
        srv.counters.requests += 1
        self.requests += 1
        self.source = header.source_net_id
        if header.target_net_id not in cfg.net_ids:
            self.reply(header, b"", AmsError.TARGET_MACHINE_NOT_FOUND)
        elif header.target_port == SYSTEM_SERVICE_PORT and cfg.system_service:
            payload = raw[wire.HEADER_SIZE :]
            self.reply(header, srv.system.handle(header.command, payload))
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

    def router_command(self, command: int, payload: bytes) -> None:
        """AMS/TCP commands to the router (router.py); a malformed or unknown one closes."""
        srv = self.server
        try:
            if command == AmsTcpCommand.PORT_CONNECT:
                port = srv.ports.connect(self, wanted_port(payload))
                self.identify()
                self.send(port_connect_reply(srv.ports.net_id, port))
                srv.note("ads.port_connected", self.peer, ams_port=port)
            elif command == AmsTcpCommand.PORT_CLOSE:
                srv.ports.close(self, wanted_port(payload))
                if not srv.ports.ports_of.get(self):  # TwinCAT closes; ads-client waits for it
                    self.closed = True
                    if self.transport is not None:
                        self.transport.close()  # after what is queued
            elif command == AmsTcpCommand.GET_LOCAL_NETID:
                self.send(router_frame(AmsTcpCommand.GET_LOCAL_NETID, srv.ports.net_id))
            else:
                self.close_for("ads.router_command", f"AMS/TCP command 0x{command:X}")
        except (ValueError, PortInUse) as exc:
            self.close_for("ads.router_command", f"AMS/TCP command 0x{command:X}: {exc}")

    def reply(self, request: wire.AmsHeader, payload: bytes, ams_error: int = 0) -> None:
        header = wire.reply_header(request, RESPONSE_FLAGS, ams_error)
        self.send(wire.encode_frame(header, payload))

    def notify(self, out: Outgoing) -> None:
        try:
            self._notify(out)
        except Exception as exc:  # as in data_received: this connection only
            self.fail(exc)

    def _notify(self, out: Outgoing) -> None:
        header = wire.AmsHeader(out.client.net_id, out.client.port, out.server.net_id,
                                out.server.port, Command.NOTIFICATION, StateFlag.ADS_COMMAND,
                                0, 0, 0)  # fmt: skip
        self.send(wire.encode_frame(header, out.payload))
        self.server.counters.notifications_sent += 1
        self.notifications += 1


@dataclass
class AdsServer:
    config: ServerConfig
    service: AdsService
    log: Any  # a structlog logger (bound); the server is the IO shell that logs
    connections: set[AdsConnection] = field(default_factory=set)
    unidentified: dict[AdsConnection, None] = field(default_factory=dict)  # oldest first
    per_ip: dict[str, int] = field(default_factory=dict)
    counters: Counters = field(default_factory=Counters)
    limiter: RateLimiter = field(default_factory=RateLimiter)
    wake: asyncio.Event = field(default_factory=asyncio.Event)
    port: int = 0
    system: SystemService = field(default_factory=SystemService)
    ports: PortTable[AdsConnection] = field(init=False)
    _server: asyncio.Server | None = None
    _task: asyncio.Task[None] | None = None

    def __post_init__(self) -> None:
        cfg = self.config
        net_id = cfg.router_net_id or min(cfg.net_ids)
        reserved = cfg.ams_ports | {SYSTEM_SERVICE_PORT}
        self.ports = PortTable(net_id, cfg.net_ids, frozenset(reserved), 8 * cfg.max_connections)

    def admit(self, conn: AdsConnection) -> str:
        """Make room for `conn` or say why not ("" = admitted). When the table or the peer
        address's share is full, the oldest connection that never sent a valid frame goes."""
        cfg = self.config
        if conn.ip != "?" and not self.ip_allowed(conn.ip):
            return "peer IP not allowed"
        if self.per_ip.get(conn.ip, 0) >= cfg.max_connections_per_ip and not self._evict(conn.ip):
            return "max_connections_per_ip"
        if len(self.connections) >= cfg.max_connections and not self._evict(None):
            return "max_connections"
        return ""

    def _evict(self, ip: str | None) -> bool:
        victim = next((c for c in self.unidentified if ip is None or c.ip == ip), None)
        if victim is None:
            return False
        self.counters.evicted += 1
        victim.close_for("ads.connection_evicted", "room for a new connection", error=False)
        victim.connection_lost(None)  # free its slot now; asyncio's call later finds it gone
        return True

    async def start(self, sock: socket.socket | None = None) -> int:
        """Listen (on `sock` if given, e.g. from systemd); returns the TCP port bound."""
        loop = asyncio.get_running_loop()
        if sock is not None:
            self._server = await loop.create_server(lambda: AdsConnection(self), sock=sock)
        else:
            self._server = await loop.create_server(
                lambda: AdsConnection(self),
                self.config.host,
                self.config.port,
                backlog=LISTEN_BACKLOG,
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

    def check_budget(self) -> None:
        """Close the connection holding most while all of them hold more than `budget_bytes`
        (a connection that keeps up holds at most the transport's high-water mark, 64 KiB)."""
        limit = self.config.budget_bytes
        while True:
            held = {c: c.held for c in self.connections if not c.closed}
            if sum(held.values()) <= limit:
                return
            worst = max(held, key=held.__getitem__)
            self.counters.over_budget += 1
            worst.close_for("ads.over_budget", f"{held[worst]} bytes held of "
                            f"{sum(held.values())} (budget_bytes {limit})")  # fmt: skip

    def peers(self) -> list[tuple[str, str, int, int]]:
        """(peer, source NetId, requests, notifications) of each open connection (read only)."""
        return sorted((c.peer, wire.net_id_text(c.source) if c.source else "", c.requests,
                       c.notifications) for c in self.connections)  # fmt: skip

    def ip_allowed(self, host: str) -> bool:
        if not self.config.allow_ips:
            return True
        try:
            addr = ipaddress.ip_address(host.split("%", 1)[0])
        except ValueError:
            return False
        return any(addr in net for net in self.config.allow_ips)

    def net_id_allowed(self, net_id: bytes) -> bool:
        return not self.config.allow_net_ids or net_id in self.config.allow_net_ids

    def warn(self, event: str, peer: str, **kw: Any) -> None:
        ok, held = self.limiter.allow(f"{event}:{peer.rsplit(':', 1)[0]}")
        if ok:
            self.log.warning(event, peer=peer, suppressed=held, **kw)

    def note(self, event: str, peer: str, **kw: Any) -> None:
        """An info event about a peer's connection, at most one per event, peer address and
        second (a peer opening thousands of connections must not flood the log)."""
        ok, held = self.limiter.allow(f"{event}:{peer.rsplit(':', 1)[0]}")
        if ok:
            self.log.info(event, peer=peer, suppressed=held, **kw)

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
        first_frame_by = time.monotonic() - self.config.first_frame_timeout_s
        for conn in list(self.unidentified):  # oldest first
            if conn.opened_at > first_frame_by:
                break
            conn.close_for("ads.first_frame_timeout", "no valid AMS frame", error=False)
            conn.connection_lost(None)
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

            try:
                outgoing = table.poll(now_ns, unix_ns, read)
            except Exception as exc:  # this connection's, never the notification task's end
                conn.fail(exc)
                continue
            for out in outgoing:
                conn.notify(out)
