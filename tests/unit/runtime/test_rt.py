"""The loop's real-time settings that liftd decides itself (not granted by the OS)."""

from __future__ import annotations

from liftd.runtime.rt import spin_refusal


def test_spinning_is_refused_where_the_kernel_would_throttle_a_fifo_loop() -> None:
    """With SCHED_FIFO and the kernel's real-time share limited (950 000 µs by default) a loop
    that never sleeps is stopped for the rest of each second: measured 5 % of cycles exceeded.
    liftd then sleeps and says why; without FIFO, or with the share unlimited, it may spin."""
    said = spin_refusal(True, 950_000)
    assert said is not None and "950000" in said and "50 ms" in said and "-1" in said
    assert spin_refusal(True, -1) is None
    assert spin_refusal(False, 950_000) is None
    assert spin_refusal(True, None) is None  # unknown (no /proc): as asked
