"""UDP discovery / add-route: the codec against the layouts pyads and ads-rs send, the access
policy, and datagrams of every size and garbage (none raises, each gets at most one reply)."""

from __future__ import annotations

import random
import struct
from typing import Any

import pytest

from liftd.ads import discovery
from liftd.ads.udp import UdpDiscovery

NET = bytes([127, 0, 0, 1, 1, 1])
ALLOWED = bytes([127, 0, 0, 5, 1, 1])


class FakeTransport:
    def __init__(self) -> None:
        self.sent: list[tuple[bytes, Any]] = []

    def sendto(self, data: bytes, addr: Any) -> None:
        self.sent.append((data, addr))


def endpoint() -> tuple[UdpDiscovery, FakeTransport, list[str]]:
    events: list[str] = []
    udp = UdpDiscovery(
        NET,
        lambda ip: ip.startswith("127."),
        lambda n: n == ALLOWED,
        lambda e, p, **k: events.append(e),
        lambda e, p, **k: events.append(e),
        host_name="cnc-box",
    )
    transport = FakeTransport()
    udp.transport = transport  # type: ignore[assignment]
    return udp, transport, events


def pyads_discover() -> bytes:  # pyads_ex.adsGetNetIdForPLC
    return (
        b"\x03\x66\x14\x71\x00\x00\x00\x00\x01\x00\x00\x00"
        + bytes([1] * 6)
        + b"\x10\x27"
        + bytes(4)
    )


def pyads_add_route(net: bytes) -> bytes:  # pyads_ex.adsAddRouteToPLC, tag by tag
    def tag(t: int, data: bytes) -> bytes:
        return struct.pack("<HH", t, len(data)) + data

    head = b"\x03\x66\x14\x71\x00\x00\x00\x00\x06\x00\x00\x00" + bytes([127, 0, 0, 9, 1, 1])
    head += struct.pack("<HI", 10000, 5)
    return (
        head
        + tag(12, b"route\0")
        + tag(7, net)
        + tag(13, b"user\0")
        + tag(2, b"pw\0")
        + tag(5, b"host\0")
    )


def test_discovery_reply_as_pyads_and_ads_rs_read_it() -> None:
    udp, t, _ = endpoint()
    udp.datagram_received(pyads_discover(), ("127.0.0.1", 5000))
    ((reply, addr),) = t.sent
    assert addr == ("127.0.0.1", 5000) and reply[11] == 0x80 and reply[12:18] == NET
    req = discovery.decode(reply[:8] + b"\x01\x00\x00\x00" + reply[12:])  # parse as a request
    assert req.text(discovery.Tag.HOST_NAME) == "cnc-box"
    assert struct.unpack("<BBH", req.tags[discovery.Tag.TC_VERSION]) == (3, 1, 4024)


def test_add_route_acknowledged_for_an_allowed_net_id_refused_otherwise() -> None:
    udp, t, events = endpoint()
    udp.datagram_received(pyads_add_route(ALLOWED), ("127.0.0.1", 5000))
    udp.datagram_received(pyads_add_route(bytes([10, 1, 1, 1, 1, 1])), ("127.0.0.1", 5000))
    ok, refused = (data for data, _ in t.sent)
    assert len(ok) == 32 and ok[26:29] == b"\x04\x00\x00"  # what pyads reads as success
    assert struct.unpack_from("<I", refused, 28)[0] == 0x704
    assert events == ["ads.route_added", "ads.route_refused"]
    udp.datagram_received(pyads_discover(), ("10.0.0.1", 5000))  # peer not allowed: silence
    assert len(t.sent) == 2 and udp.counters.ignored == 1


def test_datagrams_of_every_size_and_garbage() -> None:
    udp, t, _ = endpoint()
    rng = random.Random(16)
    valid = [pyads_discover(), pyads_add_route(ALLOWED)]
    sizes = [*range(0, 600), 1400, 8192, 65507]
    for n in sizes:
        udp.datagram_received(rng.randbytes(n), ("127.0.0.1", 1))
        base = valid[n % 2]
        udp.datagram_received(base[: n % (len(base) + 1)], ("127.0.0.1", 1))  # cut anywhere
        mangled = bytearray(base)
        mangled[rng.randrange(len(base))] ^= 1 << rng.randrange(8)
        udp.datagram_received(bytes(mangled), ("127.0.0.1", 1))
    huge = discovery.HEADER.pack(discovery.COOKIE, 0, 6, NET, 10000, 0xFFFFFFFF)
    udp.datagram_received(huge, ("127.0.0.1", 1))  # a tag count of 4 billion
    c = udp.counters
    assert c.datagrams == 3 * len(sizes) + 1
    assert c.answered + c.malformed + c.ignored == c.datagrams and len(t.sent) == c.answered
    assert all(len(data) <= 512 for data, _ in t.sent)


def test_decode_rejects_what_is_not_a_request() -> None:
    for bad in (b"", bytes(24), pyads_discover()[:23]):
        with pytest.raises(ValueError):
            discovery.decode(bad)
    reply = bytearray(pyads_discover())
    reply[11] = 0x80  # a reply (or a broadcast echo of our own) is not answered
    with pytest.raises(ValueError):
        discovery.decode(bytes(reply))
