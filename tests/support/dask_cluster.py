"""A real Dask cluster on 127.0.0.1 for the tests and benches of `liftd study --scheduler`:
`dask scheduler` and `dask worker` processes (python -m distributed.cli.…), each worker in a
working directory of its own and, where the test may (root, `unshare -m`), in a mount
namespace where the study's library directory is an empty tmpfs: the workers cannot read the
programs, as on hosts that share no filesystem with the client."""

from __future__ import annotations

import json
import os
import shlex
import signal
import subprocess
import sys
import time
from pathlib import Path

START_TIMEOUT_S = 120.0  # the shared 2-vCPU VM under load: a scheduler took 14 s to start


def can_hide() -> bool:
    """`unshare -m` with a tmpfs mount works here (root on Linux)."""
    probe = subprocess.run(["unshare", "-m", "mount", "-t", "tmpfs", "none", "/mnt"],
                           capture_output=True, check=False)  # fmt: skip
    return probe.returncode == 0


class DaskCluster:
    """Scheduler + workers as subprocesses; `stop` ends every one of them."""

    def __init__(self, root: Path, hide: Path | None = None, env: dict[str, str] | None = None):
        self.root = root
        root.mkdir(parents=True, exist_ok=True)
        self.hide = hide if hide is not None and can_hide() else None
        self.env = dict(os.environ, **(env or {}))
        self.file = root / "scheduler.json"
        self.procs: list[subprocess.Popen[bytes]] = []
        self.workers: list[subprocess.Popen[bytes]] = []  # alive, as far as we know
        self.started = 0
        self.scheduler = self._spawn(
            ["distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", "0",
             "--no-dashboard", "--scheduler-file", str(self.file), "--idle-timeout", "600"],
            root, "scheduler",
        )  # fmt: skip
        deadline = time.monotonic() + START_TIMEOUT_S
        while not self.file.exists() or not self.file.read_text().strip().endswith("}"):
            if self.scheduler.poll() is not None or time.monotonic() > deadline:
                self.stop()
                raise RuntimeError(f"dask scheduler did not start: {self.log('scheduler')}")
            time.sleep(0.1)
        self.address: str = json.loads(self.file.read_text())["address"]

    def _spawn(self, argv: list[str], cwd: Path, name: str) -> subprocess.Popen[bytes]:
        cmd = [sys.executable, "-m", *argv]
        if self.hide is not None and name.startswith("worker"):
            hide = shlex.quote(str(self.hide))
            cmd = ["unshare", "-m", "sh", "-c",
                   f"mount -t tmpfs none {hide} && exec {shlex.join(cmd)}"]  # fmt: skip
        log = open(self.root / f"{name}.log", "wb")  # noqa: SIM115 (the process's stderr)
        proc = subprocess.Popen(cmd, cwd=cwd, env=self.env, stdout=log, stderr=log,
                                start_new_session=True)  # fmt: skip
        self.procs.append(proc)
        return proc

    def log(self, name: str) -> str:
        return (self.root / f"{name}.log").read_text(errors="replace")[-3000:]

    def add_worker(
        self, preload: Path | None = None, nanny: bool = True
    ) -> subprocess.Popen[bytes]:
        """A worker with one thread, in an empty working directory of its own."""
        self.started += 1
        k = self.started
        cwd = self.root / f"worker{k}"
        cwd.mkdir()
        argv = ["distributed.cli.dask_worker", "--scheduler-file", str(self.file),
                "--nthreads", "1", "--no-dashboard", "--host", "127.0.0.1",
                "--local-directory", str(cwd), "--death-timeout", "60",
                "--nanny" if nanny else "--no-nanny"]  # fmt: skip
        if preload is not None:
            argv += ["--preload", str(preload)]
        proc = self._spawn(argv, cwd, f"worker{k}")
        self.workers.append(proc)
        return proc

    def kill(self, proc: subprocess.Popen[bytes]) -> None:
        """SIGKILL a process and what it started (a nanny's worker)."""
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
        if proc in self.workers:
            self.workers.remove(proc)

    def stop(self) -> None:
        for proc in reversed(self.procs):
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGTERM)  # its own session: the nanny's worker too
        for proc in self.procs:
            try:
                proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait(timeout=10)
