"""Run by a test inside a network namespace of its own (`unshare -rn`), where the loopback is
the namespace's: `liftd run` on a configuration whose [ads] is left out, then one read of
GEO.ch1.state at the defaults (127.0.0.1:48898, NetId 127.0.0.1.1.1). The host's port 48898
is never touched, whatever runs there. Prints one JSON line for the test to check."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from tests.support.daemon import Daemon

DEFAULT_PORT, DEFAULT_NET_ID = 48898, "127.0.0.1.1.1"


def private_network() -> str | None:
    """None when a private network namespace can be had here, else why not."""
    try:
        r = subprocess.run(
            ["unshare", "-rn", "ip", "link", "set", "lo", "up"],
            capture_output=True,
            text=True,
            timeout=10,
            check=False,
        )
    except (OSError, subprocess.TimeoutExpired) as exc:
        return f"unshare/ip: {exc}"
    return None if r.returncode == 0 else f"unshare -rn: {r.stderr.strip()}"


def main(config: Path) -> None:
    subprocess.run(["ip", "link", "set", "lo", "up"], check=True)  # a new namespace's lo is down
    d = Daemon(config)
    d.net_id = DEFAULT_NET_ID
    port = state = None
    try:
        port = d.ready()
        state = d.read_symbol("GEO.ch1.state", "<I")
    finally:
        code = d.stop()
    print(
        json.dumps(
            {
                "port": port,
                "state": state,
                "exit": code,
                "pid": d.proc.pid,
                "stderr": "".join(d.raw),
            }
        )
    )


if __name__ == "__main__":
    main(Path(sys.argv[1]))
