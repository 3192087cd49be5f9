"""Memory a peer can make the server hold (issue 41): replies sized before they are built,
notification frames split to the frame cap, write queues bounded in bytes per connection and
for the server, routed frames charged to the receiver, and no exception of the protocol layer
escaping `data_received`. One real AdsConnection per peer over a transport that buffers what
its peer does not read, as asyncio's does (pause_writing above 64 KiB)."""

from __future__ import annotations

import struct
import time
import tracemalloc
from typing import Any

import pytest
import structlog

from liftd.ads import wire
from liftd.ads.constants import AdsErr, IndexGroup
from liftd.ads.framing import AmsFramer
from liftd.ads.notifications import SAMPLE_OVERHEAD
from liftd.ads.server import AdsConnection, AdsServer
from liftd.ads.service import AdsService, ServiceLimits
from liftd.cnc.snapshot import LoopStats
from liftd.objects.catalog import Catalog, GeoView
from liftd.objects.provider import CncProvider
from liftd.service.adsconfig import server_config, service_limits
from liftd.settings.model import AdsSection
from tests.support.ads_fake import NET, Silent
from tests.support.ads_harness import snapshot
from tests.support.channel import make_channel

SOURCE = bytes([10, 0, 0, 9, 1, 1])
HIGH_WATER = 64 * 1024  # asyncio's default for a transport's write buffer
LIFT = (0x121301, 0x30095)


class Peer:
    """The transport of one connection whose peer reads only when told to."""

    def __init__(self) -> None:
        self.buffer = bytearray()  # written, not yet taken by the peer
        self.taken = bytearray()
        self.aborted = False
        self.protocol: AdsConnection | None = None
        self.paused = False

    def write(self, data: bytes) -> None:
        self.buffer += data
        if len(self.buffer) > HIGH_WATER and not self.paused and self.protocol is not None:
            self.paused = True
            self.protocol.pause_writing()

    def read_all(self) -> list[wire.Frame]:
        self.taken += self.buffer
        self.buffer.clear()
        while self.paused and self.protocol is not None:  # drained: the server writes on
            self.paused = False
            self.protocol.resume_writing()
            self.taken += self.buffer
            self.buffer.clear()
        frames = AmsFramer(1 << 30).feed(bytes(self.taken))
        self.taken.clear()
        return [wire.decode_frame(f) for f in frames if f[:2] == b"\0\0"]

    def get_write_buffer_size(self) -> int:
        return len(self.buffer)

    def abort(self) -> None:
        self.aborted = True
        self.buffer.clear()

    close = abort

    def pause_reading(self) -> None: ...

    def resume_reading(self) -> None: ...

    def get_extra_info(self, name: str) -> Any:
        return ("127.0.0.1", 40000) if name == "peername" else None


def server(**cfg: Any) -> AdsServer:
    catalog = Catalog(make_channel())
    view = GeoView(snapshot(), LoopStats(cycles=1))
    provider = CncProvider(catalog, lambda: view, lambda w: None)
    section = AdsSection(port=0, net_id="127.0.0.1.1.1", max_connections_per_ip=64, **cfg)
    return AdsServer(server_config(section), AdsService(provider, service_limits(section)),
                     structlog.wrap_logger(Silent()))  # fmt: skip


def connect(srv: AdsServer) -> tuple[AdsConnection, Peer]:
    peer = Peer()
    conn = AdsConnection(srv)
    peer.protocol = conn
    conn.connection_made(peer)  # type: ignore[arg-type]
    return conn, peer


INVOKE = [0]


def after_first_sample() -> int:
    """A poll time past the first sample of what was just subscribed (server's clock)."""
    return time.monotonic_ns() + 50_000_000


def frame(command: int, payload: bytes, port: int = 551, target: bytes = NET) -> bytes:
    INVOKE[0] += 1
    header = wire.AmsHeader(target, port, SOURCE, 30000, command, 4, 0, 0, INVOKE[0])
    return wire.encode_frame(header, payload)


def sum_request(ig: int, subs: list[tuple[int, int, int]], read_length: int) -> bytes:
    body = b"".join(struct.pack("<III", *sub) for sub in subs)
    return struct.pack("<IIII", ig, len(subs), read_length, len(body)) + body


def result_of(f: wire.Frame) -> int:
    return int(struct.unpack_from("<I", f.payload)[0])


@pytest.mark.parametrize("ig", [IndexGroup.SUMUP_READ, IndexGroup.SUMUP_READEX])
@pytest.mark.parametrize("length", [256 << 20, 2 << 30, 0xFFFFFFF0])
def test_a_sum_read_asking_gigabytes_gets_0x70a_without_allocating_them(ig: int, length: int) -> None:  # fmt: skip
    """The 66-byte frame of issue 41: one sub-command {lift_active, length L}, read length
    0xFFFFFFFF. It used to pad the reply to L (a 4 GiB peak for L = 2 GiB)."""
    srv = server()
    conn, peer = connect(srv)
    request = frame(9, sum_request(ig, [(*LIFT, length)], 0xFFFFFFFF))
    tracemalloc.start()
    conn.data_received(request)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    (reply,) = peer.read_all()
    assert result_of(reply) == AdsErr.NOMEMORY
    assert peak < 256 * 1024, peak
    assert not conn.closed and srv.counters.internal_errors == 0


