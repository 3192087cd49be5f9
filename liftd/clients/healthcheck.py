"""`liftd healthcheck`: is the daemon serving live data? Over raw AMS/TCP with liftd's own codec,
so no AdsLib route is needed (Docker HEALTHCHECK, scripts): ADS state must be RUN and the GEO
cycle counter must advance between two reads 50 ms apart."""

from __future__ import annotations

import struct
import time

from liftd.ads.client import RawClient
from liftd.ads.constants import AdsState
from liftd.ads.wire import net_id_bytes


def probe(host: str, port: int, net_id: str, timeout_s: float) -> tuple[bool, str]:
    """(healthy, a one-line message)."""
    try:
        client = RawClient(port, net_id_bytes(net_id), host=host, timeout_s=timeout_s)
        try:
            result, state, _ = client.read_state()
            counts = []
            for _ in range(2):
                code, raw = client.read_by_name("GEO.cycle", 8)
                counts.append(struct.unpack("<Q", raw)[0] if code == 0 and len(raw) == 8 else -1)
                time.sleep(0.05)
        finally:
            client.close()
    except (OSError, ValueError) as exc:
        return False, f"unhealthy: no ADS answer from {host}:{port}: {exc}"
    if result or state != AdsState.RUN:
        return False, f"unhealthy: ADS state {state} (result 0x{result:X}), not RUN"
    if counts[1] <= counts[0]:
        return False, f"unhealthy: the GEO cycle counter does not advance ({counts})"
    return True, f"healthy: RUN, GEO cycle {counts[1]}"
