"""The daemon's log path: never blocks the caller, drops and counts when the writer is stuck,
syslog priority prefixes under journald, no colours for NO_COLOR or a non-TTY. Each case runs
`logs.configure` in a fresh interpreter (structlog's configuration is process-wide)."""

from __future__ import annotations

import io
import json
import os
import subprocess
import sys
import threading

from liftd.service.logs import LineQueue
from tests.support.paths import REPO

SCRIPT = """
import sys, structlog
from liftd.service import logs
fmt = sys.argv[1]
logs.configure("info", fmt)
log = structlog.get_logger("t")
log.info("t.info", n=1)
log.warning("t.warning", n=2)
log.error("t.error", n=3)
logs.flush(5.0)
"""


def run(fmt: str, journal: bool = False, **env: str) -> list[str]:
    """The script's stderr lines; `journal`: JOURNAL_STREAM names its stderr pipe, as systemd
    sets it for a unit whose stderr is the journal."""
    clean = {k: v for k, v in os.environ.items() if k not in ("JOURNAL_STREAM", "NO_COLOR")}
    read_end, write_end = os.pipe()
    if journal:
        st = os.fstat(write_end)
        env = {**env, "JOURNAL_STREAM": f"{st.st_dev}:{st.st_ino}"}
    with os.fdopen(read_end) as out:
        proc = subprocess.Popen(
            [sys.executable, "-c", SCRIPT, fmt],
            stderr=write_end,
            env={**clean, **env},
            cwd=REPO,
            text=True,
        )
        os.close(write_end)
        text = out.read()
    assert proc.wait(60) == 0, text
    return text.splitlines()


def test_journald_gets_syslog_priority_prefixes() -> None:
    lines = run("json", journal=True)
    assert [line[:3] for line in lines] == ["<6>", "<4>", "<3>"]
    assert '"event": "t.warning"' in lines[1]
    assert not any(line.startswith("<") for line in run("json"))  # not under journald


def test_an_inherited_journal_stream_with_stderr_elsewhere_keeps_plain_json_lines() -> None:
    """$JOURNAL_STREAM outlives a redirection (`liftd run 2>log.jsonl` in a shell that a
    systemd unit started, a desktop terminal): it names another stream, so no `<N>` prefix,
    which made every line invalid JSON (systemd.exec(5): compare device and inode)."""
    lines = run("json", JOURNAL_STREAM="8:1234")
    assert len(lines) == 3 and [json.loads(line)["event"] for line in lines] == [
        "t.info",
        "t.warning",
        "t.error",
    ]


def test_no_colour_for_no_color_and_for_a_pipe() -> None:
    for lines in (run("console", NO_COLOR="1"), run("console")):  # stderr is a pipe here
        assert len(lines) == 3 and not any("\x1b[" in line for line in lines)
        assert "t.warning" in lines[1]


def test_a_blocked_writer_drops_and_counts_without_blocking() -> None:
    class Stuck(io.StringIO):
        gate = threading.Event()

        def write(self, s: str) -> int:
            self.gate.wait(10)  # the reader of the pipe is away
            return super().write(s)

    out = Stuck()
    lines = LineQueue(out, 100)
    for i in range(1000):  # returns at once although nothing gets written
        lines.put(f"line {i}")
    held = lines.dropped
    assert 800 <= held <= 900  # 100 queued, the first batch taken by the stuck writer
    Stuck.gate.set()
    lines.flush(5.0)
    written = out.getvalue().splitlines()
    assert written[0] == "line 0" and len(written) + lines.dropped == 1000


BROKEN = """
import os, sys, structlog
from liftd.service import logs
r, w = os.pipe()
os.close(r)  # the reader has gone (a supervisor restarted, `liftd run | head` ended)
logs.configure("info", "json", stream=os.fdopen(w, "w"))
structlog.get_logger("t").info("t.info")
logs.flush(5.0)
print(logs.dropped(), logs._lines._closed)
"""


def test_a_broken_stream_drops_its_lines_once_and_the_writer_rests() -> None:
    """Until 2026-12-02 the writer reported each drop in a log line that was dropped in turn:
    a loop of failed writes at 68 % of a CPU for as long as the daemon ran."""
    r = subprocess.run(
        [sys.executable, "-c", BROKEN],
        capture_output=True,
        text=True,
        cwd=REPO,
        timeout=60,
        check=False,
    )
    assert r.returncode == 0, r.stderr
    assert r.stdout.split() == ["1", "True"]  # one line dropped; flush found the writer done
