"""`run --trace` against `simulate`: the schedule of the demo's PLC writes (override 50 %, a
feed hold, override 125 %) as the GEO loop logged them (geo.plc_input, the cycle each took
effect in), replayed by `liftd simulate`, whose trace must equal the run's. Shared by the
ADS writes' test (test_daemon.py) and the live view's (test_ui.py)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path
from typing import Any

# (seconds to wait, symbol, value) written during the demo
WRITES = [(1.0, "PLC.ch1.override", 500), (1.5, "PLC.ch1.feed_hold", True),
          (0.4, "PLC.ch1.feed_hold", False), (1.0, "PLC.ch1.override", 1250)]  # fmt: skip


def simulate_logged_writes(logs: list[dict[str, Any]], cfg: Path, tmp: Path
                           ) -> tuple[list[str], int]:  # fmt: skip
    """The trace `simulate` writes with the writes `logs` show took effect, and the cycle of
    the last write."""
    inputs = [(round(r["t"] * 1000), r["text"], r["value"]) for r in logs
              if r.get("event") == "geo.plc_input"]  # fmt: skip
    assert [(name, value) for _, name, value in inputs] == [
        ("override", 0.5), ("feed_hold", 1.0), ("feed_hold", 0.0), ("override", 1.25)
    ]  # fmt: skip
    (k_ov1, _, _), (k_hold, _, _), (k_free, _, _), (k_ov2, _, _) = inputs

    def at(k: int) -> str:  # between cycle k − 1 and cycle k
        return f"{(k - 0.5) / 1000:.4f}"

    sim = tmp / "sim.csv"
    demo = Path(cfg.read_text().split('file = "')[1].split('"')[0])
    r = subprocess.run([sys.executable, "-m", "liftd", "simulate", str(demo), "-c", str(cfg),
                        "--override", f"{at(k_ov1)}:50,{at(k_ov2)}:125",
                        "--feedhold", f"{at(k_hold)}:{(k_free - k_hold) / 1000:.4f}",
                        "--trace", str(sim)], capture_output=True, text=True, timeout=120,
                       check=False)  # fmt: skip
    assert r.returncode == 0, r.stderr
    return sim.read_text().splitlines(), k_ov2


def first_difference(got: list[str], expected: list[str], k_last: int) -> int | None:
    """The first row where the run's trace differs from simulate's (None: identical)."""
    assert len(got) >= len(expected) > k_last + 1000  # every write fell inside the program
    return next(
        (i for i, (a, b) in enumerate(zip(got[: len(expected)], expected, strict=True)) if a != b),
        None,
    )
