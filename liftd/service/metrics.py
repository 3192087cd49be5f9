"""Optional Prometheus endpoint of the daemon (`[metrics] prometheus_port`): GET /metrics in
the text exposition format, GET /healthz 200 while the GEO loop runs. A dozen numbers read at
scrape time from shared memory; nothing is touched per cycle (rt-python.md §8)."""

from __future__ import annotations

import asyncio
from typing import TYPE_CHECKING

from liftd.runtime.cycle import EDGES
from liftd.service import logs

if TYPE_CHECKING:
    from liftd.service.daemon import Daemon


def exposition(d: Daemon) -> str:
    sh = d.shared
    c = d.server.counters
    lines = [
        "# TYPE liftd_geo_cycles_total counter",
        f"liftd_geo_cycles_total {sh.get('cycles')}",
        "# TYPE liftd_geo_exceeded_total counter",
        f"liftd_geo_exceeded_total {sh.get('exceeded')}",
        "# TYPE liftd_geo_regridded_total counter",
        f"liftd_geo_regridded_total {sh.get('regridded')}",
        "# TYPE liftd_geo_running gauge",
        f"liftd_geo_running {int(d.alive)}",
        "# TYPE liftd_ads_connections gauge",
        f"liftd_ads_connections {len(d.server.connections)}",
        "# TYPE liftd_ads_requests_total counter",
        f"liftd_ads_requests_total {c.requests}",
        "# TYPE liftd_ads_errors_total counter",
        f"liftd_ads_errors_total {c.closed_for_errors + c.internal_errors}",
        "# TYPE liftd_ads_notifications_total counter",
        f"liftd_ads_notifications_total {c.notifications_sent}",
        "# TYPE liftd_log_dropped_total counter",
        f"liftd_log_dropped_total {logs.dropped()}",
    ]
    for name, hist in (("lateness", sh.lateness_hist), ("compute", sh.compute_hist)):
        metric = f"liftd_geo_{name}_seconds"
        lines.append(f"# TYPE {metric} histogram")
        run = 0
        for edge, count in zip(EDGES, hist, strict=False):
            run += count
            if count or edge in (10_000, 50_000, 100_000, 500_000, 1_000_000):
                lines.append(f'{metric}_bucket{{le="{edge / 1e9:g}"}} {run}')
        total = sum(hist)
        lines.append(f'{metric}_bucket{{le="+Inf"}} {total}')
        lines.append(f"{metric}_count {total}")
    return "\n".join(lines) + "\n"


async def serve(host: str, port: int, d: Daemon) -> asyncio.Server:
    async def handle(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        try:
            request = await asyncio.wait_for(reader.readline(), 5.0)
            path = request.split()[1].decode() if len(request.split()) > 1 else ""
            if path == "/metrics":
                status, body = "200 OK", exposition(d)
            elif path == "/healthz":
                status, body = ("200 OK", "ok\n") if d.alive else ("503 Service Unavailable", "")
            else:
                status, body = "404 Not Found", ""
            data = body.encode()
            writer.write(
                f"HTTP/1.1 {status}\r\nContent-Type: text/plain; version=0.0.4\r\n"
                f"Content-Length: {len(data)}\r\nConnection: close\r\n\r\n".encode()
                + data
            )
            await writer.drain()
        except (TimeoutError, ConnectionError, IndexError):
            pass
        finally:
            writer.close()

    return await asyncio.start_server(handle, host, port)
