"""A progress bar for long runs on a terminal: one line on stderr, redrawn in place at most
every MIN_INTERVAL_S seconds (and always at the first and the last step). Where the stream is
not a terminal (a log, a pipe, CI) it writes nothing: the command's own output says what ran.

No dependency: a study needs a count, a bar, the failures so far and an estimate of the time
left, which fits in 40 lines (tqdm would add a package for that).
"""

from __future__ import annotations

import shutil
import time
from typing import TextIO

MIN_INTERVAL_S = 0.1


class ProgressBar:
    def __init__(self, total: int, stream: TextIO, unit: str = "programs") -> None:
        self.total = total
        self.stream = stream
        self.unit = unit
        self.enabled = stream.isatty()
        self.done = 0
        self.failed = 0
        self._t0 = time.monotonic()
        self._drawn = -MIN_INTERVAL_S

    def advance(self, failed: bool = False) -> None:
        """One more item finished (`failed`: it counts among the failures shown)."""
        self.done += 1
        self.failed += failed
        now = time.monotonic()
        if self.enabled and (self.done in (1, self.total) or now - self._drawn >= MIN_INTERVAL_S):
            self._drawn = now
            self.stream.write("\r" + self.line(now - self._t0))
            self.stream.flush()

    def line(self, elapsed: float) -> str:
        """The bar as drawn after `elapsed` seconds, fitted to the terminal's width."""
        share = self.done / self.total if self.total else 1.0
        left = elapsed / self.done * (self.total - self.done) if self.done else 0.0
        text = (
            f" {self.done}/{self.total} {self.unit}"
            + (f", {self.failed} with errors" if self.failed else "")
            + f"  {elapsed:.0f} s, {left:.0f} s left"
        )
        width = max(10, min(40, shutil.get_terminal_size().columns - len(text) - 3))
        full = round(share * width)
        return f"[{'#' * full}{'.' * (width - full)}]{text}"

    def close(self) -> None:
        """End the bar's line (the next output starts on a line of its own)."""
        if self.enabled and self.done:
            self.stream.write("\n")
            self.stream.flush()
