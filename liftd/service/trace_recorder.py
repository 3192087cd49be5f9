"""`liftd run --trace`: a daemon-side thread drains the GEO loop's trace ring into the CSV of
`liftd simulate` (trace.py), one file per channel, off the loop's CPU time. A write error
(disk full) stops the trace, never the loop; records the ring had to drop are reported at the
end."""

from __future__ import annotations

import threading
import time
from collections.abc import Sequence
from typing import Any, TextIO

from liftd.runtime.records import MachineCodec
from liftd.runtime.shm import Ring
from liftd.sim.trace import TraceWriter

DRAIN_PERIOD_S = 0.02


class TraceRecorder:
    def __init__(
        self,
        outs: Sequence[TextIO],
        ring: Ring,
        codec: MachineCodec,
        axis_names: Sequence[tuple[str, ...]],
        log: Any,
    ) -> None:
        """`outs` and `axis_names`: one per channel, in channel order."""
        self.outs = list(outs)
        self.ring = ring
        self.codec = codec
        self.writers = [TraceWriter(o, n) for o, n in zip(outs, axis_names, strict=True)]
        self.log = log
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._drain, name="liftd-trace", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def stop(self, timeout_s: float = 5.0) -> None:
        """Drain what is left and close the file (the loop has stopped writing)."""
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout_s)

    def _drain(self) -> None:
        ring, ok = self.ring, True
        rows = backlog_max = 0
        gap_max = 0.0
        last = time.monotonic()
        while True:
            stop = self._stop.is_set()
            now = time.monotonic()
            gap_max = max(gap_max, now - last)
            last = now
            backlog_max = max(backlog_max, len(ring))
            while (raw := ring.get()) is not None:
                rows += 1
                if ok:
                    try:
                        snaps = self.codec.unpack(raw)[0]
                        for writer, snap in zip(self.writers, snaps, strict=True):
                            writer.write(snap)
                    except OSError as exc:  # disk full: stop tracing, never the loop
                        ok = False
                        self.log.error("trace.stopped", reason=exc.strerror)
            if stop:
                break
            time.sleep(DRAIN_PERIOD_S)
        for writer, out in zip(self.writers, self.outs, strict=True):
            try:
                if ok:
                    writer.flush()
                out.close()
            except OSError as exc:
                ok = False
                self.log.error("trace.stopped", reason=exc.strerror)
        # the ring's margin as used: how far the writer fell behind, its longest pause
        self.log.info(
            "trace.closed",
            rows=rows,
            backlog_max=backlog_max,
            capacity=ring.capacity,
            pause_max_ms=round(gap_max * 1e3, 1),
        )
        if ring.dropped:
            self.log.warning("trace.dropped", records=ring.dropped)
