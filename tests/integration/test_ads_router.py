"""liftd as an AMS router toward its clients (port connect/close, get NetId, frames routed
between registered ports, the system service on port 10000) and as a server nobody can crowd
out (first-frame timeout, eviction of unidentified connections, per-address caps), over real
loopback sockets."""

from __future__ import annotations

import socket
import struct
import time

import pyads
import pytest

from liftd.ads import wire
from liftd.ads.client import RawClient
from liftd.ads.wire import net_id_bytes
from tests.support.ads_harness import Harness
from tests.support.channel import make_channel

# wall-clock latencies asserted: run alone, after the parallel part of `make test`
pytestmark = [pytest.mark.integration, pytest.mark.timing]
LIFT = struct.pack("<III", 0x121301, 0x30095, 1)


def client(h: Harness, **kw: object) -> RawClient:
    return RawClient(h.port, net_id_bytes(h.net_id), **kw)  # type: ignore[arg-type]


def router(c: RawClient, command: int, payload: bytes) -> tuple[int, bytes]:
    """Send an AMS/TCP router command; (command, payload) of the answer."""
    c.send(struct.pack("<HI", command, len(payload)) + payload)
    while True:
        data = c.sock.recv(65536)
        assert data, "closed by the server"
        c.framer._buf += data  # router answers carry no AMS header: split them by hand
        if len(c.framer._buf) >= 6:
            cmd, n = struct.unpack_from("<HI", c.framer._buf)
            if len(c.framer._buf) >= 6 + n:
                body = bytes(c.framer._buf[6 : 6 + n])
                del c.framer._buf[: 6 + n]
                return cmd, body


def idle_socket(h: Harness, source_ip: str = "127.0.0.1") -> socket.socket:
    s = socket.socket()
    s.bind((source_ip, 0))
    s.settimeout(5)
    s.connect(("127.0.0.1", h.port))
    return s


def closed(s: socket.socket, timeout: float = 3.0) -> bool:
    s.settimeout(timeout)
    try:
        return s.recv(1) == b""
    except (ConnectionResetError, BrokenPipeError):
        return True
    except TimeoutError:
        return False


def test_port_connect_routes_frames_between_clients_and_port_close_closes() -> None:
    with Harness(make_channel()) as h:
        net = net_id_bytes(h.net_id)
        a, b = client(h), client(h)
        cmd, body = router(a, 0x1000, struct.pack("<H", 0))  # ads-client registerAdsPort
        assert cmd == 0x1000 and body[:6] == net
        port_a = struct.unpack_from("<H", body, 6)[0]
        assert port_a >= 32768
        assert router(b, 0x1000, struct.pack("<H", 0))[1][:6] == net
        assert router(a, 0x1002, b"") == (0x1002, net)  # get the router's NetId
        # A's own requests, sent from the NetId and port it was given
        a.source = net
        assert a.read(0x121301, 0x30095, 1) == (0, b"\x00")
        # B sends a request to A's port: routed to A, and A's answer routed back to B
        b.source = bytes([10, 7, 7, 7, 1, 1])
        b.send(b.frame(2, LIFT, port=port_a))
        asked = a.recv_frame()
        assert (asked.header.target_port, asked.header.command) == (port_a, 2)
        answer = wire.reply_header(asked.header, 5)
        a.send(wire.encode_frame(answer, wire.read_response(0, b"\x2a")))
        got = b.recv_frame()
        assert got.header.invoke_id == asked.header.invoke_id and got.payload[-1] == 0x2A
        # a wanted port already in use, or one liftd hosts, closes the asking connection
        c = client(h)
        c.send(struct.pack("<HIH", 0x1000, 2, port_a))
        assert c.closed_by_server()
        # port close: the port is free again and the connection closes (as TwinCAT does)
        a.send(struct.pack("<HIH", 0x0001, 2, port_a))
        assert a.closed_by_server()
        d = client(h)
        assert router(d, 0x1000, struct.pack("<H", port_a))[1][6:] == struct.pack("<H", port_a)


def test_system_service_port_10000() -> None:
    with Harness(make_channel()) as h:
        c = client(h)
        assert wire.decode_state_response(c.request(4, b"", port=10000).payload) == (0, 5, 0)
        info = wire.decode_device_info_response(c.request(1, b"", port=10000).payload)
        assert info[:4] == (0, 3, 1, 4024)
        code, state = wire.decode_read_response(
            c.request(2, struct.pack("<III", 0xF0, 0, 16), port=10000).payload
        )  # ads-client readTcSystemExtendedState
        assert code == 0 and struct.unpack_from("<HHHBBH", state) == (5, 0, 0, 3, 1, 4024)
        assert wire.decode_result(c.request(3, LIFT + b"\x01", port=10000).payload) == 0x701


def test_idle_connections_are_evicted_for_a_real_client_and_time_out() -> None:
    with Harness(
        make_channel(), max_connections=6, max_connections_per_ip=6, first_frame_timeout_s=1.0
    ) as h:
        idle = [idle_socket(h) for _ in range(6)]
        t0 = time.monotonic()
        c = client(h)
        assert c.read(0x121301, 0x30095, 1) == (0, b"\x00")
        assert time.monotonic() - t0 < 1.0
        assert closed(idle[0], 2.0)  # the oldest idle one made room
        assert closed(idle[-1], 5.0)  # no valid frame within 1 s: closed
        served = [client(h) for _ in range(5)]
        assert all(s.read(0x121301, 0x30095, 1)[0] == 0 for s in served)  # 6 identified now
        assert client(h).closed_by_server()  # full of identified ones: refused
        for s in idle:
            s.close()


def test_per_address_cap_evicts_only_that_address() -> None:
    with Harness(make_channel(), max_connections=10, max_connections_per_ip=2) as h:
        here = [client(h) for _ in range(2)]
        assert all(c.read(0x121301, 0x30095, 1)[0] == 0 for c in here)
        assert client(h).closed_by_server()  # 127.0.0.1 has its two
        other = idle_socket(h, "127.0.0.2")
        assert not closed(other, 0.3)  # another address still gets in
        other.close()


def test_pyads_reads_within_1s_while_max_connections_idle_sockets_are_held() -> None:
    with Harness(make_channel(), max_connections=64, max_connections_per_ip=64) as h:
        idle = [idle_socket(h) for _ in range(64)]
        t0 = time.monotonic()
        plc = pyads.Connection(h.net_id, 551, h.address)
        plc.open()
        try:
            assert plc.read(0x121301, 0x30095, pyads.PLCTYPE_BOOL) is False
            assert time.monotonic() - t0 < 1.0  # the bound (typically a few ms)
        finally:
            plc.close()
            for s in idle:
                s.close()
