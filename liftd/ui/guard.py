"""What the page's server checks before it serves: the Host header (no DNS rebinding), the
WebSocket's Origin (no other site's page), and aiohttp's own log of requests it cannot parse,
as liftd's rate-limited log lines."""

from __future__ import annotations

import ipaddress
import logging
import time
from collections.abc import Callable
from typing import Any
from urllib.parse import urlsplit


def host_allowed(host_header: str, names: tuple[str, ...]) -> bool:
    """An IP literal, localhost or a configured name, with or without a port."""
    host = host_header.strip().lower()
    if host.startswith("["):
        host = host[1 : host.find("]")] if "]" in host else ""
    elif host.count(":") == 1:
        host = host.split(":", 1)[0]
    if host in ("localhost", *(n.lower() for n in names)):
        return True
    try:
        ipaddress.ip_address(host)
    except ValueError:
        return False
    return True


def origin_allowed(origin: str | None, host_header: str) -> bool:
    if origin is None:
        return True  # not a browser: no other site's page behind it
    parts = urlsplit(origin)
    return parts.scheme == "http" and parts.netloc.lower() == host_header.strip().lower()


class HttpLog(logging.Handler):
    """aiohttp's server log as liftd's: a request it cannot parse (a header line over 8 KiB,
    a broken request line …) is answered 400 and logged by aiohttp at ERROR with a traceback;
    here it is one `ui.bad_request` event per peer address and second, with the error on one
    line and how many were held back (a peer sends what it likes, the log must not grow with it,
    as the ADS server's `warn`)."""

    def __init__(self, log: Any, clock: Callable[[], float] = time.monotonic) -> None:
        super().__init__(logging.INFO)  # aiohttp's DEBUG (a non-HTTP first line) is dropped
        self.log = log
        self.clock = clock
        self.last: dict[str, float] = {}
        self.held: dict[str, int] = {}

    def emit(self, record: logging.LogRecord) -> None:
        args = record.args if isinstance(record.args, tuple) else ()
        peer = str(args[0]) if args else "?"
        exc = record.exc_info[1] if record.exc_info else None
        now = self.clock()
        if now - self.last.get(peer, -2.0) < 1.0:
            self.held[peer] = self.held.get(peer, 0) + 1
            return
        if len(self.last) > 1024:  # peers seen: bounded
            self.last.clear()
            self.held.clear()
        self.last[peer] = now
        error = (
            f"{type(exc).__name__}: {' '.join(str(exc).split())}" if exc else record.getMessage()
        )
        self.log.warning("ui.bad_request", peer=peer, error=error[:200],
                         suppressed=self.held.pop(peer, 0))  # fmt: skip


def http_logger(log: Any) -> logging.Logger:
    """A logger of its own for one server's aiohttp (not propagated to the root's stderr)."""
    logger = logging.getLogger(f"liftd.ui.http.{id(log):x}")
    logger.propagate = False
    logger.setLevel(logging.INFO)
    logger.handlers[:] = [HttpLog(log)]
    return logger
