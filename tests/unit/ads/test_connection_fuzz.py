"""A hypothesis state machine drives one real AdsConnection (framer + codec + access checks +
service dispatch + notifications) through a fake transport with what a hostile or broken peer
can send: valid and random requests to every command, foreign addresses, random index groups
(the symbol server's and every sum command included), handles and notification handles, router
commands (port connect/close, get NetId, unknown ones), frames for the system port and for a
registered client port, garbage, frames cut anywhere, a peer that stops reading.

Invariants after every step: the server never hit an internal error (a bug is answered 0x700
and counted); every request of an intact stream got exactly one reply, in order, with its
invoke id; handles, notifications and the write queue stay within their caps; a broken stream
closes the connection and frees what it held. The run is bounded in CI (settings below) and
runs longer with HYPOTHESIS_PROFILE=fuzz (bench/fuzz_connection.py).
"""

from __future__ import annotations

import os
import struct

from hypothesis import HealthCheck, settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, initialize, invariant, rule

from liftd.ads import wire
from liftd.ads.constants import IndexGroup
from liftd.ads.framing import AmsFramer
from liftd.ads.server import AdsConnection
from liftd.ads.wire import net_id_bytes
from tests.support.ads_fake import FRAME, LIMITS, NET, QUEUE, FakeTransport, make_server

SOURCE = bytes([10, 0, 0, 9, 1, 1])
STATS = {"chunks": 0, "bytes": 0}  # for bench/fuzz_connection.py
EXAMPLES = int(os.environ.get("LIFTD_FUZZ_EXAMPLES", "200"))

IGS = [0x121301, 0x21301, 0x121401, 0x121501, 0x121601, 0x121701, 0x121801, 0x121901,
       *[int(g) for g in IndexGroup], 0, 0xFFFFFFFF]  # fmt: skip
IOS = [0x30095, 0x30094, 0x10095, 0xF, 0x10, 0x15, 0, 1, 0xFFFFFFFF]
NAMES = [b"GEO.ch1.Z.lift_active\0", b"gpAx[3].ipo_state.lift_active\0", b"PLC.ch1.override\0",
         b"PLC.ch1.start\0", b"GEO.cycle\0", b"nope\0", b"", b"GEO.ch1.Z.lift_active"]  # fmt: skip


payloads = st.one_of(
    st.binary(max_size=64),
    st.builds(
        lambda ig, io, n: struct.pack("<III", ig, io, n),
        st.sampled_from(IGS),
        st.sampled_from(IOS),
        st.integers(0, 70000),
    ),
    st.builds(
        lambda ig, io, data: struct.pack("<III", ig, io, len(data)) + data,
        st.sampled_from(IGS),
        st.sampled_from(IOS),
        st.binary(max_size=8),
    ),
    st.builds(
        lambda ig, io, n, name: struct.pack("<IIII", ig, io, n, len(name)) + name,
        st.sampled_from(IGS),
        st.sampled_from(IOS),
        st.integers(0, 300),
        st.sampled_from(NAMES),
    ),
    st.builds(
        lambda ig, io, n, mode, cyc: struct.pack("<IIIIII", ig, io, n, mode, 0, cyc) + bytes(16),
        st.sampled_from(IGS),
        st.sampled_from(IOS),
        st.integers(0, 16),
        st.sampled_from([3, 4, 0, 99]),
        st.integers(0, 100000),
    ),
    st.builds(lambda h: struct.pack("<I", h), st.integers(0, 40)),
)


