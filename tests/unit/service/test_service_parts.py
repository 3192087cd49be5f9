"""The daemon's small parts without a daemon: the Prometheus collector on a fixed sample, the
notification texts, where the control socket is, and the GEO events' log levels."""

from __future__ import annotations

import re
import time
from pathlib import Path

from prometheus_client import generate_latest
from structlog.testing import capture_logs

from liftd.cnc.snapshot import Event
from liftd.objects.catalog import AdsStats
from liftd.runtime.cycle import BUCKETS, bucket
from liftd.runtime.shared import LoopTotals
from liftd.service import control, systemd
from liftd.service.daemon import needs_restart
from liftd.service.geo_log import GeoEventLog
from liftd.service.metrics import BUCKETS_NS, Sample, buckets, registry
from liftd.settings.model import LiftdConfig


def hist(*ns: int) -> list[int]:
    counts = [0] * BUCKETS
    for value in ns:
        counts[bucket(value)] += 1
    return counts


def test_buckets_are_cumulative_on_the_fixed_edges() -> None:
    got = buckets(hist(3_000, 10_000, 30_000, 2_000_000, 50_000_000))
    assert [le for le, _ in got] == [f"{e / 1e9:g}" for e in BUCKETS_NS] + ["+Inf"]
    counts = [c for _, c in got]
    assert counts == sorted(counts) and counts[0] == 2 and counts[-2] == 4 and counts[-1] == 5


def test_the_exposition_of_a_sample() -> None:
    totals = LoopTotals(
        cycles=1000,
        exceeded=3,
        compute_over=7,
        regridded=0,
        events_dropped=0,
        compute_sum_ns=60_000_000,
        lateness_sum_ns=20_000_000,
        compute_cpu_over=2,
    )
    sample = Sample(
        totals, hist(*[60_000] * 1000), hist(*[20_000] * 1000), True, AdsStats(2, 500, 1, 40)
    )
    body = generate_latest(registry(lambda: sample, lambda: None)).decode()
    assert "liftd_geo_cycles_total 1000.0" in body
    assert "liftd_geo_compute_over_25pct_total 7.0" in body
    assert "liftd_geo_compute_cpu_over_25pct_total 2.0" in body
    assert "liftd_geo_compute_seconds_sum 0.06" in body
    assert "liftd_geo_compute_seconds_count 1000.0" in body
    assert 'liftd_geo_compute_seconds_bucket{le="5e-05"} 0.0' in body
    assert 'liftd_geo_compute_seconds_bucket{le="0.0001"} 1000.0' in body
    assert "liftd_ads_connections 2.0" in body and "liftd_geo_running 1.0" in body
    assert set(re.findall(r"^# TYPE (\S+)", body, re.M)) <= set(
        re.findall(r"^# HELP (\S+)", body, re.M)
    )
    assert "process_resident_memory_bytes" in body  # the daemon's own
    assert "liftd_geo_process_resident_memory_bytes" not in body  # no GEO process: nothing


def test_reloading_carries_the_monotonic_time_in_microseconds() -> None:
    before = time.clock_gettime_ns(time.CLOCK_MONOTONIC) // 1000
    head, stamp = systemd.reloading_message().split("\n")
    assert head == "RELOADING=1" and stamp.startswith("MONOTONIC_USEC=")
    assert before <= int(stamp.split("=")[1]) <= before + 10_000_000


def test_the_control_socket_lives_in_the_runtime_directory() -> None:
    assert control.socket_path({"RUNTIME_DIRECTORY": "/run/liftd"}) == Path(
        "/run/liftd/control.sock"
    )
    assert control.socket_path({}) is None  # no systemd RuntimeDirectory: no socket
    assert control.socket_path({}, "/tmp/x.sock") == Path("/tmp/x.sock")


def test_geo_events_become_log_lines_at_their_level_and_quiet_ones_are_limited() -> None:
    log = GeoEventLog(__import__("structlog").get_logger())
    with capture_logs() as logs:
        log(Event("geo.fault", 0.0, 0, 0.0, "ValueError: x"))
        log(Event("geo.overrun", 1.0, 3, 120.5))
        log(Event("geo.rt_setting", 0.0, 0, 0.0, "mlockall: not permitted"))
        log(Event("lift.start", 2.0, 7, 0.1 + 0.2))
        log(Event("geo.m_ack", 2.0, 7))  # dropped
        for _ in range(3):
            log(Event("lift.override_limited", 2.0, 7, 1.5))  # once a second
    assert [(r["event"], r["log_level"]) for r in logs] == [
        ("geo.fault", "error"),
        ("geo.overrun", "warning"),
        ("geo.rt_setting", "warning"),
        ("lift.start", "info"),
        ("lift.override_limited", "info"),
    ]
    assert logs[3]["value"] == 0.3  # no float noise


def test_a_reload_names_what_needs_a_restart_against_what_runs() -> None:
    """The daemon compares a reloaded file with the configuration it started with: a port
    changed by an earlier reload still needs the restart, and a port changed back does not
    (it compared with the last accepted file: 'restart for port' came and went wrongly)."""
    running = LiftdConfig.model_validate({"ads": {"port": 48898}})
    moved = LiftdConfig.model_validate(
        {"ads": {"port": 1}, "rt": {"sched_fifo_priority": 0}, "log": {"format": "json"}}
    )
    assert needs_restart(running, running) == []
    assert needs_restart(running, moved) == ["ads.port", "rt.sched_fifo_priority", "log.format"]
    assert (
        needs_restart(
            running,
            moved.model_copy(update={"ads": running.ads, "rt": running.rt, "log": running.log}),
        )
        == []
    )


def test_a_reload_that_changes_the_live_view_needs_a_restart() -> None:
    """[ui] is read when the daemon starts (listener, control): a reload that changes it says
    so instead of seeming applied; the token a reload applies (UiHost.reloaded)."""
    running = LiftdConfig.model_validate({"ui": {"enabled": True}})
    changed = LiftdConfig.model_validate(
        {"ui": {"enabled": True, "control": True, "token": "0123456789abcdef"}}
    )
    assert needs_restart(running, changed) == ["ui.control"]
