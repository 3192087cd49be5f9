"""Pause points of a program's preparation: where the work of decoding and planning a program
may be interrupted.

`liftd run` prepares a program for a START after a RESET, an NC error or a reload in a thread
of the GEO process that may run only in the loop's idle time (runtime/preparer.py): the
preparation calls `pause()` often enough (each block, each segment of a pass, each range; the
longest stretch between two calls is a figure of bench/bench_prepare.py) for that thread to
stop at the end of its slice and leave the interpreter to the loop. What the preparation
throws away in bulk goes through `release` for the same reason. `pause` does nothing
unless a hook is installed (simulate, check, study and the tests install none), and the hook
is the runtime's: the core stays without threads and clocks.

Not compiled on purpose: a call from compiled code into this interpreted function passes the
interpreter's eval breaker, where a thread waiting for the GIL gets it even without a hook.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Final

hook: Callable[[], None] | None = None
# a loop whose pass costs well under a µs (the path table's) pauses when `not k & EVERY`:
# every 64th pass, ~10–30 µs of compiled work here; loops of µs a pass pause every pass
EVERY: Final = 63


def pause() -> None:
    h = hook
    if h is not None:
        h()


RELEASE_CHUNK = 512  # objects freed between two pause points (~50 µs of deallocation here)


def release(items: list[object]) -> None:
    """Empty `items` a chunk at a time with pause points between: freeing what a program's
    preparation built and no longer needs (a decoded program's blocks, its lines) is work in
    proportion to the program too (15 ms for 70 000 blocks at once)."""
    while items:
        del items[-RELEASE_CHUNK:]
        pause()
