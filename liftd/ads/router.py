"""What liftd does as an AMS router toward its TCP clients. Pure: a port table keyed by any
hashable owner (the server passes its connections) and the AMS/TCP router frames.

A client that talks to a router (Node ads-client by default, jisotalo/ads-server, TwinCAT's own
tools) first sends AMS/TCP command 0x1000 "port connect" with a u16 wanted port (0 = any) and
gets back the NetId and port it shall use as its AMS source (6 + 2 bytes). Like a TwinCAT
router for its local clients, liftd hands out its own NetId and a free port from 32768 up;
frames for that NetId:port are then routed to the connection that holds it. 0x0001 "port
close" gives the port back (TwinCAT then drops the TCP connection, and ads-client waits for
that), 0x1002 answers the router's NetId. Sources: ads-client 2.1.0 `src/ads-client.ts`
registerAdsPort / unregisterAdsPort / onAmsTcpPacketReceived, `src/ads-commons.ts`
AMS_HEADER_FLAG; docs/reference/ads.md §1.2.
"""

from __future__ import annotations

import struct
from collections import OrderedDict
from collections.abc import Hashable
from typing import Generic, TypeVar

from liftd.ads import wire
from liftd.ads.constants import AmsTcpCommand

FIRST_DYNAMIC_PORT = 32768
LAST_DYNAMIC_PORT = 65535
PORT = struct.Struct("<H")
MAX_PORTS_PER_OWNER = 8
MAX_ROUTES_BACK = 4096

Owner = TypeVar("Owner", bound=Hashable)


class PortInUse(Exception):
    """The wanted port is taken, hosted by liftd itself, or the table is full."""


class PortTable(Generic[Owner]):
    def __init__(
        self, net_id: bytes, own: frozenset[bytes], reserved: frozenset[int], max_ports: int
    ) -> None:
        self.net_id = net_id  # the NetId handed out with every port
        self.own = own | {net_id}  # liftd's NetIds: never learned as a route back
        self.reserved = reserved  # liftd's own AMS ports (551, 10000, …)
        self.max_ports = max_ports
        self.owner_of: dict[int, Owner] = {}
        self.ports_of: dict[Owner, set[int]] = {}
        self._next = FIRST_DYNAMIC_PORT
        # where to send a response: the connection a forwarded request came from, by its
        # (NetId, port) source, for clients that did not register a port (bounded, oldest out)
        self.back: OrderedDict[tuple[bytes, int], Owner] = OrderedDict()

    def connect(self, owner: Owner, wanted: int) -> int:
        """Register a port for `owner`; returns it. Raises PortInUse."""
        owned = self.ports_of.get(owner, set())
        if len(self.owner_of) >= self.max_ports or len(owned) >= MAX_PORTS_PER_OWNER:
            raise PortInUse("no more ports")
        if wanted:
            if wanted in self.owner_of or wanted in self.reserved:
                raise PortInUse(f"port {wanted} in use")
            port = wanted
        else:
            port = self._free()
        self.owner_of[port] = owner
        self.ports_of.setdefault(owner, set()).add(port)
        return port

    def _free(self) -> int:
        span = LAST_DYNAMIC_PORT - FIRST_DYNAMIC_PORT + 1
        for _ in range(span):
            port, self._next = (
                self._next,
                FIRST_DYNAMIC_PORT + (self._next - FIRST_DYNAMIC_PORT + 1) % span,
            )
            if port not in self.owner_of and port not in self.reserved:
                return port
        raise PortInUse("no free port")

    def close(self, owner: Owner, port: int) -> bool:
        """Give `port` back; False if `owner` did not hold it."""
        if self.owner_of.get(port) != owner:
            return False
        del self.owner_of[port]
        self.ports_of[owner].discard(port)
        return True

    def drop(self, owner: Owner) -> None:
        """Everything `owner` held (its connection closed)."""
        for port in self.ports_of.pop(owner, set()):
            self.owner_of.pop(port, None)
        for key in [k for k, v in self.back.items() if v == owner]:
            del self.back[key]

    def remember(self, source: tuple[bytes, int], owner: Owner) -> None:
        if source[0] in self.own:
            return  # liftd's own addresses route only to registered ports
        self.back[source] = owner
        self.back.move_to_end(source)
        while len(self.back) > MAX_ROUTES_BACK:
            self.back.popitem(last=False)

    def route(self, net_id: bytes, port: int) -> Owner | None:
        """The connection a frame for `net_id`:`port` goes to: a registered port, or the
        source of a request forwarded earlier; None: not routed (liftd answers it itself)."""
        if net_id in self.own:
            return self.owner_of.get(port) if net_id == self.net_id else None
        return self.back.get((net_id, port))


def router_frame(command: AmsTcpCommand, payload: bytes) -> bytes:
    """An AMS/TCP frame without an AMS header (router commands and their answers)."""
    return wire.TCP_HEADER.pack(int(command), len(payload)) + payload


def port_connect_reply(net_id: bytes, port: int) -> bytes:
    return router_frame(AmsTcpCommand.PORT_CONNECT, net_id + PORT.pack(port))


def wanted_port(payload: bytes) -> int:
    """The port a 0x1000/0x0001 frame names (u16); ValueError for a malformed one."""
    if len(payload) != PORT.size:
        raise ValueError(f"router command payload of {len(payload)} bytes, expected 2")
    return int(PORT.unpack(payload)[0])
