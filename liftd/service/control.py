"""The reload control socket, so that `systemctl reload liftd` reports what happened.

A SIGHUP cannot answer, so systemd's `ExecReload=liftd reload` connects to this Unix socket in
the unit's runtime directory (`RuntimeDirectory=liftd`, `$RUNTIME_DIRECTORY`), asks for a
reload and waits for the verdict on the same connection: exit 0 only when the configuration was
applied, non-zero when it was rejected (the running one is kept). SIGHUP still reloads, without
an answer. Protocol: the request line `reload`, the answer one JSON line
`{"applied": true|false, "detail": "…"}`; one request per connection.
"""

from __future__ import annotations

import asyncio
import contextlib
import errno
import json
import os
import socket
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import NamedTuple

SOCKET_NAME = "control.sock"
DEFAULT_RUNTIME_DIRECTORY = "/run/liftd"  # systemd's RuntimeDirectory=liftd
REQUEST_TIMEOUT_S = 5.0


class Verdict(NamedTuple):
    applied: bool
    detail: str


def socket_path(env: dict[str, str] | None = None, explicit: str | None = None) -> Path | None:
    """Where the socket is: the explicit path, else in $RUNTIME_DIRECTORY (systemd sets it
    for the daemon and for ExecReload); None when neither is given (the daemon then opens no
    socket)."""
    if explicit:
        return Path(explicit)
    runtime = (env if env is not None else os.environ).get("RUNTIME_DIRECTORY", "")
    return Path(runtime.split(":")[0]) / SOCKET_NAME if runtime else None


async def serve(path: Path, reload: Callable[[], Awaitable[Verdict]]) -> asyncio.Server:
    """Answer reload requests on `path` (owner and group only)."""

    async def handle(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        try:
            request = await asyncio.wait_for(reader.readline(), REQUEST_TIMEOUT_S)
            if request.strip() == b"reload":
                verdict = await reload()
            else:
                verdict = Verdict(False, f"unknown request {request.strip()[:40]!r}")
            writer.write(json.dumps(verdict._asdict()).encode() + b"\n")
            await writer.drain()
        except (TimeoutError, ConnectionError):
            pass
        finally:
            writer.close()

    if _answers(path):  # another daemon's (the same RUNTIME_DIRECTORY): never take it over
        raise OSError(errno.EADDRINUSE, "another liftd serves it (RUNTIME_DIRECTORY shared)")
    with contextlib.suppress(FileNotFoundError):
        path.unlink()  # left by a killed predecessor
    old = os.umask(0o117)
    try:
        return await asyncio.start_unix_server(handle, str(path))
    finally:
        os.umask(old)


def _answers(path: Path) -> bool:
    """Something listens on the socket at `path` (a stale file refuses the connection)."""
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM | socket.SOCK_CLOEXEC) as sock:
        sock.settimeout(1.0)
        try:
            sock.connect(str(path))
        except OSError:
            return False
        return True


def owns(path: Path, inode: int) -> bool:
    """The socket file at `path` is still the one this daemon bound (inode), so that a
    daemon stopping removes its own socket only."""
    try:
        return path.stat().st_ino == inode
    except OSError:
        return False


def request_reload(path: Path, timeout_s: float) -> Verdict:
    """The client side (`liftd reload`). Raises OSError when no daemon answers."""
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM | socket.SOCK_CLOEXEC) as sock:
        sock.settimeout(timeout_s)
        sock.connect(str(path))
        sock.sendall(b"reload\n")
        answer = b""
        while not answer.endswith(b"\n"):
            chunk = sock.recv(4096)
            if not chunk:
                break
            answer += chunk
    try:
        data = json.loads(answer)
        return Verdict(bool(data["applied"]), str(data["detail"]))
    except (ValueError, KeyError, TypeError):
        raise OSError(f"no verdict from the daemon (got {answer[:80]!r})") from None
