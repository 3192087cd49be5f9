"""structlog configuration, done once by the CLI: JSON lines on stderr when not a TTY (journald,
docker logs), console lines otherwise (coloured on a TTY unless NO_COLOR is set); stable
dotted event names.

Logging never blocks serving: a line is rendered where it is logged and handed to a bounded
queue without waiting; one writer thread does the blocking writes. When stderr is a pipe nobody
reads (journald busy, `liftd run | less` paused, a stuck container log driver), the queue fills
and further lines are dropped and counted (`dropped()`: a metric and the ADS symbol
GEO.ads.log_dropped); once the writer gets through again it logs `log.dropped` with the count.
When stderr is the journal stream systemd names in `$JOURNAL_STREAM` (its device:inode, as
systemd.exec(5) says to compare: the variable is inherited by processes whose stderr goes
elsewhere) every line starts with its syslog priority `<N>` (sd-daemon(3)), so `journalctl -p
warning` selects by level.
"""

from __future__ import annotations

import logging
import os
import sys
import threading
from collections import deque
from collections.abc import Mapping
from typing import Any, TextIO

import structlog

LEVELS = {
    "debug": logging.DEBUG,
    "info": logging.INFO,
    "warning": logging.WARNING,
    "error": logging.ERROR,
}
# syslog priorities of structlog's method names (sd-daemon(3): SD_ERR "<3>", SD_WARNING "<4>")
PRIORITY = {
    "debug": 7,
    "info": 6,
    "msg": 6,
    "warning": 4,
    "warn": 4,
    "error": 3,
    "err": 3,
    "exception": 3,
    "critical": 2,
    "fatal": 2,
}
DEFAULT_QUEUE_LINES = 10_000


class LineQueue:
    """Lines on their way to a stream: `put` never blocks; a thread writes them, in batches (a
    burst of lines costs one wake-up and one write, not one each)."""

    def __init__(self, stream: TextIO, capacity: int) -> None:
        self.stream = stream
        try:  # a blocked write must hold no lock of the stream object: write to its fd
            self._fd: int | None = stream.fileno()
        except (OSError, ValueError):  # no file descriptor (a test's StringIO)
            self._fd = None
        self.capacity = capacity
        self._lines: deque[str] = deque()  # append/popleft are atomic: no lock on the way in
        self._ready = threading.Event()  # set when lines wait (or at stop)
        self._stop = False
        self._dropped = 0  # counted by the logging threads, read by the writer (ints: atomic)
        self._reported = 0
        self._closed = False
        self._thread = threading.Thread(target=self._write, name="liftd-log", daemon=True)
        self._thread.start()

    def put(self, line: str) -> None:
        if self._closed:  # after flush (the process is ending): write it directly
            self._write_lines([line])
            return
        if len(self._lines) >= self.capacity:
            self._dropped += 1
            return
        self._lines.append(line)
        if not self._ready.is_set():
            self._ready.set()

    @property
    def dropped(self) -> int:
        return self._dropped

    def _write(self) -> None:
        lines = self._lines
        while True:
            self._ready.wait()
            self._ready.clear()
            batch = [lines.popleft() for _ in range(len(lines))]
            wrote = self._write_lines(batch) if batch else False
            # report drops only once a write got through: on a broken stream the report is
            # dropped too, and reporting that was a loop (68 % of a CPU in a daemon whose
            # stderr reader had gone, 13 000 failed writes a second)
            if wrote and self._dropped != self._reported and not lines:
                held, self._reported = self._dropped - self._reported, self._dropped
                structlog.get_logger("liftd").warning(
                    "log.dropped", lines=held, total=self._dropped
                )
            if self._stop and not lines:
                return

    def _write_lines(self, batch: list[str]) -> bool:
        """Blocking write; False when the stream is closed or broken. Through the fd, not
        `stream.write`: a writer blocked inside the stream's buffer would keep its lock, and
        the interpreter aborts at exit ("could not acquire lock for <stderr> at interpreter
        shutdown")."""
        text = "".join(line + "\n" for line in batch)
        try:
            if self._fd is None:
                self.stream.write(text)
                self.stream.flush()
                return True
            data = text.encode("utf-8", "replace")
            while data:
                data = data[os.write(self._fd, data) :]
        except (OSError, ValueError):  # stream closed or broken: count the lines as dropped
            self._dropped += len(batch)
            return False
        return True

    def flush(self, timeout_s: float) -> None:
        """Write what is queued, waiting at most `timeout_s` (a blocked stream stays blocked:
        the rest is dropped with the process). Logging after this is written unbuffered."""
        self._stop = True
        self._ready.set()
        self._thread.join(timeout_s)
        self._closed = not self._thread.is_alive()


class QueueLogger:
    """structlog's PrintLogger interface, writing through a LineQueue."""

    def __init__(self, lines: LineQueue) -> None:
        self._lines = lines

    def msg(self, message: str) -> None:
        self._lines.put(message)

    log = debug = info = warn = warning = err = error = critical = fatal = exception = msg


_lines: LineQueue | None = None


def dropped() -> int:
    """Log lines dropped since start because the writer could not keep up."""
    return _lines.dropped if _lines is not None else 0


def flush(timeout_s: float = 1.0) -> None:
    if _lines is not None:
        _lines.flush(timeout_s)


def _priority_prefix(logger: Any, method: str, line: str) -> str:
    return f"<{PRIORITY.get(method, 6)}>{line}"


def _to_journal(out: TextIO, journal_stream: str) -> bool:
    """`out` is the stream systemd connected to the journal: its "device:inode" is the value
    of $JOURNAL_STREAM (inherited, the variable outlives a redirection)."""
    try:
        st = os.fstat(out.fileno())
    except (OSError, ValueError):  # no file descriptor (a test's StringIO)
        return False
    return journal_stream == f"{st.st_dev}:{st.st_ino}"


def configure(
    level: str = "info",
    fmt: str = "auto",
    queue_lines: int = DEFAULT_QUEUE_LINES,
    stream: TextIO | None = None,
    env: Mapping[str, str] | None = None,
) -> None:
    """Set up structlog for the daemon (`stream`/`env` default to stderr and os.environ)."""
    global _lines  # noqa: PLW0603  # one writer per process, like structlog's own config
    out = stream if stream is not None else sys.stderr
    env = env if env is not None else os.environ
    tty = out.isatty()
    json_lines = fmt == "json" or (fmt == "auto" and not tty)
    renderer: Any = (
        structlog.processors.JSONRenderer()
        if json_lines
        else structlog.dev.ConsoleRenderer(colors=tty and not env.get("NO_COLOR"))
    )
    processors: list[Any] = [
        structlog.processors.add_log_level,
        structlog.processors.TimeStamper(fmt="iso", utc=True),
        structlog.processors.format_exc_info,
        renderer,
    ]
    if _to_journal(out, env.get("JOURNAL_STREAM", "")):
        processors.append(_priority_prefix)
    if _lines is not None:
        _lines.flush(0.5)
    _lines = LineQueue(out, queue_lines)
    lines = _lines
    structlog.configure(
        processors=processors,
        wrapper_class=structlog.make_filtering_bound_logger(LEVELS[level]),
        logger_factory=lambda *args: QueueLogger(lines),
        cache_logger_on_first_use=True,
    )