def test_a_sum_read_that_fits_the_frame_is_still_answered_padded() -> None:
    """Up to the cap the layout clients step by holds: the object's byte, then zeros."""
    srv = server(max_frame_bytes=65536)
    conn, peer = connect(srv)
    cap = 65536 - 32 - 8  # a ReadWrite reply's data: the frame less AMS header, result, length
    conn.data_received(frame(9, sum_request(IndexGroup.SUMUP_READ, [(*LIFT, cap - 4)], cap)))
    conn.data_received(frame(9, sum_request(IndexGroup.SUMUP_READ, [(*LIFT, cap - 3)], cap + 1)))
    fits, over = peer.read_all()
    code, data = wire.decode_read_response(fits.payload)
    assert code == 0 and len(data) == cap and data[:4] == bytes(4) and data[5:] == bytes(cap - 5)
    assert result_of(over) == AdsErr.NOMEMORY


def test_a_compact_sum_read_is_checked_as_it_grows() -> None:
    """0xF084 returns the data read: 1000 reads of the symbol upload (a few kB each) would be
    megabytes; it stops at the cap."""
    srv = server(max_frame_bytes=65536)
    conn, peer = connect(srv)
    subs = [(IndexGroup.SYM_UPLOAD, 0, 1 << 20)] * 1000
    conn.data_received(frame(9, sum_request(IndexGroup.SUMUP_READEX2, subs, 0xFFFFFFFF)))
    (reply,) = peer.read_all()
    assert result_of(reply) == AdsErr.NOMEMORY


def upload_size(conn: AdsConnection, peer: Peer) -> int:
    conn.data_received(frame(2, struct.pack("<III", IndexGroup.SYM_UPLOADINFO, 0, 8)))
    (reply,) = peer.read_all()
    return int(struct.unpack_from("<II", wire.decode_read_response(reply.payload)[1])[1])


