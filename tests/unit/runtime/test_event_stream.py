"""The GEO loop's events reach the daemon through the shared block's event stream: in order,
whole, and still after a consumer failed on one of them."""

from __future__ import annotations

import asyncio
from typing import Any

from liftd.cnc.snapshot import Event
from liftd.runtime.geo_process import GeoProcess
from liftd.runtime.records import pack_event
from liftd.runtime.shared import Shared


def test_events_arrive_in_order_and_a_failing_consumer_does_not_end_their_delivery() -> None:
    shared = Shared(3)
    got: list[Event] = []
    errors: list[dict[str, Any]] = []

    def consume(ev: Event) -> None:
        if ev.name == "lift.start" and not any(e.name == "lift.start" for e in got):
            got.append(ev)
            raise RuntimeError("a consumer's bug")
        got.append(ev)

    async def main() -> None:
        asyncio.get_running_loop().set_exception_handler(lambda _loop, ctx: errors.append(ctx))
        geo = GeoProcess(shared, consume, stall_timeout_s=1.0)
        poller = asyncio.create_task(geo._poll_events())
        for i, name in enumerate(("geo.program_start", "lift.start", "lift.end")):
            shared.events.put(pack_event(Event(name, 0.001 * i, 10 + i, 1.5, "x" * 300 * i)))
            while len(got) <= i:  # the daemon's poll takes it within EVENT_POLL_S
                await asyncio.sleep(0.001)
        poller.cancel()

    try:
        asyncio.run(asyncio.wait_for(main(), 10.0))
    finally:
        shared.close()
    assert [(e.name, e.line, len(e.text)) for e in got] == [
        ("geo.program_start", 10, 0),
        ("lift.start", 11, 300),
        ("lift.end", 12, 600),
    ]
    assert len(errors) == 1 and isinstance(errors[0]["exception"], RuntimeError)
