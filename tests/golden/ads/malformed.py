"""Writes malformed.hex: frames no well-behaved client sends, each with the outcome liftd must
produce (reviewed against reference/ads.md; tests/unit/ads/test_malformed_corpus.py checks
them whole and byte by byte). Run from the repo root: python tests/golden/ads/malformed.py"""

from __future__ import annotations

import struct
from pathlib import Path

from liftd.ads import wire
from liftd.ads.wire import net_id_bytes

NET = net_id_bytes("127.0.0.1.1.1")
SRC = net_id_bytes("10.0.0.9.1.1")
LIFT = struct.pack("<III", 0x121301, 0x30095, 1)


def frame(cmd: int, payload: bytes, target: bytes = NET, port: int = 551, flags: int = 4) -> bytes:
    return wire.encode_frame(wire.AmsHeader(target, port, SRC, 30000, cmd, flags, 0, 0, 7), payload)


def lie(raw: bytes, length: int) -> bytes:
    b = bytearray(raw)
    b[26:30] = length.to_bytes(4, "little")
    return bytes(b)


def sum_read(n: int, subs: int) -> bytes:
    body = LIFT * subs
    return frame(9, struct.pack("<IIII", 0xF080, n, 5 * n, len(body)) + body)


def notif(ig: int, io: int, n: int, mode: int) -> bytes:
    return frame(6, struct.pack("<IIIIII16s", ig, io, n, mode, 0, 10_000, bytes(16)))


CASES = [
    ("close", "AMS/TCP length above the 4096-byte cap", struct.pack("<HI", 0, 5000)),
    ("close", "AMS/TCP length too short for an AMS header", struct.pack("<HI", 0, 10) + bytes(10)),
    ("close", "AMS router command (port connect): liftd is a target", struct.pack("<HIH", 0x1000, 2, 551)),
    ("AMS 0xE", "AMS data length 13 in a frame carrying 12", lie(frame(2, LIFT), 13)),
    ("AMS 0x8", "unknown command 17", frame(17, b"")),
    ("AMS 0x8", "command 0", frame(0, b"")),
    ("AMS 0x7", "foreign target NetId", frame(2, LIFT, target=net_id_bytes("1.2.3.4.5.6"))),
    ("AMS 0x6", "AMS port not hosted (852)", frame(2, LIFT, port=852)),
    ("none", "a stray response (flag 0x0005)", frame(2, LIFT, flags=5)),
    ("none", "a device notification sent to the server", frame(8, bytes(8))),
    ("ADS 0x705", "read request of 8 bytes instead of 12", frame(2, LIFT[:8])),
    ("ADS 0x702", "read of an unknown index group", frame(2, struct.pack("<III", 0x999, 0, 4))),
    ("ADS 0x703", "read of an unknown index offset", frame(2, struct.pack("<III", 0x121301, 0x77, 1))),
    ("ADS 0x705", "read of lift_active with length 0", frame(2, struct.pack("<III", 0x121301, 0x30095, 0))),
    ("ADS 0x704", "write to read-only lift_active", frame(3, struct.pack("<III", 0x121301, 0x30095, 1) + b"\x01")),
    ("ADS 0x705", "write whose length field says 4, carrying 1", frame(3, struct.pack("<III", 0x121301, 0x30095, 4) + b"\x01")),
    ("ADS 0x705", "sum read announcing 600 sub-commands, over the cap of 500", sum_read(600, 2)),
    ("ADS 0x705", "sum read announcing 3 sub-commands, carrying 2", sum_read(3, 2)),
    ("ADS 0x705", "sum read of 0 sub-commands", sum_read(0, 0)),
    ("ADS 0x710", "read by an invalid symbol handle", frame(2, struct.pack("<III", 0xF005, 4242, 1))),
    ("ADS 0x710", "handle by name of an unknown symbol", frame(9, struct.pack("<IIII", 0xF003, 0, 4, 5) + b"nope\0")),
    ("ADS 0x714", "delete of an invalid notification handle", frame(7, struct.pack("<I", 4242))),
    ("ADS 0x701", "notification on a sum command", notif(0xF080, 1, 4, 4)),
    ("ADS 0x713", "notification transmission mode 99", notif(0x121301, 0x30095, 1, 99)),
    ("ADS 0x705", "add notification payload of 20 bytes", frame(6, bytes(20))),
    ("pending", "half a frame (20 bytes): held for the idle timeout", frame(2, LIFT)[:20]),
]  # fmt: skip


def main() -> None:
    out = ["# malformed frames: <expected outcome> | <what> | <hex>; written by malformed.py"]
    for expected, what, raw in CASES:
        out.append(f"{expected} | {what} | {raw.hex()}")
    Path(__file__).with_name("malformed.hex").write_text("\n".join(out) + "\n")


if __name__ == "__main__":
    main()
