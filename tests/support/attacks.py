"""The raw-socket attack cases against a running `liftd run` (issue 8), as data: each case does
its thing to the daemon and returns the observed outcome, which the test compares with the
expected one and bench/attack_table.py prints for docs/figures.md.

Daemon settings the cases assume: ATTACK_ADS below.
"""

from __future__ import annotations

import socket
import struct
import time
from collections.abc import Callable
from dataclasses import dataclass

from liftd.ads import wire
from liftd.ads.client import RawClient
from liftd.ads.wire import net_id_bytes
from tests.support.daemon import Daemon

ATTACK_ADS: dict[str, float] = {
    "max_connections": 64,
    "max_connections_per_ip": 64,
    "max_frame_bytes": 65536,
    "incomplete_frame_timeout_s": 0.5,
    "write_queue_frames": 64,
    "max_notifications_per_connection": 16,
    "max_handles_per_connection": 32,
    "max_sum_subcommands": 1000,
}
LIFT = struct.pack("<III", 0x121301, 0x30095, 1)


def client(d: Daemon, **kw: object) -> RawClient:
    return RawClient(d.port, net_id_bytes(d.net_id), **kw)  # type: ignore[arg-type]


def closed(c: RawClient, timeout: float = 3.0) -> str:
    outcome = "closed" if c.closed_by_server(timeout) else "open"
    c.close()
    return outcome


def error_of(frame: wire.Frame) -> str:
    if frame.header.error:
        return f"AMS 0x{frame.header.error:X}"
    code = struct.unpack_from("<I", frame.payload)[0]
    return f"ADS 0x{code:X}" if code else "ok"


def truncated_then_close(d: Daemon) -> str:
    c = client(d)
    c.send(c.frame(2, LIFT)[:17])
    c.close()  # the server drops the partial frame with the connection
    return "dropped"


def oversized(d: Daemon) -> str:
    c = client(d)
    c.send(struct.pack("<HI", 0, 70000) + bytes(100))
    return closed(c)


def length_lie(d: Daemon) -> str:
    c = client(d)
    lie = bytearray(c.frame(2, LIFT))
    lie[26:30] = (13).to_bytes(4, "little")  # AMS data length ≠ AMS/TCP length
    c.send(bytes(lie))
    outcome = error_of(c.recv_frame())
    c.close()
    return outcome


def garbage_after_valid(d: Daemon) -> str:
    c = client(d)
    c.send(c.frame(2, LIFT) + b"\xff" * 64)
    first = error_of(c.recv_frame())
    return f"{first}, then {closed(c)}"


def thousand_connections(d: Daemon) -> str:
    socks, refused = [], 0
    for _ in range(1000):
        s = socket.socket()
        s.settimeout(5)
        try:
            s.connect(("127.0.0.1", d.port))
        except OSError:
            refused += 1
            s.close()
            continue
        socks.append(s)
    end = time.monotonic() + 10  # until the daemon has worked through the queued connections
    while True:
        time.sleep(0.25)
        alive = 0
        for s in socks:
            s.setblocking(False)
            try:
                alive += s.recv(1, socket.MSG_PEEK) != b""  # b"": closed by the server
            except BlockingIOError:
                alive += 1  # still open
            except OSError:
                pass
        if alive <= ATTACK_ADS["max_connections"] or time.monotonic() > end:
            break
    for s in socks:
        s.close()
    return f"{alive} kept (max_connections {ATTACK_ADS['max_connections']}), rest closed"


def half_frame_stall(d: Daemon) -> str:
    c = client(d)
    c.send(c.frame(2, LIFT)[:20])
    t0 = time.monotonic()
    outcome = closed(c, 5.0)
    waited = time.monotonic() - t0
    return f"{outcome} after the timeout" if 0.45 <= waited <= 2.0 else f"{outcome}, {waited:.2f} s"


def never_reads(d: Daemon) -> str:
    closes = ("ads.over_budget", "ads.write_queue_full")
    before = sum(d.count(e) for e in closes)
    c = client(d, rcvbuf=4096)
    _, info = c.read(0xF00C, 0, 8)  # symbol upload size: a few kB per notification
    size = struct.unpack("<II", info)[1]
    upload = struct.pack("<IIIIII16s", 0xF00B, 0, size, 3, 0, 10_000, bytes(16))  # 1 ms cyclic
    for _ in range(16):
        c.send(c.frame(6, upload))
    end = time.monotonic() + 10.0  # reads nothing until the server says it closed it
    while sum(d.count(e) for e in closes) == before and time.monotonic() < end:
        time.sleep(0.05)
    return closed(c, 5.0)


