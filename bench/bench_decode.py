"""Decoder speed and memory on generated programs; one JSON line per size.

Figure to reach (issue 2): 100 000 blocks in under 2 s, memory proportional to the program.
Run: .venv/bin/python bench/bench_decode.py
"""

from __future__ import annotations

import json
import sys
import time
import tracemalloc
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench.gen import count_blocks, nesting_program
from liftd.cnc.nc import DecoderContext, decode
from liftd.settings import load_settings


def main() -> None:
    settings = load_settings(str(Path(__file__).resolve().parents[1] / "config" / "liftd.toml"))
    ctx = DecoderContext.from_channel(settings.channel)
    for parts in (715, 3572, 7143):  # ~10 000, 50 000, 100 000 blocks
        text = nesting_program(parts)
        blocks = count_blocks(text)
        runs = []
        for _ in range(3):  # best of 3: the shared 2-vCPU VM adds up to 30 % noise
            t0 = time.perf_counter()
            result = decode(text, ctx)
            runs.append(time.perf_counter() - t0)
        seconds = min(runs)
        assert result.first_error is None, result.first_error
        tracemalloc.start()
        result = decode(text, ctx)
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        print(
            json.dumps(
                {
                    "bench": "decode",
                    "blocks": blocks,
                    "decoded_blocks": len(result.blocks),
                    "seconds": round(seconds, 3),
                    "blocks_per_s": round(blocks / seconds),
                    "peak_bytes": peak,
                    "bytes_per_block": round(peak / blocks),
                }
            )
        )


if __name__ == "__main__":
    main()
