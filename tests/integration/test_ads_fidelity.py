"""Where liftd follows what TwinCAT 3 (and the ISG CNC behind it) does in corners clients reach,
over the real server on a free loopback port. Each test names the source of the behaviour it
holds liftd to."""

from __future__ import annotations

import contextlib
import struct
from collections.abc import Iterator

import pytest

from liftd.ads import wire
from liftd.ads.client import RawClient
from liftd.ads.wire import net_id_bytes
from tests.support.ads_harness import Harness
from tests.support.channel import make_channel, make_second_channel

pytestmark = pytest.mark.integration


@pytest.fixture
def h2() -> Iterator[Harness]:
    """The two-head machine: channel 1 X Y Z (logical 1 2 3), channel 2 U V W (4 5 6)."""
    with Harness([make_channel(), make_second_channel()]) as harness:  # type: ignore[arg-type]
        yield harness


def client(h: Harness) -> RawClient:
    return RawClient(h.port, net_id_bytes(h.net_id))


def address_of(c: RawClient, ig: int, io: int, channel: int, axis: int) -> tuple[int, bytes]:
    """ReadWrite on the object-address attribute: in (channel, axis), out (IG, IO)."""
    payload = struct.pack("<IIIIII", ig, io, 8, 8, channel, axis)
    return wire.decode_read_response(c.request(9, payload).payload)


def test_object_address_answers_in_the_addressing_it_was_asked_in(h2: Harness) -> None:
    """TF5200 "Administration, IndexGroup/Offset address" (infosys 1031/hmiviaads/15685565323,
    1033/tf5200_ads_access_to_cnc/312768779): ReadWrite on the index-based HLD group 0x23900
    with (channel 1, axis 0) returns 0x23301, on the logical 0x123900 it returns 0x123301.
    Read and ReadWrite of +0x600 on one group name the same addressing."""
    c = client(h2)
    w_flag = struct.pack("<II", 0x121302, 0x00060095)  # W: logical axis 6, 3rd of channel 2
    assert address_of(c, 0x121901, 0x00030095, 2, 6) == (0, w_flag)
    indexed = struct.pack("<II", 0x021302, 0x00030095)  # the same flag, index based
    assert c.read(0x021902, 0x00030095, 8) == (0, indexed)
    assert address_of(c, 0x021901, 0x00030095, 2, 3) == (0, indexed)  # axis: 3rd in channel
    assert address_of(c, 0x021901, 0x00000015, 2, 0) == (0, struct.pack("<II", 0x021302, 0x15))
    c.close()


def test_object_address_of_an_instance_the_machine_lacks_is_zero_zero(h2: Harness) -> None:
    """TF5200 "Administration, IndexGroup/Offset address" (infosys 1033/
    tf5200_ads_access_to_cnc/312768779): "No instance of the class exists if (0, 0) is returned
    as the address" -- a client probes channels and axes this way and stops at (0, 0)."""
    c = client(h2)
    none = (0, struct.pack("<II", 0, 0))
    assert address_of(c, 0x121901, 0x00030095, 3, 1) == none  # no channel 3
    assert address_of(c, 0x121901, 0x00030095, 2, 3) == none  # logical axis 3 is channel 1's
    assert address_of(c, 0x021901, 0x00030095, 1, 4) == none  # channel 1 has 3 axes
    assert address_of(c, 0x121901, 0x00030095, 1, 0) == none  # axis 0: no axis
    c.close()


def subscribe(c: RawClient, ig: int, io: int, length: int, mode: int = 4) -> tuple[int, int]:
    """AddDeviceNotification, 1 ms cycle, no max delay: (result, notification handle)."""
    spec = struct.pack("<IIIIII16s", ig, io, length, mode, 0, 10_000, bytes(16))
    return wire.decode_add_notification_response(c.request(6, spec).payload)


def first_samples(c: RawClient, want: set[int]) -> dict[int, bytes]:
    """The first sample of each notification handle in `want`, as the server sends them."""
    got: dict[int, bytes] = {}
    while not want <= got.keys():
        frame = c.recv_frame()
        assert frame.header.command == 8
        for stamp in wire.decode_notification(frame.payload):
            for sample in stamp.samples:
                got.setdefault(sample.handle, sample.data)
    return got


def test_a_notification_longer_than_its_object_carries_the_objects_bytes() -> None:
    """The length of AddDeviceNotification is a maximum, as it is for a Read: Beckhoff's
    TwinCAT.Ads documents it as the "Maximum amount of data in bytes to receive with this ADS
    Notification" (infosys 1033/tc3_ads.net/21041338891); TwinCAT's own logger sends samples
    shorter than the length subscribed (Beckhoff/ADS#235: 101 of 1024; #277); ads-client 2.x
    subscribes to a raw address of unknown size with length 0xFFFFFFFF (src/ads-client.ts
    addSubscription), as it reads by name with 0xFFFFFFFF ("Seems to work OK (we don't know
    the size)", readRawByPath). liftd padded such samples with zeros to the length asked."""
    with Harness(make_channel()) as h, contextlib.closing(client(h)) as c:
        h.set(lift_active=True)
        assert c.read(0x121301, 0x30095, 4) == (0, b"\x01")  # a Read: the BOOL's one byte
        result, by_address = subscribe(c, 0x121301, 0x30095, 4)
        assert result == 0
        name = b"GEO.ch1.Z.lift_active\0"
        reply = c.request(9, struct.pack("<IIII", 0xF003, 0, 4, len(name)) + name)
        code, raw = wire.decode_read_response(reply.payload)
        assert code == 0
        result, by_handle = subscribe(c, 0xF005, int.from_bytes(raw, "little"), 4)
        assert result == 0
        result, unknown_size = subscribe(c, 0x121301, 0x30095, 0xFFFFFFFF)
        assert result == 0
        samples = first_samples(c, {by_address, by_handle, unknown_size})
        assert samples == {by_address: b"\x01", by_handle: b"\x01", unknown_size: b"\x01"}
