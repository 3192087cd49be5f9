"""sd_notify(3) in a few lines: READY, RELOADING, STATUS, WATCHDOG, STOPPING to $NOTIFY_SOCKET
(a leading "@" is an abstract socket), and the keep-alive task behind WATCHDOG=1 and the
container heartbeat file. Outside systemd every notification is a no-op (docs/reference/rt-python.md
§6)."""

from __future__ import annotations

import asyncio
import contextlib
import os
import socket
import time
from collections.abc import Callable
from pathlib import Path

HEARTBEAT_ENV = "LIFTD_HEARTBEAT"  # a file whose mtime the daemon renews while the loop cycles
HEARTBEAT_PERIOD_S = 1.0


def notify(message: str, env: dict[str, str] | None = None) -> bool:
    """Send one datagram ("READY=1", "WATCHDOG=1", …); False when there is no socket."""
    path = (env if env is not None else os.environ).get("NOTIFY_SOCKET", "")
    if not path:
        return False
    address = "\0" + path[1:] if path.startswith("@") else path
    try:
        with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM | socket.SOCK_CLOEXEC) as sock:
            sock.connect(address)
            sock.sendall(message.encode())
    except OSError:
        return False
    return True


def reloading_message() -> str:
    """RELOADING=1 with the CLOCK_MONOTONIC time in µs, which Type=notify-reload needs to
    tie the message to its SIGHUP (sd_notify(3), MONOTONIC_USEC=)."""
    return f"RELOADING=1\nMONOTONIC_USEC={time.clock_gettime_ns(time.CLOCK_MONOTONIC) // 1000}"


def watchdog_interval_s(env: dict[str, str] | None = None) -> float | None:
    """Half of WATCHDOG_USEC (sd_watchdog_enabled(3)), if the watchdog is for this process."""
    env = env if env is not None else dict(os.environ)
    usec = env.get("WATCHDOG_USEC", "")
    pid = env.get("WATCHDOG_PID", "")
    if not usec.isdigit() or int(usec) == 0 or (pid and pid != str(os.getpid())):
        return None
    return int(usec) / 2e6


async def keep_alive(advancing: Callable[[], bool], env: dict[str, str] | None = None) -> None:
    """While `advancing()` (the GEO loop cycles): WATCHDOG=1 every half WATCHDOG_USEC, and the
    heartbeat file's mtime renewed (Docker's HEALTHCHECK reads it instead of starting a
    process that asks over ADS). Returns at once when neither is configured."""
    env = env if env is not None else dict(os.environ)
    interval = watchdog_interval_s(env)
    heartbeat = Path(env[HEARTBEAT_ENV]) if env.get(HEARTBEAT_ENV) else None
    if interval is None and heartbeat is None:
        return
    period = min(interval or HEARTBEAT_PERIOD_S, HEARTBEAT_PERIOD_S)
    while True:
        if advancing():
            if interval is not None:
                notify("WATCHDOG=1", env)
            if heartbeat is not None:
                with contextlib.suppress(OSError):  # unwritable: shows as unhealthy, rightly
                    heartbeat.touch()
        await asyncio.sleep(period)
