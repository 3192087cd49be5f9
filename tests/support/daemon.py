"""`liftd run` as systemd starts it: a subprocess with a temporary configuration, its JSON log
lines collected, and a datagram socket standing in for systemd's NOTIFY_SOCKET."""

from __future__ import annotations

import contextlib
import itertools
import json
import os
import signal
import socket
import struct
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

from tests.support.paths import REPO

_ids = itertools.count(1)


def write_config(tmp: Path, *, program_file: str | None = None, **sections: dict[str, Any]) -> Path:
    """A liftd.toml in tmp using the shipped lists; `sections` override keys per section."""
    net = f"127.0.0.1.{next(_ids) % 200 + 20}.1"  # AdsLib keeps one route per NetId per process
    values: dict[str, dict[str, Any]] = {
        "cnc": {"startup_list": str(REPO / "config" / "cnc" / "hochlauf.lis")},
        "program": {
            "file": program_file or str(REPO / "config" / "programs" / "demo.nc"),
            "autostart": True,
            "repeat": False,
        },
        "ads": {"port": 0, "net_id": net},
        # tests share 2 vCPUs with pytest and pyads: no SCHED_FIFO, no PM QoS, no mlock
        "rt": {"sched_fifo_priority": 0, "hold_cpu_dma_latency": False, "lock_memory": False},
        "log": {"format": "json"},
    }
    for name, keys in sections.items():
        values.setdefault(name, {}).update(keys)
    lines = []
    for name, keys in values.items():
        lines.append(f"[{name}]")
        lines += [f"{k} = {json.dumps(v)}" for k, v in keys.items()]
    path = tmp / "liftd.toml"
    path.write_text("\n".join(lines) + "\n")
    return path


def free_port() -> int:
    """A TCP port on loopback that nobody listens on right now."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class Notify:
    """A datagram socket in tmp standing in for systemd's notification socket."""

    def __init__(self, tmp: Path) -> None:
        self.path = str(tmp / "notify.sock")
        self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        self.sock.bind(self.path)
        self.messages: list[str] = []

    def drain(self) -> list[str]:
        """Every message received so far (queued ones without waiting)."""
        try:
            while True:
                self.messages.append(self.sock.recv(4096, socket.MSG_DONTWAIT).decode())
        except BlockingIOError:
            pass
        return self.messages

    def close(self) -> None:
        self.sock.close()


def runtime_env(tmp: Path) -> dict[str, str]:
    """A RUNTIME_DIRECTORY of its own (the reload control socket), as systemd gives one."""
    runtime = tmp / "run"
    runtime.mkdir(exist_ok=True)
    return {"RUNTIME_DIRECTORY": str(runtime)}


class Daemon:
    def __init__(
        self,
        config: Path,
        *args: str,
        env: dict[str, str] | None = None,
        wrapper: list[str] | None = None,
    ) -> None:
        """`wrapper`: a command that execs the rest (e.g. to set a process attribute first)."""
        full_env = {**os.environ, "PYTHONUNBUFFERED": "1", **(env or {})}
        self.proc = subprocess.Popen(
            [*(wrapper or []), sys.executable, "-m", "liftd", "run", "-c", str(config), *args],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=full_env,
        )
        self.logs: list[dict[str, Any]] = []
        self.raw: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()
        self.port = 0
        self.net_id = ""
        for line in config.read_text().splitlines():
            if line.startswith("net_id"):
                self.net_id = json.loads(line.split("=", 1)[1])

    def _read(self) -> None:
        assert self.proc.stderr is not None
        for line in self.proc.stderr:
            self.raw.append(line)
            with contextlib.suppress(ValueError):
                self.logs.append(json.loads(line))

    def event(self, name: str, timeout: float = 15.0) -> dict[str, Any] | None:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            for rec in list(self.logs):
                if rec.get("event") == name:
                    return rec
            if self.proc.poll() is not None and not self._reader.is_alive():
                break
            time.sleep(0.02)
        return None

    def count(self, name: str) -> int:
        """How many log records of event `name` so far."""
        return sum(rec.get("event") == name for rec in list(self.logs))

    def ready(self) -> int:
        rec = self.event("daemon.ready")
        assert rec is not None, "".join(self.raw)
        self.port = int(rec["ads_port"])
        return self.port

    @property
    def address(self) -> str:
        return f"127.0.0.1:{self.port}"

    def read_symbol(self, name: str, fmt: str) -> Any:
        """One symbol by name over raw AMS/TCP (no AdsLib route involved)."""
        from liftd.ads.client import RawClient  # noqa: PLC0415
        from liftd.ads.wire import net_id_bytes  # noqa: PLC0415

        client = RawClient(self.port, net_id_bytes(self.net_id))
        try:
            code, raw = client.read_by_name(name, struct.calcsize(fmt))
        finally:
            client.close()
        assert code == 0, hex(code)
        return struct.unpack(fmt, raw)[0]

    def read_exceeded(self) -> int:
        return int(self.read_symbol("GEO.timing.exceeded", "<I"))

    def signal(self, sig: int) -> None:
        self.proc.send_signal(sig)

    def wait(self, timeout: float = 30.0) -> int:
        """The exit code of a daemon expected to exit by itself."""
        code = self.proc.wait(timeout)
        self._reader.join(5)
        return code

    def stop(self, timeout: float = 10.0) -> int:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
        try:
            code = self.proc.wait(timeout)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            code = self.proc.wait()
        self._reader.join(5)
        return code
