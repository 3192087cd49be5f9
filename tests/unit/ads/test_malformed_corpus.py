"""The malformed-frame corpus (tests/golden/ads/malformed.hex, written by malformed.py) through
one real AdsConnection, whole and byte by byte: each frame gets exactly its expected outcome —
a reply with the AMS or ADS error, no reply, a close, or held as an incomplete frame."""

from __future__ import annotations

import struct

import pytest

from liftd.ads import wire
from liftd.ads.framing import AmsFramer
from liftd.ads.server import AdsConnection
from tests.support.ads_fake import FakeTransport, make_server
from tests.support.paths import GOLDEN

CORPUS = [
    [part.strip() for part in line.split("|")]
    for line in (GOLDEN / "ads" / "malformed.hex").read_text().splitlines()
    if line and not line.startswith("#")
]


def outcome(raw: bytes, chunk: int) -> str:
    server = make_server()
    transport = FakeTransport()
    conn = AdsConnection(server)
    conn.connection_made(transport)  # type: ignore[arg-type]
    for i in range(0, len(raw), chunk):
        if not conn.closed:
            conn.data_received(raw[i : i + chunk])
    assert server.counters.internal_errors == 0
    raw_replies = AmsFramer(1 << 20).feed(bytes(transport.out))
    if conn.closed or transport.aborted:
        assert not raw_replies
        return "close"
    if not raw_replies:
        return "pending" if conn.framer.pending else "none"
    (raw,) = raw_replies
    if raw[:2] != b"\0\0":  # a router answer: AMS/TCP command, no AMS header
        return f"router 0x{struct.unpack_from('<H', raw)[0]:X}"
    reply = wire.decode_frame(raw)
    assert reply.header.invoke_id == 7 and reply.header.flags & 1
    if reply.header.error:
        return f"AMS 0x{reply.header.error:X}"
    code = struct.unpack_from("<I", reply.payload)[0]
    return f"ADS 0x{code:X}" if code else "ok"


@pytest.mark.parametrize(("expected", "what", "hexa"), CORPUS, ids=[c[1] for c in CORPUS])
@pytest.mark.parametrize("chunk", [1 << 16, 1], ids=["whole", "byte-by-byte"])
def test_malformed_frame(expected: str, what: str, hexa: str, chunk: int) -> None:
    assert outcome(bytes.fromhex(hexa), chunk) == expected, what
