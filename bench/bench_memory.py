"""Memory of `liftd run` (issue 17): RSS of the daemon and of the GEO process (with VmLck, what
mlockall holds), sampled right after READY and then every --every seconds for --minutes, one
JSON line per sample and a summary line.

The daemon runs as systemd would start it, on the shipped demo (repeating), with the RT
settings on (SCHED_FIFO 80, mlockall, /dev/cpu_dma_latency: run as root for them to take
effect, else they are refused and VmLck stays 0), no --trace, and a light client load: one
pyads client polling lift_active at 100 Hz and one holding 10 on-change notifications.

Targets: GEO process ≤ 40 MiB, daemon ≤ 60 MiB, at start and after 10 minutes.
Run: .venv/bin/python bench/bench_memory.py --minutes 10
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench import load  # noqa: E402
from bench.bench_ads import RT_ON  # noqa: E402
from tests.support.daemon import Daemon, write_config  # noqa: E402


def status(pid: int) -> dict[str, float]:
    """VmRSS, VmLck, VmHWM in MiB from /proc/PID/status."""
    out: dict[str, float] = {}
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        key, _, value = line.partition(":")
        if key in ("VmRSS", "VmLck", "VmHWM"):
            out[key] = round(int(value.split()[0]) / 1024, 1)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, default=10.0)
    ap.add_argument("--every", type=float, default=60.0, help="seconds between samples")
    args = ap.parse_args()
    seconds = args.minutes * 60
    with tempfile.TemporaryDirectory() as tmp:
        cfg = write_config(Path(tmp), program={"repeat": True}, rt=RT_ON)
        d = Daemon(cfg)
        try:
            d.ready()
            (geo,) = subprocess.run(
                ["pgrep", "-P", str(d.proc.pid), "-f", "liftd.runtime"],
                capture_output=True,
                text=True,
                check=True,
            ).stdout.split()
            rt = [r["text"] for r in d.logs if r.get("event") == "geo.rt_setting"]
            procs, out = load.start(d.net_id, d.address, seconds + 5, 1, 100.0, 1, 10, 10)
            t0 = time.monotonic()
            samples = []
            while True:
                t = time.monotonic() - t0
                sample = {"t_s": round(t), "daemon": status(d.proc.pid), "geo": status(int(geo))}
                samples.append(sample)
                print(json.dumps(sample), flush=True)
                if t >= seconds:
                    break
                time.sleep(min(args.every, max(0.0, seconds - t)))
            load.collect(procs, out, 120.0)
        finally:
            d.stop()
        first, last = samples[0], samples[-1]
        print(
            json.dumps(
                {
                    "figure": "rss_mib",
                    "minutes": args.minutes,
                    "rt_settings": rt,
                    "daemon_start": first["daemon"]["VmRSS"],
                    "daemon_end": last["daemon"]["VmRSS"],
                    "geo_start": first["geo"]["VmRSS"],
                    "geo_end": last["geo"]["VmRSS"],
                    "geo_locked_end": last["geo"].get("VmLck"),
                    "targets": {"geo": 40, "daemon": 60},
                }
            )
        )


if __name__ == "__main__":
    main()