def notifications_beyond_cap(d: Daemon) -> str:
    c = client(d)
    spec = struct.pack("<IIIIII16s", 0x121301, 0x30095, 1, 4, 0, 100_000, bytes(16))
    codes = [
        wire.decode_add_notification_response(c.request(6, spec).payload)[0]
        for _ in range(int(ATTACK_ADS["max_notifications_per_connection"]) + 1)
    ]
    c.close()
    return f"{codes.count(0)} ok, then ADS 0x{codes[-1]:X}"


def sum_beyond_cap(d: Daemon) -> str:
    c = client(d)
    n = int(ATTACK_ADS["max_sum_subcommands"]) + 1
    body = LIFT * n
    req = struct.pack("<IIII", 0xF080, n, 5 * n, len(body)) + body
    outcome = error_of(c.request(9, req))
    c.close()
    return outcome


def invalid_handles(d: Daemon) -> str:
    c = client(d)
    by_handle = error_of(c.request(2, struct.pack("<III", 0xF005, 12345, 1)))
    release = error_of(c.request(3, struct.pack("<III", 0xF006, 0, 4) + struct.pack("<I", 999)))
    notif = error_of(c.request(7, struct.pack("<I", 4242)))
    c.close()
    return f"read {by_handle}, release {release}, delete notification {notif}"


def foreign_addresses(d: Daemon) -> str:
    c = client(d)
    net = error_of(c.request(2, LIFT, target=bytes([1, 2, 3, 4, 5, 6])))
    port = error_of(c.request(2, LIFT, port=851))
    cmd = error_of(c.request(17, b""))
    c.close()
    return f"NetId {net}, port {port}, command {cmd}"


def sum_read_gigabytes(ig: int, length: int) -> Callable[[Daemon], str]:
    """Issue 41's 66-byte frame: one sub-command {lift_active, length L}, read length
    0xFFFFFFFF; its reply used to be padded to L (a 4 GiB peak for L = 2 GiB)."""

    def run(d: Daemon) -> str:
        c = client(d)
        body = struct.pack("<III", 0x121301, 0x30095, length)
        outcome = error_of(c.request(9, struct.pack("<IIII", ig, 1, 0xFFFFFFFF, 12) + body))
        c.close()
        return outcome

    return run


def upload_notifications_unread(d: Daemon) -> str:
    """A notification sum on the symbol upload (all the connection may have, at 1 ms), then
    the client reads nothing: its frames are split to the frame cap and its queue bounded in
    bytes; it is closed at its budget."""
    closes = ("ads.over_budget", "ads.write_queue_full")
    before = sum(d.count(e) for e in closes)
    c = client(d, rcvbuf=4096)
    _, info = c.read(0xF00C, 0, 8)
    size = struct.unpack("<II", info)[1]
    n = int(ATTACK_ADS["max_notifications_per_connection"])
    entry = struct.pack("<IIIIII16s", 0xF00B, 0, 0xFFFFFFFF, 3, 0, 10_000, bytes(16))
    reply = c.request(9, struct.pack("<IIII", 0xF085, n, 8 * n, 40 * n) + entry * n)
    code, data = wire.decode_read_response(reply.payload)
    assert code == 0 and set(struct.unpack(f"<{2 * n}I", data)[::2]) == {0}, (code, data)
    assert size * n > ATTACK_ADS["max_frame_bytes"]  # a poll's samples need several frames
    # read nothing until the server says it closed the connection (reading would drain what it
    # sends: on a quiet machine as fast as it comes, and the budget is never reached)
    end = time.monotonic() + 10.0
    while sum(d.count(e) for e in closes) == before and time.monotonic() < end:
        time.sleep(0.05)
    return closed(c, 3.0)


def routed_to_a_reader_that_stalls(d: Daemon) -> str:
    """A client registers an AMS port and reads nothing; another sends it 60 kB frames."""
    receiver = client(d, rcvbuf=4096)
    receiver.send(struct.pack("<HIH", 0x1000, 2, 0))
    head = b""
    while len(head) < 14:
        head += receiver.sock.recv(14 - len(head))
    port = struct.unpack_from("<H", head, 12)[0]
    sender = client(d)
    payload = bytes(60_000)
    sent = 0
    try:
        for _ in range(400):  # 24 MB, far beyond connection_budget_bytes
            sender.send(sender.frame(3, payload, port=port, target=net_id_bytes(d.net_id)))
            sent += 1
    except OSError:
        return f"sender closed after {sent} frames"
    outcome = f"receiver {closed(receiver, 10.0)}"
    sender.send(sender.frame(2, LIFT))
    invoke = sender.invoke
    while (reply := sender.recv_frame()).header.invoke_id != invoke:
        pass  # the answers to frames sent after the port was gone (AMS 0x6)
    sender.close()
    return f"{outcome}, sender served: {error_of(reply)}"


