"""Optional Prometheus endpoint of the daemon (`[metrics] prometheus_port`): GET /metrics in
the text exposition format of prometheus_client, GET /healthz 200 while the GEO loop runs.

A custom collector asks for one `Sample` per scrape (a callable the daemon passes in: the GEO
loop's counters and histograms, read from shared memory at that moment, and the ADS server's
counters); nothing is touched per cycle (docs/reference/rt-python.md §8). The histograms are served
on a fixed bucket set with `_sum` and `_count`; the daemon's and the GEO process's process metrics
(CPU, memory, descriptors) come from prometheus_client's process collector.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable, Iterator, Sequence
from typing import NamedTuple

from prometheus_client import CollectorRegistry, ProcessCollector, generate_latest
from prometheus_client.core import (
    CounterMetricFamily,
    GaugeMetricFamily,
    HistogramMetricFamily,
    Metric,
)
from prometheus_client.exposition import CONTENT_TYPE_LATEST
from prometheus_client.registry import Collector

from liftd.objects.catalog import AdsStats
from liftd.runtime.cycle import EDGES
from liftd.runtime.shared import LoopTotals
from liftd.service import logs

# histogram upper edges (ns) served, whatever the run: 10 µs … 10 ms (each an EDGES entry)
BUCKETS_NS = (
    10_000,
    25_000,
    50_000,
    100_000,
    250_000,
    500_000,
    1_000_000,
    2_500_000,
    5_000_000,
    10_000_000,
)
assert set(BUCKETS_NS) <= set(EDGES)


class Sample(NamedTuple):
    """What one scrape reports."""

    totals: LoopTotals
    compute_hist: Sequence[int]  # counts per runtime.cycle bucket (EDGES, then overflow)
    lateness_hist: Sequence[int]
    geo_running: bool
    ads: AdsStats


def buckets(counts: Sequence[int]) -> list[tuple[str, float]]:
    """Cumulative counts at BUCKETS_NS (in seconds) and +Inf, from the fine histogram."""
    out: list[tuple[str, float]] = []
    run = 0
    i = 0
    for edge in BUCKETS_NS:
        while i < len(EDGES) and EDGES[i] <= edge:
            run += counts[i]
            i += 1
        out.append((f"{edge / 1e9:g}", run))
    out.append(("+Inf", sum(counts)))
    return out


class LiftdCollector(Collector):
    def __init__(self, sample: Callable[[], Sample]) -> None:
        self.sample = sample

    def collect(self) -> Iterator[Metric]:
        s = self.sample()
        t, a = s.totals, s.ads
        for name, text, value in (
            ("geo_cycles", "GEO cycles computed", t.cycles),
            (
                "geo_exceeded",
                "GEO cycles that finished after the start of the next one (TwinCAT exceed counter)",
                t.exceeded,
            ),
            (
                "geo_compute_over_25pct",
                "GEO cycles whose compute took more than 25 % of the cycle time",
                t.compute_over,
            ),
            (
                "geo_compute_cpu_over_25pct",
                "GEO cycles whose compute took more than 25 % of the "
                "cycle time on the loop thread's CPU clock",
                t.compute_cpu_over,
            ),
            ("geo_regridded", "wall-clock GEO ticks skipped after a stall", t.regridded),
            (
                "geo_events_dropped",
                "GEO events dropped (the daemon had not read the last 64 KiB)",
                t.events_dropped,
            ),
            ("ads_requests", "ADS requests answered", a.requests),
            (
                "ads_errors",
                "ADS connections closed for protocol errors and requests answered 0x700",
                a.errors,
            ),
            ("ads_notifications", "ADS device notification frames sent", a.notifications),
            (
                "log_dropped",
                "log lines dropped because the log output did not keep up",
                logs.dropped(),
            ),
        ):
            yield CounterMetricFamily(f"liftd_{name}", text, value)
        yield GaugeMetricFamily(
            "liftd_geo_running", "1 while the GEO loop cycles and ADS serves", int(s.geo_running)
        )
        yield GaugeMetricFamily("liftd_ads_connections", "open ADS connections", a.connections)
        for name, hist, total_ns, what in (
            ("lateness", s.lateness_hist, t.lateness_sum_ns, "wake-up lateness"),
            ("compute", s.compute_hist, t.compute_sum_ns, "compute time"),
        ):
            yield HistogramMetricFamily(
                f"liftd_geo_{name}_seconds",
                f"GEO cycle {what}",
                buckets=buckets(hist),
                sum_value=total_ns / 1e9,
            )


def registry(sample: Callable[[], Sample], geo_pid: Callable[[], int | None]) -> CollectorRegistry:
    reg = CollectorRegistry(auto_describe=False)
    reg.register(LiftdCollector(sample))
    ProcessCollector(registry=reg)  # the daemon: process_cpu_seconds_total, …
    ProcessCollector(namespace="liftd_geo", pid=lambda: geo_pid() or "none", registry=reg)
    return reg


async def serve(
    host: str,
    port: int,
    sample: Callable[[], Sample],
    alive: Callable[[], bool],
    geo_pid: Callable[[], int | None],
) -> asyncio.Server:
    reg = registry(sample, geo_pid)

    async def handle(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        try:
            request = await asyncio.wait_for(reader.readline(), 5.0)
            path = request.split()[1].decode() if len(request.split()) > 1 else ""
            content_type = "text/plain; charset=utf-8"
            if path == "/metrics":
                status, data, content_type = "200 OK", generate_latest(reg), CONTENT_TYPE_LATEST
            elif path == "/healthz":
                status, data = ("200 OK", b"ok\n") if alive() else ("503 Service Unavailable", b"")
            else:
                status, data = "404 Not Found", b""
            writer.write(
                f"HTTP/1.1 {status}\r\nContent-Type: {content_type}\r\n"
                f"Content-Length: {len(data)}\r\nConnection: close\r\n\r\n".encode()
                + data
            )
            await writer.drain()
        except (TimeoutError, ConnectionError, IndexError):
            pass
        finally:
            writer.close()

    return await asyncio.start_server(handle, host, port)
