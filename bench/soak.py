"""Soak (issue 8): an hour at 1 ms with polling and notification clients on the repeating demo.

Reported (one JSON line): RSS of the daemon and the GEO process at start / end / max, exceeded
cycles per 10-minute window (stable?), and lift_active changes that the notification clients
missed against the run's trace (must be 0). Run: .venv/bin/python bench/soak.py [--minutes 60]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.bench_rt import one_run  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--minutes", type=float, default=60.0)
    ap.add_argument("--no-rt", action="store_true")
    args = ap.parse_args()
    rec = one_run(args.minutes, not args.no_rt, pollers=4, notifiers=4, subscriptions=20,
                  window_s=600.0)  # fmt: skip
    rec["bench"] = "soak"
    print(json.dumps(rec), flush=True)


if __name__ == "__main__":
    main()
