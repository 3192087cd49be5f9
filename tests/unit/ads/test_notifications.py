"""Notification scheduling on a virtual clock: modes, cycle clamping, max delay batching,
samples of the object's size (at most the length subscribed), addresses, caps."""

from __future__ import annotations

import pytest

from liftd.ads import wire
from liftd.ads.errors import AdsError
from liftd.ads.notifications import FIRST_SAMPLE_DELAY_NS, AmsAddr, NotificationTable

MS = 1_000_000
FIRST = FIRST_SAMPLE_DELAY_NS  # subscribed this long before t = 0: the first sample is due at 0
CLIENT = AmsAddr(bytes([10, 0, 0, 7, 1, 1]), 30001)
SERVER = AmsAddr(bytes([127, 0, 0, 1, 1, 1]), 551)


class Value:
    def __init__(self) -> None:
        self.data = b"\x00"
        self.reads = 0

    def __call__(self, ig: int, io: int, n: int) -> bytes:
        self.reads += 1
        return self.data


def req(mode: int = 4, cycle_ms: float = 1.0, delay_ms: float = 0.0, n: int = 1):  # type: ignore[no-untyped-def]
    return wire.AddNotificationRequest(
        0x121301, 0x30095, n, mode, int(delay_ms * 1e4), int(cycle_ms * 1e4)
    )


def run(
    table: NotificationTable, value: Value, until_ms: int, change_at: dict[int, bytes]
) -> list[tuple[int, tuple[wire.Stamp, ...]]]:
    out = []
    for ms in range(until_ms + 1):
        if ms in change_at:
            value.data = change_at[ms]
        for o in table.poll(ms * MS, ms * MS, value):
            assert (o.client, o.server) == (CLIENT, SERVER)
            out.append((ms, wire.decode_notification(o.payload)))
    return out


def test_on_change_sends_the_first_value_and_every_change() -> None:
    table = NotificationTable(10, MS, 1024, 65536)
    table.add(req(4, cycle_ms=2), CLIENT, SERVER, -FIRST)
    sent = run(table, Value(), 20, {5: b"\x01", 6: b"\x01", 11: b"\x00"})
    assert [ms for ms, _ in sent] == [0, 6, 12]  # checked every 2 ms
    assert [s[0].samples[0].data for _, s in sent] == [b"\x00", b"\x01", b"\x00"]


def test_cyclic_sends_every_cycle_and_the_cycle_is_clamped() -> None:
    table = NotificationTable(10, 2 * MS, 1024, 65536)
    table.add(req(3, cycle_ms=0.0001), CLIENT, SERVER, -FIRST)  # pyads' default: 1 × 100 ns
    assert [ms for ms, _ in run(table, Value(), 10, {})] == [0, 2, 4, 6, 8, 10]


def test_max_delay_batches_stamps_into_one_frame() -> None:
    table = NotificationTable(10, MS, 1024, 65536)
    h1 = table.add(req(3, cycle_ms=1, delay_ms=5), CLIENT, SERVER, -FIRST)
    h2 = table.add(req(3, cycle_ms=1, delay_ms=5, n=2), CLIENT, SERVER, -FIRST)
    sent = run(table, Value(), 9, {})
    assert [ms for ms, _ in sent] == [5]  # first sample at 0 waits its max delay of 5 ms
    stamps = sent[0][1]
    assert [s.filetime for s in stamps] == [wire.filetime(ms * MS) for ms in range(6)]
    assert all([x.handle for x in s.samples] == [h1, h2] for s in stamps)
    # 2 bytes subscribed to a 1-byte object: its byte, not padded (the length is a maximum)
    assert all(s.samples[1].data == b"\x00" for s in stamps)


def test_failed_reads_are_skipped_and_handles_are_unique() -> None:
    table = NotificationTable(3, MS, 1024, 65536)
    handles = {table.add(req(), CLIENT, SERVER, -FIRST) for _ in range(3)}
    assert len(handles) == 3 and 0 not in handles
    with pytest.raises(AdsError) as err:
        table.add(req(), CLIENT, SERVER, -FIRST)
    assert err.value.code == 0x716

    def failing(ig: int, io: int, n: int) -> bytes:
        raise AdsError(0x707)

    assert table.poll(0, 0, failing) == []
    table.delete(handles.pop())
    with pytest.raises(AdsError) as err:
        table.delete(999)
    assert err.value.code == 0x714
    with pytest.raises(AdsError) as err:  # the cap is on what a sample carries
        table.add(req(n=0xFFFFFFFF), CLIENT, SERVER, -FIRST, size=2000)
    assert err.value.code == 0x717
    table.add(req(n=0xFFFFFFFF), CLIENT, SERVER, -FIRST, size=1)  # ads-client's "any size"


def test_next_wakeup_follows_the_earliest_subscription() -> None:
    table = NotificationTable(10, MS, 1024, 65536)
    assert table.next_wakeup() is None
    table.add(req(4, cycle_ms=10), CLIENT, SERVER, 3 * MS)
    assert table.next_wakeup() == 23 * MS  # first sample: a cycle but at least 20 ms later
    table.poll(23 * MS, 0, Value())
    assert table.next_wakeup() == 33 * MS
    table.poll(80 * MS, 0, Value())  # late: missed cycles are skipped, not replayed
    assert table.next_wakeup() == 90 * MS


def test_a_subscription_while_not_ready_takes_any_length_and_samples_keep_to_the_cap() -> None:
    """ads-client's "any size" (0xFFFFFFFF) while the GEO task does not serve yet: the size is
    unknown, so the length is taken; no sample ever carries more than the cap (1024 here)."""
    table = NotificationTable(10, MS, 1024, 65536)
    table.add(req(n=0xFFFFFFFF), CLIENT, SERVER, -FIRST)  # size unknown: was 0x717
    value = Value()
    value.data = b"\x01" * 3000  # an object longer than the cap (an upload that grew)
    sent = run(table, value, 0, {})
    assert [len(s.samples[0].data) for _, stamps in sent for s in stamps] == [1024]
