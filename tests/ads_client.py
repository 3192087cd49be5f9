"""A minimal raw AMS client for tests that need to send what real clients never would."""

from __future__ import annotations

import socket
import struct

from liftd.ads import wire
from liftd.ads.framing import AmsFramer

SOURCE = bytes([10, 1, 2, 3, 1, 1])


class RawClient:
    def __init__(self, port: int, target: bytes, source: bytes = SOURCE, rcvbuf: int = 0) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        if rcvbuf:
            self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, rcvbuf)
        self.sock.settimeout(3.0)
        self.sock.connect(("127.0.0.1", port))
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.target = target
        self.source = source
        self.framer = AmsFramer(1 << 24)
        self.pending: list[bytes] = []
        self.invoke = 0

    def frame(self, command: int, payload: bytes, port: int = 551, target: bytes | None = None,
              flags: int = 4) -> bytes:  # fmt: skip
        self.invoke += 1
        header = wire.AmsHeader(target or self.target, port, self.source, 30000, command, flags,
                                0, 0, self.invoke)  # fmt: skip
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

    def request(self, command: int, payload: bytes, **kw: object) -> wire.Frame:
        self.send(self.frame(command, payload, **kw))  # type: ignore[arg-type]
        return self.recv_frame()

    def read(self, ig: int, io: int, n: int) -> tuple[int, bytes]:
        reply = self.request(2, struct.pack("<III", ig, io, n))
        return wire.decode_read_response(reply.payload)

    def closed_by_server(self, timeout: float = 3.0) -> bool:
        self.sock.settimeout(timeout)
        try:
            while True:
                data = self.sock.recv(65536)
                if not data:
                    return True
        except (ConnectionResetError, BrokenPipeError):
            return True
        except TimeoutError:
            return False

    def close(self) -> None:
        self.sock.close()
