"""What real clients never send, over a real socket: broken frames, foreign addresses, peers
outside the access policy, clients that stall or never read. Every request is answered with the
right code or the connection is closed, and the server keeps serving the others."""

from __future__ import annotations

import struct
import time
from collections.abc import Iterator
from typing import Any

import pytest

from liftd.ads import wire
from liftd.ads.client import RawClient
from liftd.ads.wire import net_id_bytes
from tests.support.ads_harness import Harness
from tests.support.channel import make_channel

pytestmark = pytest.mark.integration
LIFT = struct.pack("<III", 0x121301, 0x30095, 1)


@pytest.fixture
def h() -> Iterator[Harness]:
    with Harness(make_channel(), incomplete_frame_timeout_s=0.3, write_queue_frames=16,
                 max_frame_bytes=4096) as harness:  # fmt: skip
        yield harness


def client(h: Harness, **kw: object) -> RawClient:
    return RawClient(h.port, net_id_bytes(h.net_id), **kw)  # type: ignore[arg-type]


def still_served(h: Harness) -> None:
    c = client(h)
    assert c.read(0x121301, 0x30095, 1) == (0, b"\x00")
    c.close()


def test_split_and_coalesced_requests_are_answered_in_order(h: Harness) -> None:
    c = client(h)
    frames = b"".join(c.frame(2, LIFT) for _ in range(5))
    for i in range(0, len(frames), 7):  # 7-byte pieces, several frames per piece
        c.send(frames[i : i + 7])
        time.sleep(0.001)
    replies = [c.recv_frame() for _ in range(5)]
    assert [r.header.invoke_id for r in replies] == [1, 2, 3, 4, 5]
    assert all(wire.decode_read_response(r.payload) == (0, b"\x00") for r in replies)
    assert all(r.header.flags == 0x0005 for r in replies)


def test_ams_level_errors(h: Harness) -> None:
    c = client(h)
    assert c.request(2, LIFT, port=552).header.error == 0x6  # port not hosted
    assert c.request(2, LIFT, target=bytes([1, 2, 3, 4, 5, 6])).header.error == 0x7
    assert c.request(17, b"").header.error == 0x8  # unknown command
    assert c.request(0, b"").header.error == 0x8
    lie = bytearray(c.frame(2, LIFT))
    lie[26:30] = (13).to_bytes(4, "little")  # AMS data length ≠ AMS/TCP length
    c.send(bytes(lie))
    assert c.recv_frame().header.error == 0xE
    c.send(c.frame(2, LIFT, flags=5))  # a stray response: ignored, not answered
    c.send(c.frame(8, b""))  # a notification from the client: ignored
    assert c.read(0x121301, 0x30095, 1) == (0, b"\x00")  # the next request is the next reply
    assert wire.decode_read_response(c.request(2, LIFT[:8]).payload) == (0x705, b"")


@pytest.mark.parametrize(
    "attack",
    [
        struct.pack("<HI", 0, 5000),  # over the 4096-byte cap
        struct.pack("<HI", 0, 10) + bytes(10),  # too short for an AMS header
        struct.pack("<HIH", 0x1000, 2, 551),  # AMS router "port connect": liftd is a target
    ],
)
def test_broken_streams_are_closed_and_others_served(h: Harness, attack: bytes) -> None:
    bad = client(h)
    bad.send(attack)
    assert bad.closed_by_server()
    still_served(h)


def test_half_a_frame_then_silence_is_closed_after_the_timeout(h: Harness) -> None:
    stall = client(h)
    stall.send(stall.frame(2, LIFT)[:20])
    still_served(h)  # meanwhile
    assert stall.closed_by_server(timeout=2.0)  # incomplete_frame_timeout_s = 0.3


