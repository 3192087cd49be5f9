"""Waiting in integration tests for what a live daemon does in its own time: poll a condition
until a deadline instead of sleeping a fixed time a loaded machine may stretch."""

from __future__ import annotations

import time
from collections.abc import Callable


def wait_for(cond: Callable[[], bool], timeout: float = 3.0, every: float = 0.005) -> bool:
    """True as soon as `cond()` holds, False if it still does not after `timeout` s."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if cond():
            return True
        time.sleep(every)
    return cond()
