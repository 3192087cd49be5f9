"""The UDP 48899 protocol of TwinCAT routers (broadcast search and "add route"), as a pure
codec: datagram in, typed request out, and the replies.

Layout (little-endian; docs/reference/ads.md §4.4): u32 cookie 0x71146603, u32 invoke id, u32
service (1 = discovery, 6 = add route; a reply has 0x80000000 set), AmsAddr (NetId 6 + port u16),
u32 tag count, then tags {u16 id, u16 length, data}; strings NUL-terminated, the length counting the
NUL. Sources: birkenfeld/ads-rs `src/udp.rs` (Message, Tag, add_route, get_info), pyads 3.6
`pyads_ex.py` adsAddRouteToPLC / adsGetNetIdForPLC (it reads the reply's NetId at bytes 12..18
after checking that byte 11 is 0x80, and an add-route reply of 32 bytes), AdsLib `AdsLib.cpp`.
"""

from __future__ import annotations

import enum
import struct
from typing import NamedTuple

COOKIE = 0x71146603
HEADER = struct.Struct("<III6sHI")  # 24 bytes
TAG = struct.Struct("<HH")
REPLY_BIT = 0x8000_0000
MAX_TAGS = 64
TC_VERSION = (3, 1, 4024)


class Service(enum.IntEnum):
    DISCOVER = 1
    ADD_ROUTE = 6


class Tag(enum.IntEnum):
    """ads-rs `udp.rs` Tag"""

    STATUS = 1
    PASSWORD = 2
    TC_VERSION = 3
    OS_VERSION = 4
    HOST_NAME = 5
    NET_ID = 7
    OPTIONS = 9
    ROUTE_NAME = 12
    USER_NAME = 13
    FINGERPRINT = 18


class Request(NamedTuple):
    invoke_id: int
    service: int
    net_id: bytes  # the sender's AmsAddr
    port: int
    tags: dict[int, bytes]

    def text(self, tag: Tag) -> str:
        return self.tags.get(tag, b"").split(b"\0", 1)[0].decode("utf-8", "replace")


def decode(datagram: bytes) -> Request:
    """Raises ValueError for anything that is not a well-formed request of a known service."""
    if len(datagram) < HEADER.size:
        raise ValueError(f"{len(datagram)} bytes, shorter than the {HEADER.size}-byte header")
    cookie, invoke_id, service, net_id, port, count = HEADER.unpack_from(datagram)
    if cookie != COOKIE:
        raise ValueError(f"cookie 0x{cookie:08X}")
    if service not in (Service.DISCOVER, Service.ADD_ROUTE):
        raise ValueError(f"service 0x{service:X}")
    if count > MAX_TAGS:
        raise ValueError(f"{count} tags")
    tags: dict[int, bytes] = {}
    pos = HEADER.size
    for _ in range(count):
        if pos + TAG.size > len(datagram):
            raise ValueError("tag header truncated")
        tag, length = TAG.unpack_from(datagram, pos)
        pos += TAG.size
        if pos + length > len(datagram):
            raise ValueError(f"tag {tag} of {length} bytes truncated")
        tags[tag] = datagram[pos : pos + length]
        pos += length
    return Request(invoke_id, service, net_id, port, tags)


def _reply(req: Request, net_id: bytes, port: int, tags: list[tuple[int, bytes]]) -> bytes:
    head = HEADER.pack(COOKIE, req.invoke_id, req.service | REPLY_BIT, net_id, port, len(tags))
    return head + b"".join(TAG.pack(tag, len(data)) + data for tag, data in tags)


def discovery_reply(req: Request, net_id: bytes, port: int, host_name: str) -> bytes:
    """NetId (pyads reads only that), host name and TwinCAT version (ads-rs get_info)."""
    major, minor, build = TC_VERSION
    return _reply(
        req,
        net_id,
        port,
        [
            (Tag.HOST_NAME, host_name.encode("utf-8", "replace")[:255] + b"\0"),
            (Tag.TC_VERSION, struct.pack("<BBH", major, minor, build)),
        ],
    )


def add_route_reply(req: Request, net_id: bytes, port: int, status: int) -> bytes:
    """32 bytes: header + one status tag (0 ok, 0x704 refused; ads-rs add_route)."""
    return _reply(req, net_id, port, [(Tag.STATUS, struct.pack("<I", status))])