def plc_command_flood(d: Daemon) -> str:
    """200 sum writes of 128 × (RESET, START) back to back: the GEO loop reads 16 writes a
    cycle and never plans a program in its cycle; what does not fit the input ring is BUSY."""
    c = client(d)
    _, info = c.read_by_name("PLC.ch1.reset", 1)
    assert info
    codes: set[int] = set()
    heads, data = b"", b""
    for k in range(256):
        name = "PLC.ch1.reset" if k % 2 == 0 else "PLC.ch1.start"
        heads += struct.pack("<III", *_address(c, name), 1)
        data += b"\x01"
    for _ in range(200):
        reply = c.request(
            9, struct.pack("<IIII", 0xF081, 256, 4 * 256, len(heads + data)) + heads + data
        )
        code, results = wire.decode_read_response(reply.payload)
        codes.add(code)
        codes.update(struct.unpack("<256I", results))
    c.close()
    return "answered " + ", ".join("ok" if x == 0 else f"0x{x:X}" for x in sorted(codes))


def _address(c: RawClient, name: str) -> tuple[int, int]:
    reply = c.request(9, struct.pack("<IIII", 0xF007, 0, 12, len(name)) + name.encode())
    code, data = wire.decode_read_response(reply.payload)
    assert code == 0, hex(code)
    ig, io, _ = struct.unpack("<III", data)
    return ig, io


@dataclass(frozen=True)
class Case:
    name: str
    run: Callable[[Daemon], str]
    expected: str


CASES = [
    Case("truncated frame, then the client closes", truncated_then_close, "dropped"),
    Case("frame above max_frame_bytes", oversized, "closed"),
    Case("AMS length ≠ TCP length", length_lie, "AMS 0xE"),
    Case("garbage after a valid frame", garbage_after_valid, "ok, then closed"),
    Case(
        "1000 connections at once",
        thousand_connections,
        "64 kept (max_connections 64), rest closed",
    ),
    Case(
        "half a frame, then silence (timeout 0.5 s)", half_frame_stall, "closed after the timeout"
    ),
    Case("client that never reads (16 × 1 ms symbol-upload notifications)", never_reads, "closed"),
    Case(
        "notification subscriptions beyond the cap",
        notifications_beyond_cap,
        "16 ok, then ADS 0x716",
    ),
    Case("sum read beyond max_sum_subcommands", sum_beyond_cap, "ADS 0x705"),
    Case(
        "invalid handles",
        invalid_handles,
        "read ADS 0x710, release ADS 0x710, delete notification ADS 0x714",
    ),
    Case(
        "foreign NetId, port, command",
        foreign_addresses,
        "NetId AMS 0x7, port AMS 0x6, command AMS 0x8",
    ),
    Case(
        "sum read of one sub-command asking 2 GiB", sum_read_gigabytes(0xF080, 2 << 30), "ADS 0x70A"
    ),
    Case(
        "sum read-ex of one sub-command asking 4 GiB",
        sum_read_gigabytes(0xF083, 0xFFFFFFF0),
        "ADS 0x70A",
    ),
    Case(
        "notification sum on the symbol upload, client stops reading",
        upload_notifications_unread,
        "closed",
    ),
    Case(
        "60 kB frames routed to a registered port that does not read",
        routed_to_a_reader_that_stalls,
        "receiver closed, sender served: ok",
    ),
    Case("200 sum writes of 128 × (RESET, START)", plc_command_flood, "answered ok, 0x708"),
]


def probe_ms(d: Daemon, n: int = 200) -> float:
    """p99 latency of lift_active reads from a fresh well-behaved client, in ms."""
    c = client(d)
    lat = []
    for _ in range(n):
        t0 = time.perf_counter()
        assert c.read(0x121301, 0x30095, 1)[0] == 0
        lat.append(time.perf_counter() - t0)
    c.close()
    lat.sort()
    return 1e3 * lat[int(0.99 * (len(lat) - 1))]
