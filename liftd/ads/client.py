"""A minimal blocking AMS/TCP client built on the codec: `liftd healthcheck` uses it (no AdsLib,
no route needed), and tests use it to send what real clients never would."""

from __future__ import annotations

import socket
import struct
import time
from typing import Any

from liftd.ads import wire
from liftd.ads.constants import Command
from liftd.ads.framing import AmsFramer

SOURCE = bytes([10, 1, 2, 3, 1, 1])


class RawClient:
    def __init__(
        self,
        port: int,
        target: bytes,
        source: bytes = SOURCE,
        rcvbuf: int = 0,
        host: str = "127.0.0.1",
        timeout_s: float = 3.0,
    ) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        if rcvbuf:
            self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, rcvbuf)
        self.sock.settimeout(timeout_s)
        try:
            self.sock.connect((host, port))
        except OSError:
            self.sock.close()
            raise
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.target = target
        self.source = source
        self.framer = AmsFramer(1 << 24)
        self.pending: list[bytes] = []
        self.invoke = 0
        self.notifications = 0  # device notifications skipped while waiting for a response

    def frame(
        self,
        command: int,
        payload: bytes,
        port: int = 551,
        target: bytes | None = None,
        flags: int = 4,
    ) -> bytes:
        self.invoke += 1
        header = wire.AmsHeader(
            target or self.target, port, self.source, 30000, command, flags, 0, 0, self.invoke
        )
        return wire.encode_frame(header, payload)

    def send(self, data: bytes) -> None:
        self.sock.sendall(data)

    def recv_frame(self) -> wire.Frame:
        while not self.pending:
            data = self.sock.recv(65536)
            if not data:
                raise ConnectionError("closed by the server")
            self.pending += self.framer.feed(data)
        return wire.decode_frame(self.pending.pop(0))

    def request(self, command: int, payload: bytes, **kw: Any) -> wire.Frame:
        """Send one request and return the next frame that is not a device notification (the
        server sends those whenever they are due, also between a request and its response;
        they are kept in `notifications`)."""
        self.send(self.frame(command, payload, **kw))
        while True:
            frame = self.recv_frame()
            if frame.header.command != Command.NOTIFICATION or command == Command.NOTIFICATION:
                return frame
            self.notifications += 1

    def read_state(self) -> tuple[int, int, int]:
        """(result, ADS state, device state)"""
        return wire.decode_state_response(self.request(4, b"").payload)

    def read_by_name(self, name: str, n: int) -> tuple[int, bytes]:
        """ReadWrite SYM_VALBYNAME: one round trip, no handle left behind."""
        raw = name.encode("ascii") + b"\0"
        reply = self.request(9, struct.pack("<IIII", 0xF004, 0, n, len(raw)) + raw)
        return wire.decode_read_response(reply.payload)

    def read(self, ig: int, io: int, n: int) -> tuple[int, bytes]:
        reply = self.request(2, struct.pack("<III", ig, io, n))
        return wire.decode_read_response(reply.payload)

    def closed_by_server(self, timeout: float = 3.0) -> bool:
        """Whether the server closes the connection within `timeout` s in all (what it sends
        meanwhile is read and dropped: a server that keeps sending is not "closed")."""
        end = time.monotonic() + timeout
        try:
            while (left := end - time.monotonic()) > 0:
                self.sock.settimeout(left)
                if not self.sock.recv(65536):
                    return True
        except (ConnectionResetError, BrokenPipeError):
            return True
        except TimeoutError:
            return False
        return False

    def close(self) -> None:
        self.sock.close()