def test_a_client_that_never_reads_is_closed(h: Harness) -> None:
    lazy = client(h, rcvbuf=4096)
    _, info = lazy.read(0xF00C, 0, 8)  # symbol upload size: a few kB per notification
    size = struct.unpack("<II", info)[1]
    upload = struct.pack("<IIIIII16s", 0xF00B, 0, size, 3, 0, 10_000, bytes(16))  # 1 ms cyclic
    for _ in range(40):
        assert wire.decode_add_notification_response(lazy.request(6, upload).payload)[0] == 0
    assert h.server is not None
    end = time.monotonic() + 10
    while h.server.counters.closed_for_errors == 0 and time.monotonic() < end:
        time.sleep(0.05)  # the client reads nothing meanwhile
    assert h.server.counters.closed_for_errors == 1  # write queue of 16 frames overflowed
    still_served(h)
    assert lazy.closed_by_server()


def test_access_policy() -> None:
    other_ips = Harness(
        make_channel(), allow_ips=(__import__("ipaddress").ip_network("10.0.0.0/8"),)
    )
    with other_ips as h:
        assert client(h).closed_by_server()
    allowed = net_id_bytes("10.1.2.3.1.1")
    with Harness(make_channel(), allow_net_ids=frozenset({allowed}), reject="error",
                 write_net_ids=frozenset({allowed})) as h:  # fmt: skip
        ok = client(h)
        assert ok.read(0x121301, 0x30095, 1) == (0, b"\x00")
        stranger = client(h, source=bytes([10, 9, 9, 9, 1, 1]))
        assert wire.decode_read_response(stranger.request(2, LIFT).payload) == (0x723, b"")
    reader = net_id_bytes("10.5.5.5.1.1")
    with Harness(make_channel(), allow_net_ids=frozenset({allowed, reader}),
                 write_net_ids=frozenset({allowed})) as h:  # fmt: skip
        sym = h.provider.find_symbol("PLC.ch1.override")
        write = struct.pack("<III", sym.index_group, sym.index_offset, 2) + struct.pack("<H", 500)
        ro = client(h, source=reader)
        assert wire.decode_result(ro.request(3, write).payload) == 0x704
        assert ro.read(0x121301, 0x30095, 1) == (0, b"\x00")  # reading is fine
        rw = client(h)
        assert wire.decode_result(rw.request(3, write).payload) == 0
        stranger = client(h, source=bytes([10, 9, 9, 9, 1, 1]))
        stranger.send(stranger.frame(2, LIFT))
        assert stranger.closed_by_server()  # reject = "close" (the default)


def test_max_connections() -> None:
    with Harness(make_channel(), max_connections=2) as h:
        a, b = client(h), client(h)
        assert a.read(0x121301, 0x30095, 1)[0] == 0 and b.read(0x121301, 0x30095, 1)[0] == 0
        assert client(h).closed_by_server()
        a.close()
        time.sleep(0.1)
        still_served(h)


def test_a_client_pipelining_thousands_of_requests_does_not_make_others_wait_for_them() -> None:
    """Issue 41: a connection's received frames are handled for a turn of 0.25 ms at most, then
    the others get theirs. A client sends 20 000 reads in one go (880 kB), another a single
    read just after: in the order the server handles them, the single read comes before the
    flood's 2 000th (asyncio reads 64–256 kB a time, 1 500–6 000 of these frames, which were
    all handled before anyone else's)."""
    with Harness(make_channel()) as h:
        assert h.server is not None
        order: list[int] = []  # the session of each request, in the order handled
        handle = h.server.service.handle

        def recording(session: Any, *args: Any) -> Any:
            order.append(id(session))
            return handle(session, *args)

        h.server.service.handle = recording  # type: ignore[method-assign]
        flood, probe = client(h), client(h)
        assert probe.read(0x121301, 0x30095, 1)[0] == 0
        first = order[-1]  # the probe's session
        n = 20_000
        flood.send(b"".join(flood.frame(2, LIFT) for _ in range(n)))
        end = time.monotonic() + 10
        while len(order) < 100 and time.monotonic() < end:
            time.sleep(0.001)  # the flood is being handled
        assert probe.read(0x121301, 0x30095, 1)[0] == 0
        before = order[1:].index(first)  # flood requests handled before the probe's
        assert before < 2_000, before
        flood.close()
        probe.close()