def test_notification_frames_never_exceed_the_frame_cap() -> None:
    """512 subscriptions to the symbol upload in one notification sum (issue 41: one 2.6 MiB
    frame per poll with a 1 MiB cap): no frame above the cap, at most a frame's worth of
    samples a poll (the rest first in line at the next), and every subscription served."""
    cap = 65536
    srv = server(max_frame_bytes=cap, max_notifications_per_connection=512)
    conn, peer = connect(srv)
    size = upload_size(conn, peer)
    n = 512
    subscribe_uploads(conn, n)
    (reply,) = peer.read_all()
    code, data = wire.decode_read_response(reply.payload)
    assert code == 0 and set(struct.unpack(f"<{2 * n}I", data)[::2]) == {0}
    t0 = after_first_sample()
    polls = -(-n * (size + 8) // (cap - 32)) + 1  # enough for every subscription once
    seen: set[int] = set()
    for ms in range(polls):  # the peer reads after each poll
        srv.poll_notifications(t0 + ms * 1_000_000, 0)
        frames = peer.read_all()
        samples = [s for f in frames for st in wire.decode_notification(f.payload)
                   for s in st.samples]  # fmt: skip
        assert frames and all(wire.HEADER_SIZE - 6 + len(f.payload) <= cap for f in frames)
        assert sum(8 + len(s.data) for s in samples) <= cap + size + 8
        assert all(len(s.data) == size for s in samples)
        seen.update(s.handle for s in samples)
    assert seen == set(range(1, n + 1)) and not conn.closed


def test_a_sample_that_cannot_fit_a_frame_is_refused_at_subscription() -> None:
    srv = server(max_frame_bytes=1024)
    conn, peer = connect(srv)
    size = upload_size(conn, peer)
    assert size > 1024 - 32 - SAMPLE_OVERHEAD  # the symbol upload does not fit a frame alone
    spec = struct.pack("<IIIIII16s", IndexGroup.SYM_UPLOAD, 0, 0xFFFFFFFF, 3, 0, 10_000, bytes(16))
    conn.data_received(frame(6, spec))
    (reply,) = peer.read_all()
    assert result_of(reply) == AdsErr.INVALIDWATCHSIZE


def subscribe_uploads(conn: AdsConnection, n: int) -> None:
    entry = struct.pack("<IIIIII16s", IndexGroup.SYM_UPLOAD, 0, 0xFFFFFFFF, 3, 0, 10_000, bytes(16))
    conn.data_received(frame(9, struct.pack("<IIII", IndexGroup.SUMUP_ADDDEVNOTE, n, 8 * n,
                                            40 * n) + entry * n))  # fmt: skip


def test_a_peer_that_stops_reading_is_closed_at_its_budget_not_its_frame_count() -> None:
    budget = 1 << 20
    srv = server(connection_budget_bytes=budget, max_notifications_per_connection=512)
    conn, peer = connect(srv)
    subscribe_uploads(conn, 512)
    peer.read_all()
    most, t0 = 0, after_first_sample()
    for ms in range(1000):
        srv.poll_notifications(t0 + ms * 1_000_000, 0)
        most = max(most, conn.held)
        if conn.closed:
            break
    assert conn.closed and peer.aborted
    assert srv.counters.over_budget == 1
    assert most <= budget + (1 << 20)  # at most one frame beyond the budget, never kept
    assert conn.held == 0


def test_the_server_budget_closes_the_connection_holding_most() -> None:
    """Four peers that stop reading, each under its own budget, together over the server's:
    the largest goes; a peer that reads is never the one."""
    srv = server(connection_budget_bytes=4 << 20, budget_bytes=6 << 20,
                 max_notifications_per_connection=512)  # fmt: skip
    hogs = [connect(srv) for _ in range(4)]
    plc, plc_peer = connect(srv)
    for k, (conn, peer) in enumerate(hogs):
        subscribe_uploads(conn, 100 * (k + 1))  # the last one holds most
        peer.read_all()
    t0 = after_first_sample()
    for ms in range(400):
        srv.poll_notifications(t0 + ms * 1_000_000, 0)
        plc.data_received(frame(2, struct.pack("<III", *LIFT, 1)))
        plc_peer.read_all()
        total = sum(c.held for c in srv.connections if not c.closed)
        assert total <= (6 << 20) + 5 * (256 << 10) + (1 << 20)
    assert hogs[3][0].closed and not plc.closed
    assert srv.counters.over_budget >= 1


def test_routed_frames_count_against_the_receiver() -> None:
    """A client registers a port and reads nothing; another sends it 60 kB frames: the
    receiver is closed at its budget (issue 41: 1 GiB queued in 1.1 s), the sender is not."""
    srv = server(connection_budget_bytes=1 << 20)
    receiver, rpeer = connect(srv)
    receiver.data_received(struct.pack("<HIH", 0x1000, 2, 0))
    (answer,) = [rpeer.taken + rpeer.buffer]
    port = struct.unpack_from("<H", bytes(answer), 12)[0]
    sender, speer = connect(srv)
    big = bytes(60_000)
    for _ in range(100):
        sender.data_received(frame(3, big, port=port))
        if receiver.closed:
            break
    assert receiver.closed and not sender.closed
    assert srv.counters.over_budget == 1 and srv.counters.routed < 40


def test_an_exception_in_the_protocol_layer_closes_only_that_connection(monkeypatch: pytest.MonkeyPatch) -> None:  # fmt: skip
    """issue 41: a reply `wire.encode_frame` could not encode ended in asyncio's `Fatal error
    on transport` traceback; now any exception closes the connection, logged and counted."""
    srv = server()
    bad, bad_peer = connect(srv)
    good, good_peer = connect(srv)

    def broken(*a: object) -> bytes:
        raise MemoryError

    request = frame(2, struct.pack("<III", *LIFT, 1))
    monkeypatch.setattr(wire, "encode_frame", broken)
    bad.data_received(request)
    monkeypatch.undo()
    assert bad.closed and bad_peer.aborted and srv.counters.protocol_errors == 1
    good.data_received(frame(2, struct.pack("<III", *LIFT, 1)))
    (reply,) = good_peer.read_all()
    assert result_of(reply) == 0


def test_the_service_never_answers_more_than_a_frame() -> None:
    """The last check (a reply whose size no pre-check knew): 0x70A instead of the bytes."""
    svc = AdsService(CncProvider(Catalog(make_channel()), lambda: None, lambda w: None),
                     ServiceLimits(max_reply_payload=64))  # fmt: skip
    s = svc.new_session()
    upload = wire.encode_read_request(wire.ReadRequest(IndexGroup.SYM_UPLOAD, 0, 1 << 20))
    header = wire.AmsHeader(NET, 551, SOURCE, 30000, 2, 4, 0, 0, 1)
    reply = svc.handle(s, header, upload, True, 0)
    assert reply.failure is None and wire.decode_read_response(reply.payload)[0] == 0x70A


def test_an_exception_while_sampling_closes_only_that_connection(monkeypatch: pytest.MonkeyPatch) -> None:  # fmt: skip
    """The notification task polls every connection: one whose poll raises is closed, the
    task and the others go on (it used to end the task silently: no more notifications)."""
    srv = server()
    bad, bad_peer = connect(srv)
    good, good_peer = connect(srv)
    spec = struct.pack("<IIIIII16s", *LIFT, 1, 3, 0, 10_000, bytes(16))
    for conn, peer in ((bad, bad_peer), (good, good_peer)):
        conn.data_received(frame(6, spec))
        peer.read_all()
    broken = bad.session.notifications

    def poll(*a: object) -> list[object]:
        raise MemoryError

    monkeypatch.setattr(broken, "poll", poll)
    srv.poll_notifications(after_first_sample(), 0)
    assert bad.closed and srv.counters.protocol_errors == 1
    assert any(f.header.command == 8 for f in good_peer.read_all())
