"""The TCP server's settings (addresses, limits, access policy), its counters, and the rate
limiter of its log lines. Declarations only; server.py acts on them.
"""

from __future__ import annotations

import ipaddress
import time
from dataclasses import dataclass

IpNetwork = ipaddress.IPv4Network | ipaddress.IPv6Network


@dataclass(frozen=True, slots=True)
class ServerConfig:
    host: str = "127.0.0.1"
    port: int = 48898
    net_ids: frozenset[bytes] = frozenset({bytes([127, 0, 0, 1, 1, 1])})
    ams_ports: frozenset[int] = frozenset({551})
    max_connections: int = 64
    max_frame_bytes: int = 1 << 20
    write_queue_frames: int = 1024
    connection_budget_bytes: int = 4 << 20  # held for one connection (in and out)
    budget_bytes: int = 48 << 20  # held for all connections
    incomplete_frame_timeout_s: float = 10.0
    first_frame_timeout_s: float = 10.0  # no valid frame yet after this: closed
    max_connections_per_ip: int = 32
    system_service: bool = True  # answer AMS port 10000 (ReadState, device info)
    router_net_id: bytes | None = None  # NetId handed out on port connect; None: the smallest
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
            self.suppressed.clear()
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
    evicted: int = 0
    routed: int = 0
    over_budget: int = 0  # connections closed for holding more than their budget
    protocol_errors: int = 0  # connections closed for an exception in the protocol layer