class ConnectionMachine(RuleBasedStateMachine):
    @initialize()
    def connect(self) -> None:
        self.server = make_server()
        self.new_connection()

    def new_connection(self) -> None:
        self.transport = FakeTransport()
        self.conn = AdsConnection(self.server)
        self.conn.connection_made(self.transport)  # type: ignore[arg-type]
        self.reader = AmsFramer(1 << 24)
        self.expected: list[tuple[int, int]] = []  # (invoke id, command) awaiting a reply
        self.invoke = 0
        self.broken = False  # garbage went in: replies are no longer predictable

    def frame(self, command: int, payload: bytes, target: bytes = NET, port: int = 551) -> bytes:
        self.invoke += 1
        header = wire.AmsHeader(target, port, SOURCE, 30000, command, 4, 0, 0, self.invoke)
        return wire.encode_frame(header, payload)

    def feed(self, data: bytes, cut: int) -> None:
        STATS["chunks"] += 1
        STATS["bytes"] += len(data)
        for i in range(0, len(data), max(cut, 1)):
            if self.conn.closed:
                return
            self.conn.data_received(data[i : i + max(cut, 1)])

    def collect(self) -> None:
        frames = self.reader.feed(bytes(self.transport.out))
        self.transport.out.clear()
        for raw in frames:
            assert len(raw) <= FRAME + 6  # no reply, notification or routed frame above the cap
            if raw[:2] != b"\0\0":  # a router answer (AMS/TCP command, no AMS header)
                assert struct.unpack_from("<H", raw)[0] in (0x1000, 0x1002)
                continue
            f = wire.decode_frame(raw)
            if not f.header.flags & 1 and self.server.ports.route(
                f.header.target_net_id, f.header.target_port
            ):  # a frame for this connection's own registered port, routed back to it
                continue
            if f.header.command == 8:  # a device notification
                assert f.header.target_net_id == SOURCE
                wire.decode_notification(f.payload)
                continue
            assert f.header.flags & 1, "a reply carries the response flag"
            if not self.broken:
                assert self.expected, f"a reply nobody asked for: {f.header}"
                invoke, command = self.expected.pop(0)
                assert (f.header.invoke_id, f.header.command) == (invoke, command)

    @rule(command=st.integers(1, 9), payload=payloads, cut=st.integers(1, 80))
    def request(self, command: int, payload: bytes, cut: int) -> None:
        self.send(self.frame(command, payload), command, cut)

    def send(self, data: bytes, command: int, cut: int, routed: bool = False) -> None:
        if not self.transport.reading:
            return  # reading paused: the bytes wait in the kernel, nothing is delivered
        if not self.broken and command != 8 and not routed:  # no reply for these
            self.expected.append((self.invoke, command))
        self.feed(data, cut)
        if self.transport.reading:
            self.collect()

    @rule(dest=st.sampled_from([net_id_bytes("1.2.3.4.5.6"), NET]),
          port=st.sampled_from([550, 551, 851, 0, 10000, 32768]),
          command=st.integers(0, 12))  # fmt: skip
    def addressed(self, dest: bytes, port: int, command: int) -> None:
        routed = self.server.ports.route(dest, port) is not None
        self.send(self.frame(command, b"", dest, port), command, 1000, routed)

    @rule(command=st.sampled_from([0x1000, 0x0001, 0x1002, 0x1001, 0x4321]),
          payload=st.one_of(st.sampled_from([b"\0\0", b"\x00\x80", b"\x27\x02"]),
                            st.binary(max_size=5)))  # fmt: skip
    def router(self, command: int, payload: bytes) -> None:
        if self.transport.reading:
            self.feed(struct.pack("<HI", command, len(payload)) + payload, 1000)
            if self.transport.reading:
                self.collect()

    @rule(n=st.integers(1, 60))
    def burst(self, n: int) -> None:
        """n pipelined reads in one chunk (delivered even just after reading was paused: the
        chunk was already in flight)."""
        data = b""
        for _ in range(n):
            data += self.frame(2, struct.pack("<III", 0x121301, 0x30095, 1))
            if not self.broken:
                self.expected.append((self.invoke, 2))
        self.feed(data, len(data))
        if self.transport.reading:
            self.collect()

    @rule(mode=st.sampled_from([3, 4]), cycle_100ns=st.integers(0, 200_000),
          io=st.sampled_from([0x30095, 0x10094, 0x15]))  # fmt: skip
    def subscribe(self, mode: int, cycle_100ns: int, io: int) -> None:
        n = 8 if io == 0x15 else 1
        spec = struct.pack("<IIIIII", 0x121301, io, n, mode, 0, cycle_100ns) + bytes(16)
        self.send(self.frame(6, spec), 6, 1000)

    @rule(ig=st.sampled_from([0xF080, 0xF083, 0xF084]), n=st.integers(1, 4),
          length=st.sampled_from([1, 2048, 5000, 1 << 20, 2 << 30, 0xFFFFFFF0]),
          rlen=st.sampled_from([0xFFFFFFFF, 8, 4096]))  # fmt: skip
    def sum_asking_gigabytes(self, ig: int, n: int, length: int, rlen: int) -> None:
        """Issue 41: a sum read's reply is sized before it is built (0x70A above the cap)."""
        body = struct.pack("<III", 0x121301, 0x30095, length) * n
        self.send(self.frame(9, struct.pack("<IIII", ig, n, rlen, len(body)) + body), 9, 1000)

    @rule(n=st.integers(1, 8), mode=st.sampled_from([3, 4]))
    def notify_on_the_upload(self, n: int, mode: int) -> None:
        """A notification sum on the symbol upload (larger than the 4 kB frame): refused."""
        entry = struct.pack("<IIIIII16s", 0xF00B, 0, 0xFFFFFFFF, mode, 0, 10_000, bytes(16))
        payload = struct.pack("<IIII", 0xF085, n, 8 * n, 40 * n) + entry * n
        self.send(self.frame(9, payload), 9, 1000)

    @rule(data=st.binary(min_size=1, max_size=200))
    def garbage(self, data: bytes) -> None:
        if self.transport.reading:
            self.broken = True
            self.feed(data, 1000)

    @rule()
    def stop_reading(self) -> None:
        self.conn.pause_writing()  # the kernel buffer is full: the peer does not read

    @rule()
    def read_again(self) -> None:
        self.conn.resume_writing()
        self.collect()

    @rule(now_s=st.floats(0, 10))
    def notifications_due(self, now_s: float) -> None:
        self.server.poll_notifications(int(now_s * 1e9) + 10**12, 0)

    @invariant()
    def bounded_and_sane(self) -> None:
        assert self.server.counters.internal_errors == 0
        s = self.conn.session
        assert len(s.handles) <= LIMITS.max_handles
        assert len(s.notifications) <= LIMITS.max_notifications
        assert len(self.conn.queue) <= QUEUE + 1
        assert self.conn.held <= self.server.config.connection_budget_bytes  # bytes too
        assert self.conn.framer.pending <= 4096 + wire.HEADER_SIZE
        if self.conn.closed or self.transport.aborted:
            self.conn.connection_lost(None)
            assert not s.handles and not len(s.notifications) and not self.conn.queue
            assert self.conn not in self.server.connections
            assert self.conn not in self.server.ports.ports_of
            self.new_connection()


ConnectionMachine.TestCase.settings = settings(
    max_examples=EXAMPLES, stateful_step_count=40, deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
)  # fmt: skip
test_connection_state_machine = ConnectionMachine.TestCase
