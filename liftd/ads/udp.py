"""UDP discovery and add-route server (discovery.py has the codec): the second IO module of
liftd.ads beside server.py. Off unless `[ads] udp_discovery` is set.

Every datagram gets at most one small reply, to its sender, and only when the sender's address
is allowed (`allow_ips`); an add-route is acknowledged (status 0) only when also the NetId it
adds is allowed (`allow_net_ids`, if set), else refused with 0x704. liftd needs no route to
answer (it replies on the connection a request came on), so an acknowledged route changes
nothing: it tells the tool (TwinCAT's "Add Route" dialog, `pyads.add_route_to_plc`) that it may
connect. Credentials are not checked: the address rules are the policy. Garbage is counted and
logged rate-limited; nothing a datagram holds can raise out of here.
"""

from __future__ import annotations

import asyncio
import socket
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from liftd.ads import discovery
from liftd.ads.constants import SYSTEM_SERVICE_PORT, AdsErr
from liftd.ads.discovery import Service, Tag

Allowed = Callable[[str], bool]  # peer IP → allowed


@dataclass
class UdpCounters:
    datagrams: int = 0
    answered: int = 0
    ignored: int = 0  # peer not allowed
    malformed: int = 0
    routes_added: int = 0
    routes_refused: int = 0


@dataclass
class UdpDiscovery(asyncio.DatagramProtocol):
    net_id: bytes
    ip_allowed: Allowed
    net_id_allowed: Callable[[bytes], bool]
    warn: Callable[..., None]  # (event, peer, **fields): the TCP server's rate-limited warning
    note: Callable[..., None]  # the same at info level
    host_name: str = field(default_factory=socket.gethostname)
    counters: UdpCounters = field(default_factory=UdpCounters)
    transport: asyncio.DatagramTransport | None = None
    port: int = 0

    async def start(self, host: str, port: int) -> int:
        loop = asyncio.get_running_loop()
        transport, _ = await loop.create_datagram_endpoint(lambda: self, local_addr=(host, port))
        self.transport = transport
        self.port = transport.get_extra_info("sockname")[1]
        return self.port

    def close(self) -> None:
        if self.transport is not None:
            self.transport.close()

    def datagram_received(self, data: bytes, addr: Any) -> None:
        self.counters.datagrams += 1
        peer = f"{addr[0]}:{addr[1]}"
        try:
            reply = self.answer(data, str(addr[0]), peer)
        except ValueError as exc:
            self.counters.malformed += 1
            self.warn("ads.udp_malformed", peer, detail=str(exc)[:200])
            return
        except Exception as exc:  # a bug must not stop the endpoint
            self.counters.malformed += 1
            self.warn("ads.udp_failed", peer, detail=repr(exc)[:200])
            return
        if reply and self.transport is not None:
            self.counters.answered += 1
            self.transport.sendto(reply, addr)

    def answer(self, data: bytes, ip: str, peer: str) -> bytes:
        req = discovery.decode(data)
        if not self.ip_allowed(ip):
            self.counters.ignored += 1
            self.warn("ads.udp_refused", peer, service=req.service)
            return b""
        if req.service == Service.DISCOVER:
            return discovery.discovery_reply(req, self.net_id, SYSTEM_SERVICE_PORT, self.host_name)
        added = req.tags.get(Tag.NET_ID, b"")
        if len(added) != 6:
            raise ValueError(f"add route: NetId tag of {len(added)} bytes")
        name = req.text(Tag.ROUTE_NAME)
        net = ".".join(str(b) for b in added)
        if self.net_id_allowed(added):
            self.counters.routes_added += 1
            self.note("ads.route_added", peer, net_id=net, route=name)
            status = 0
        else:
            self.counters.routes_refused += 1
            self.warn("ads.route_refused", peer, net_id=net, route=name)
            status = AdsErr.INVALIDACCESS
        return discovery.add_route_reply(req, self.net_id, SYSTEM_SERVICE_PORT, status)

    def error_received(self, exc: Exception) -> None:  # ICMP errors of earlier replies
        pass
