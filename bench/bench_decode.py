"""Decoder speed and memory; one JSON line per figure.

Figures (issues 2 and 19):
* plain blocks: 100 000 in under 2 s, memory proportional to the program (`decode`, blocks kept);
* executed blocks of a CAM-shaped job with subroutines and expressions (every coordinate an
  expression, a local subroutine per placement, lifted travels): 100 000 in under 2 s; the same
  job kerf-compensated (G41/G40) for reference;
* the decoder's own memory is bounded by the program text, not by its expansion: a text of
  fixed size repeated with L SEQUENCE to 10 000 … 300 000 executed blocks, decoded as a stream
  (`iter_decode`, blocks not kept): the peak stays flat.

Speed is best of 5 (the 2-vCPU VM is shared: ±25 % between runs).
Run: .venv/bin/python bench/bench_decode.py
"""

from __future__ import annotations

import dataclasses
import gc
import json
import sys
import time
import tracemalloc
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench.cli import parser
from liftd.cnc.nc import DecoderContext, decode
from liftd.cnc.nc.decoder import iter_decode
from liftd.settings import load_settings
from tests.support.programs import (
    count_blocks,
    nesting_program,
    repeated_program,
    subroutine_program,
)


def best_of(n: int, fn: object) -> float:
    assert callable(fn)
    runs = []
    for _ in range(n):
        gc.collect()
        t0 = time.perf_counter()
        fn()
        runs.append(time.perf_counter() - t0)
    return min(runs)


def main() -> None:
    parser(__doc__).parse_args()
    settings = load_settings(str(Path(__file__).resolve().parents[1] / "config" / "liftd.toml"))
    ctx = DecoderContext.from_channel(settings.channel)
    for parts in (715, 3572, 7143):  # ~10 000, 50 000, 100 000 blocks
        text = nesting_program(parts)
        blocks = count_blocks(text)
        seconds = best_of(5, lambda t=text: decode(t, ctx))
        tracemalloc.start()
        result = decode(text, ctx)
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        assert result.first_error is None, result.first_error
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

    for kerf in (False, True):  # 6667 placements x 15 blocks = 100 005 executed blocks
        text = subroutine_program(6667, kerf=kerf)
        result = decode(text, ctx)
        assert result.first_error is None, result.first_error
        seconds = best_of(5, lambda t=text: decode(t, ctx))
        print(
            json.dumps(
                {
                    "bench": "decode_subroutines",
                    "kerf_compensation": kerf,
                    "program_lines": text.count("\n"),
                    "executed_blocks": len(result.blocks),
                    "executed_lines": result.executed_lines,
                    "seconds": round(seconds, 3),
                    "blocks_per_s": round(len(result.blocks) / seconds),
                }
            )
        )

    channel = dataclasses.replace(settings.channel, max_executed_blocks=20_000_000)
    stream_ctx = DecoderContext.from_channel(channel)
    for placements in (700, 7000, 20000):  # 10 500, 105 000, 300 000 executed blocks
        text = repeated_program(placements)
        gc.collect()
        tracemalloc.start()
        stream, decoder = iter_decode(text, stream_ctx)
        count = sum(1 for _ in stream)
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        errors = decoder.result(()).errors
        assert not errors, errors
        print(
            json.dumps(
                {
                    "bench": "decode_stream_memory",
                    "program_bytes": len(text),
                    "executed_blocks": count,
                    "peak_bytes": peak,
                }
            )
        )


if __name__ == "__main__":
    main()
