"""The attack cases of tests/attacks.py against one running daemon: each gets exactly its
expected reply or close; afterwards a well-behaved client is still served with normal latency,
the daemon's memory stays bounded and the GEO loop did not miss its deadlines for it."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from liftd.daemon import rss_mb
from tests.attacks import ATTACK_ADS, CASES, Case, probe_ms
from tests.daemon_helper import Daemon, write_config

pytestmark = pytest.mark.integration


@pytest.fixture(scope="module")
def daemon(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Daemon]:
    tmp: Path = tmp_path_factory.mktemp("attacks")
    # SCHED_FIFO where permitted: then the GEO loop must not notice the attacks at all
    cfg = write_config(tmp, program={"repeat": True}, ads=ATTACK_ADS,
                       rt={"sched_fifo_priority": 80})  # fmt: skip
    d = Daemon(cfg)
    d.ready()
    yield d
    assert d.stop() == 0


def fifo(d: Daemon) -> bool:
    return any(rec.get("text", "").startswith("sched_fifo: ok") for rec in d.logs)


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_attack(daemon: Daemon, case: Case) -> None:
    rss0 = rss_mb(daemon.proc.pid) or 0.0
    exceeded0 = daemon.read_exceeded()
    assert case.run(daemon) == case.expected
    assert daemon.proc.poll() is None
    assert probe_ms(daemon) < 20.0  # p99 of a normal client right after (≈ 0.2 ms normally)
    if fifo(daemon):
        assert daemon.read_exceeded() - exceeded0 <= 2  # the loop did not feel it
    assert (rss_mb(daemon.proc.pid) or 0.0) - rss0 < 20.0
