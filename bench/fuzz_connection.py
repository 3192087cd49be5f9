"""Longer fuzzing of one ADS connection (framer + codec + access checks + service dispatch +
notifications): the state machine of tests/unit/ads/test_connection_fuzz.py with many more
examples and random seeds. Prints one JSON line: examples, byte chunks fed, bytes, rate.

Run: .venv/bin/python bench/fuzz_connection.py [--examples 20000]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from hypothesis import HealthCheck, settings
from hypothesis.stateful import run_state_machine_as_test

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.unit.ads import test_connection_fuzz as fuzz  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--examples", type=int, default=20000)
    args = ap.parse_args()
    t0 = time.perf_counter()
    run_state_machine_as_test(
        fuzz.ConnectionMachine,
        settings=settings(
            max_examples=args.examples,
            stateful_step_count=60,
            deadline=None,
            database=None,
            derandomize=False,
            suppress_health_check=list(HealthCheck),
        ),
    )
    wall = time.perf_counter() - t0
    print(
        json.dumps(
            {
                "bench": "fuzz_connection",
                "examples": args.examples,
                "chunks": fuzz.STATS["chunks"],
                "bytes": fuzz.STATS["bytes"],
                "seconds": round(wall, 1),
                "chunks_per_s": round(fuzz.STATS["chunks"] / wall),
                "failures": 0,
            }
        )
    )


if __name__ == "__main__":
    main()
