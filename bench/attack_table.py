"""The attack cases of tests/support/attacks.py against a running daemon, one JSON line per case with
its outcome, the p99 latency of a normal client right after it, the GEO exceed count it caused
and the daemon's RSS growth (the table of docs/figures.md, "Hardening"). Run: .venv/bin/python bench/attack_table.py
"""

from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from liftd.runtime.geo_process import rss_mb  # noqa: E402
from tests.support.attacks import ATTACK_ADS, CASES, probe_ms  # noqa: E402
from tests.support.daemon import Daemon, write_config  # noqa: E402


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        cfg = write_config(
            Path(tmp), program={"repeat": True}, ads=ATTACK_ADS, rt={"sched_fifo_priority": 80}
        )
        d = Daemon(cfg)
        try:
            d.ready()
            base_ms = probe_ms(d)
            for case in CASES:
                rss0, exc0 = rss_mb(d.proc.pid) or 0.0, d.read_exceeded()
                outcome = case.run(d)
                print(
                    json.dumps(
                        {
                            "case": case.name,
                            "outcome": outcome,
                            "expected": case.expected,
                            "probe_p99_ms": round(probe_ms(d), 3),
                            "probe_p99_ms_before": round(base_ms, 3),
                            "geo_exceeded": d.read_exceeded() - exc0,
                            "rss_growth_mb": round((rss_mb(d.proc.pid) or 0.0) - rss0, 1),
                        }
                    ),
                    flush=True,
                )
        finally:
            d.stop()


if __name__ == "__main__":
    main()
