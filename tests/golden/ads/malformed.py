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


def rw(ig: int, io: int, rlen: int, data: bytes, port: int = 551) -> bytes:
    return frame(9, struct.pack("<IIII", ig, io, rlen, len(data)) + data, port=port)


def router(command: int, payload: bytes) -> bytes:
    return struct.pack("<HI", command, len(payload)) + payload


def notif(ig: int, io: int, n: int, mode: int) -> bytes:
    return frame(6, struct.pack("<IIIIII16s", ig, io, n, mode, 0, 10_000, bytes(16)))


CASES = [
    ("close", "AMS/TCP length above the 4096-byte cap", struct.pack("<HI", 0, 5000)),
    ("close", "AMS/TCP length too short for an AMS header", struct.pack("<HI", 0, 10) + bytes(10)),
    ("close", "router port connect asking for 551, a port liftd hosts", router(0x1000, struct.pack("<H", 551))),
    ("close", "router port connect with a 3-byte payload", router(0x1000, b"\0\0\0")),
    ("close", "router port close of a port the connection does not hold", router(0x0001, struct.pack("<H", 40000))),
    ("close", "unknown router command 0x1234", router(0x1234, b"")),
    ("close", "router note (0x1001) sent by a client", router(0x1001, bytes(4))),
    ("router 0x1000", "router port connect, any port", router(0x1000, struct.pack("<H", 0))),
    ("router 0x1002", "router: get the NetId", router(0x1002, b"")),
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
    ("ok", "system service: ReadState on port 10000", frame(4, b"", port=10000)),
    ("ADS 0x701", "system service: write", frame(3, LIFT + b"\x01", port=10000)),
    ("ADS 0x701", "system service: read of an index group it does not have", frame(2, struct.pack("<III", 0x999, 0, 4), port=10000)),
    ("ADS 0x705", "system service: extended state into 8 bytes", frame(2, struct.pack("<III", 0xF0, 0, 8), port=10000)),
    ("ADS 0x705", "system service: read request of 4 bytes", frame(2, bytes(4), port=10000)),
    ("ADS 0x710", "data type by name: unknown type", rw(0xF011, 0, 0xFFFFFFFF, b"ST_Nope\0")),
    ("ADS 0x705", "data type by name: read length below the entry", rw(0xF011, 0, 10, b"BOOL\0")),
    ("ADS 0x705", "data-type upload into 10 bytes", frame(2, struct.pack("<III", 0xF00E, 0, 10))),
    ("ADS 0x710", "symbol location (0xF007): unknown name", rw(0xF007, 0, 12, b"GEO.nope")),
    ("ADS 0x705", "symbol location (0xF007) into 4 bytes", rw(0xF007, 0, 4, b"GEO.cycle")),
    ("ADS 0x710", "extended handle of an unknown name", rw(0xF003, 0, 0xFFFFFFFF, b"GEO.nope\0")),
    ("ADS 0x705", "sum read-ex announcing 4 294 967 295 sub-commands", rw(0xF083, 0xFFFFFFFF, 100, LIFT)),
    ("ADS 0x705", "sum read-ex with a read length below results + data", rw(0xF083, 1, 8, LIFT)),
    ("ADS 0x705", "sum read-ex2 carrying 13 bytes per sub-command", rw(0xF084, 1, 100, LIFT + b"\0")),
    ("ADS 0x705", "sum add notification: 30-byte entries", rw(0xF085, 1, 8, bytes(30))),
    ("ADS 0x705", "sum add notification announcing 600 entries, over the cap of 500", rw(0xF085, 600, 4800, bytes(24))),
    ("ADS 0x705", "sum delete notification announcing 2 handles, carrying 1", rw(0xF086, 2, 8, bytes(4))),
    ("ADS 0x703", "device data (0xF100) at offset 5", frame(2, struct.pack("<III", 0xF100, 5, 4))),
    ("pending", "half a frame (20 bytes): held for the idle timeout", frame(2, LIFT)[:20]),
    # issue 41: replies sized before they are built (the frame cap here is 4 096 bytes)
    ("ADS 0x70A", "sum read of one sub-command asking 2 GiB, read length 0xFFFFFFFF", rw(0xF080, 1, 0xFFFFFFFF, struct.pack("<III", 0x121301, 0x30095, 2 << 30))),
    ("ADS 0x70A", "sum read-ex of one sub-command asking 4 GiB", rw(0xF083, 1, 0xFFFFFFFF, struct.pack("<III", 0x121301, 0x30095, 0xFFFFFFF0))),
    ("ADS 0x70A", "sum read of two 2 kB sub-commands: a reply above the frame cap", rw(0xF080, 2, 0xFFFFFFFF, struct.pack("<III", 0x121301, 0x30095, 2048) * 2)),
    ("ADS 0x70A", "sum read-ex2 of 300 symbol uploads: a compact reply above the frame cap", rw(0xF084, 300, 0xFFFFFFFF, struct.pack("<III", 0xF00B, 0, 1 << 20) * 300)),
    ("ADS 0x70A", "read of the symbol upload (5 kB) with length 0xFFFFFFFF", frame(2, struct.pack("<III", 0xF00B, 0, 0xFFFFFFFF))),
    ("ok", "read of lift_active with length 0xFFFFFFFF: the object's byte", frame(2, struct.pack("<III", 0x121301, 0x30095, 0xFFFFFFFF))),
    ("ADS 0x717", "notification on the symbol upload, whose sample cannot fit a frame", notif(0xF00B, 0, 0xFFFFFFFF, 3)),
]  # fmt: skip


def main() -> None:
    out = ["# malformed frames: <expected outcome> | <what> | <hex>; written by malformed.py"]
    for expected, what, raw in CASES:
        out.append(f"{expected} | {what} | {raw.hex()}")
    Path(__file__).with_name("malformed.hex").write_text("\n".join(out) + "\n")


if __name__ == "__main__":
    main()
