"""Freeing what the GEO cycle let go of a few items a cycle, not at once.

Freeing a container of hundreds of objects in one cycle costs tens of µs (a discarded queue of
~600 entries ~50 µs; a 500-part run's lift records ~70 µs hot, several times that cold). What
an event or a START lets go of is put in `ReleaseBins` instead and freed RELEASE_PER_CYCLE
items a cycle, oldest bin first. The items are gone a few cycles later; nothing reads them.
"""

from __future__ import annotations

from collections import deque
from typing import Any

# More than the producer makes per cycle, so what an event discards is gone a few cycles later.
RELEASE_PER_CYCLE = 8


class ReleaseBins:
    """Containers (lists, deques, dicts) emptied a few items a cycle by `release`."""

    def __init__(self) -> None:
        self.bins: deque[Any] = deque()

    def put(self, items: list[Any] | deque[Any] | dict[Any, Any]) -> None:
        if items:
            self.bins.append(items)

    def take_from(self, other: ReleaseBins) -> None:
        """Move another's bins here (a retired interpolator's discarded futures)."""
        bins = other.bins
        while bins:
            self.bins.append(bins.popleft())

    def release(self, n: int = RELEASE_PER_CYCLE) -> None:
        bins = self.bins
        while n > 0 and bins:
            b = bins[0]
            if not b:
                bins.popleft()
            elif isinstance(b, dict):
                b.popitem()
                n -= 1
            else:
                b.pop()
                n -= 1

    def __bool__(self) -> bool:
        return bool(self.bins)
