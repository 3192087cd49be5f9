"""Device notifications of one connection: subscriptions and what is due. Pure: the server
passes the clocks and a reader, and writes what `poll` returns.

Rules (reference/ads.md §1.5–§1.6, Beckhoff "ADS Add Device Notification"):

* cycle time and max delay arrive in 100 ns units; the cycle is clamped to a configured minimum
  (pyads sends 1 = 100 ns by default);
* cyclic modes send the value every cycle, on-change modes check it every cycle and send it when
  its bytes differ from the last sent; the first check always sends, one cycle but at least
  FIRST_SAMPLE_DELAY after subscribing: AdsLib registers its dispatcher only after it has read
  the handle from the response and drops a notification that comes earlier (seen with pyads);
* a sample may wait up to its max delay, so samples of several cycles and handles share frames
  (one stamp per poll, several samples per stamp); with max delay 0 it goes out at once; no
  frame carries more than `max_payload` bytes (the server's frame cap less the AMS header): a
  poll's samples are split over several stamps and frames where needed, and a subscription
  whose sample could not fit a frame alone is refused (0x717);
* the subscribed length is a maximum, as a Read's is: a sample carries the object's bytes, at
  most that many (TwinCAT.Ads: "Maximum amount of data in bytes to receive with this ADS
  Notification", infosys 1033/tc3_ads.net/21041338891; TwinCAT's logger sends samples shorter
  than the length subscribed, Beckhoff/ADS#235 and #277; ads-client subscribes with length
  0xFFFFFFFF to an address of unknown size). AdsLib drops a sample whose size is not the one it
  subscribed (ADS#235), so pyads gets samples when it asks the object's size, as with TwinCAT;
* a notification goes to the client address that subscribed, from the server address it
  subscribed to (AdsLib routes on that pair and drops the rest).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import NamedTuple

from liftd.ads.constants import CYCLIC_MODES, ON_CHANGE_MODES, AdsErr
from liftd.ads.errors import AdsError
from liftd.ads.wire import AddNotificationRequest, Sample, Stamp, encode_notification, filetime

Reader = Callable[[int, int, int], bytes]  # (index group, index offset, length) → data
FIRST_SAMPLE_DELAY_NS = 20_000_000
SAMPLE_OVERHEAD = 28  # payload head (8), stamp (12) and sample head (8) around one sample


class AmsAddr(NamedTuple):
    net_id: bytes
    port: int


class Outgoing(NamedTuple):
    """One DeviceNotification frame to send: to `client`, from `server`."""

    client: AmsAddr
    server: AmsAddr
    payload: bytes


@dataclass(slots=True)
class Subscription:
    handle: int
    index_group: int
    index_offset: int
    length: int
    on_change: bool
    cycle_ns: int
    max_delay_ns: int
    client: AmsAddr
    server: AmsAddr
    next_due_ns: int
    last: bytes | None = None


@dataclass(slots=True)
class _Batch:
    deadline_ns: int
    stamps: list[Stamp] = field(default_factory=list)
    size: int = 8


class NotificationTable:
    def __init__(
        self, max_handles: int, min_cycle_ns: int, max_length: int, max_payload: int
    ) -> None:
        self.max_handles = max_handles
        self.min_cycle_ns = min_cycle_ns
        self.max_payload = max_payload
        # a sample alone in a frame: 8 bytes of payload head, 12 of stamp, 8 of sample head
        self.max_length = min(max_length, max_payload - SAMPLE_OVERHEAD)
        self.subs: dict[int, Subscription] = {}
        self._next_handle = 1
        self._batches: dict[tuple[AmsAddr, AmsAddr], _Batch] = {}
        self._cursor = 0  # where the next poll starts sampling (polls cut by max_payload)

    def __len__(self) -> int:
        return len(self.subs)

    def add(
        self,
        req: AddNotificationRequest,
        client: AmsAddr,
        server: AmsAddr,
        now_ns: int,
        size: int | None = None,
    ) -> int:
        """Subscribe; returns the handle. Raises 0x713 (mode), 0x717 (length), 0x716 (cap).
        The caller checks first that the object exists and is readable and passes its `size`
        when it has it: the cap on the length is a cap on what a sample carries. Without it
        (the device not ready at the subscription) the length is taken, cut to the cap: no
        sample ever carries more."""
        if req.mode in CYCLIC_MODES:
            on_change = False
        elif req.mode in ON_CHANGE_MODES:
            on_change = True
        else:
            raise AdsError(AdsErr.TRANSMODENOTSUPP, f"transmission mode {req.mode}")
        if req.length == 0 or (size is not None and min(req.length, size) > self.max_length):
            raise AdsError(AdsErr.INVALIDWATCHSIZE, f"notification length {req.length}")
        if len(self.subs) >= self.max_handles:
            raise AdsError(AdsErr.NOMOREHDLS, f"{self.max_handles} notifications per connection")
        handle = self._next_handle
        while handle in self.subs or handle == 0:
            handle = (handle + 1) & 0xFFFFFFFF
        self._next_handle = (handle + 1) & 0xFFFFFFFF
        cycle_ns = max(req.cycle_time_100ns * 100, self.min_cycle_ns)
        self.subs[handle] = Subscription(
            handle,
            req.index_group,
            req.index_offset,
            min(req.length, self.max_length),  # a maximum (module docstring)
            on_change,
            cycle_ns,
            req.max_delay_100ns * 100,
            client,
            server,
            now_ns + max(cycle_ns, FIRST_SAMPLE_DELAY_NS),
        )
        return handle

    def delete(self, handle: int) -> None:
        if self.subs.pop(handle, None) is None:
            raise AdsError(AdsErr.NOTIFYHNDINVALID, f"notification handle {handle}")

    def clear(self) -> None:
        self.subs.clear()
        self._batches.clear()

    def next_wakeup(self) -> int | None:
        """Earliest time (monotonic ns) at which `poll` has something to do."""
        times = [s.next_due_ns for s in self.subs.values()]
        times += [b.deadline_ns for b in self._batches.values()]
        return min(times, default=None)

    def poll(self, now_ns: int, unix_ns: int, read: Reader) -> list[Outgoing]:
        """Sample what is due at `now_ns` (monotonic) with stamps from `unix_ns` (wall clock);
        return the frames whose max delay is up. A failing read skips that sample. At most
        `max_payload` bytes of samples a poll: what is due beyond stays due, first in line at
        the next poll (one connection's 512 subscriptions to a 5 kB object were 2.6 MB and
        several ms of the event loop each millisecond, which every other client waited for)."""
        out: list[Outgoing] = []
        stamp_time = filetime(unix_ns)
        fresh: dict[tuple[AmsAddr, AmsAddr], list[Sample]] = {}
        subs = list(self.subs.values())
        start = self._cursor % len(subs) if subs else 0
        taken = 0
        for i in range(len(subs)):
            sub = subs[(start + i) % len(subs)]
            if sub.next_due_ns > now_ns:
                continue
            if taken >= self.max_payload:
                self._cursor = start + i  # the next poll begins here
                break
            sub.next_due_ns += sub.cycle_ns
            if sub.next_due_ns <= now_ns:  # late (a busy loop): skip the missed cycles
                sub.next_due_ns = now_ns + sub.cycle_ns
            try:
                data = read(sub.index_group, sub.index_offset, sub.length)
            except AdsError:
                continue
            if len(data) > sub.length:
                data = data[: sub.length]
            if sub.on_change and data == sub.last:
                continue
            sub.last = data
            taken += 8 + len(data)
            key = (sub.client, sub.server)
            fresh.setdefault(key, []).append(Sample(sub.handle, data))
            batch = self._batches.get(key)
            if batch is None:
                self._batches[key] = _Batch(now_ns + sub.max_delay_ns)
            else:
                batch.deadline_ns = min(batch.deadline_ns, now_ns + sub.max_delay_ns)
        for key, samples in fresh.items():  # frames of at most max_payload: split stamps too
            batch = self._batches[key]
            stamp: list[Sample] = []
            size = 12
            for sample in samples:
                need = 8 + len(sample.data)
                if batch.size + size + need > self.max_payload and (stamp or batch.stamps):
                    if stamp:
                        batch.stamps.append(Stamp(stamp_time, tuple(stamp)))
                    out.append(Outgoing(*key, encode_notification(batch.stamps)))
                    batch.stamps, batch.size = [], 8
                    stamp, size = [], 12
                stamp.append(sample)
                size += need
            batch.stamps.append(Stamp(stamp_time, tuple(stamp)))
            batch.size += size
        for key in [k for k, b in self._batches.items() if b.deadline_ns <= now_ns]:
            batch = self._batches.pop(key)
            if batch.stamps:
                out.append(Outgoing(*key, encode_notification(batch.stamps)))
        return out
