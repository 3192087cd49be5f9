"""`liftd study --scheduler` on a real Dask cluster (issue 39): a scheduler and two worker
processes on 127.0.0.1 whose working directories (and, where the test may, whose view of the
library directory) cannot read the programs; the report equals the local study's row for
row; a worker killed during a study, a program that kills every worker it runs on, an
unreachable scheduler, a worker of another liftd version, a scheduler that goes away."""

# `# fmt: skip` where it stays: ruff's one-item-per-line layout of those statements would
# take this file past the house's ~450 lines a file (the others were removed, issue 40)
from __future__ import annotations

import csv
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

distributed = pytest.importorskip("distributed")  # the cluster extra: installed by `make`

from liftd import __version__, cli  # noqa: E402
from liftd.cli.study import study_config, study_programs  # noqa: E402
from liftd.settings import load_settings  # noqa: E402
from liftd.sim import cluster as dask_study  # noqa: E402
from liftd.sim.study import ProgramResult, StudyConfig, StudyStopped  # noqa: E402
from tests.support.dask_cluster import DaskCluster  # noqa: E402
from tests.support.paths import GOLDEN, REPO  # noqa: E402

pytestmark = pytest.mark.integration
CONFIG = str(REPO / "config" / "liftd.toml")
TINY = (
    "G90 G17 G94\nG00 X10 Y10 Z1\nZ[LIFT_START POS=1 POS_LIMIT={limit}]\n"
    "G01 X{x} Y20 F24000\nZ[LIFT_END]\nM30\n"
)
SHARED = "G90 G17 G94\nG00 X{x} Y10 Z1\nL shared_hop.nc\nM30\n"  # a CAM library's shape file
SHARED_SUB = "Z[LIFT_START POS=1 POS_LIMIT=30]\nG91 G01 X80 F24000\nZ[LIFT_END]\nG90\nM17\n"
CRASH_HOOK = '''"""dask worker --preload: a program named crash*.nc kills the worker process running it
(as a crash in native code or the OOM killer would); recurse*.nc raises RecursionError, whose
traceback Dask cannot pickle (its client then never hears of the task)."""
import os

import liftd.sim.cluster as cluster

_work = getattr(cluster, "_unhooked_work", cluster.work)  # dask may load a preload twice
cluster._unhooked_work = _work


def work(settings, program, text, name, files):
    if os.path.basename(program).startswith("crash"):
        os._exit(3)
    if os.path.basename(program).startswith("recurse"):  # an exception Dask cannot pickle
        return work(settings, program, text, name, files)
    return _work(settings, program, text, name, files)


cluster.work = work
'''
OTHER_VERSION = "import liftd\n\nliftd.__version__ = '0.0.0+other'\n"


def library(root: Path) -> Path:
    """A few dozen small programs: the demo, the CAM corpus (its global subroutine file in
    lib/), programs that share one subroutine file, an NC error, bytes that are not UTF-8
    (in a comment: runs; in a word: an NC error at its line), and one-lift hops."""
    lib = root / "library"
    lib.mkdir()
    for src in [REPO / "config" / "programs" / "demo.nc", *(GOLDEN / "nc" / "cam").glob("*.nc")]:
        shutil.copy(src, lib / src.name)
    shutil.copytree(GOLDEN / "nc" / "cam" / "lib", lib / "lib")
    (lib / "lib" / "shared_hop.nc").write_text(SHARED_SUB)  # found by [nc] subroutine_dirs
    for k in range(3):
        (lib / f"calls_shared_{k}.nc").write_text(SHARED.format(x=10 + 5 * k))
    (lib / "stops_in_a_lift.nc").write_text(
        "G90 G17 G94\nG01 X10 Y10 Z1 F6000\nZ[LIFT_START POS=1 POS_LIMIT=40]\n"
        "G01 X150 F24000\nQ3\nX200\nZ[LIFT_END]\nM30\n"
    )
    (lib / "latin1_comment.nc").write_bytes(
        b"( Blech St\xe4rke 2 mm )\n"  # CP1252, as on Windows
        + TINY.format(limit=30, x=90).encode()
    )
    (lib / "latin1_word.nc").write_bytes(b"G90 G17 G94\nG01 X1\xe40 Y10 Z1 F6000\nM30\n")
    for k in range(16):
        (lib / f"hop_{k:02d}.nc").write_text(TINY.format(limit=20 + 5 * (k % 4), x=40 + 7 * k))
    return lib


def config_toml(root: Path) -> Path:
    """The shipped configuration, looking for subroutine files in the library's lib/ too."""
    config = root / "config"
    shutil.copytree(REPO / "config", config)
    toml = config / "liftd.toml"
    text = toml.read_text()
    assert "[nc]" not in text
    toml.write_text(text + f'\n[nc]\nsubroutine_dirs = ["{root / "library" / "lib"}"]\n')
    return toml


def liftd(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "liftd", *args],
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
        cwd=cwd,
    )


class Setup:
    def __init__(self, root: Path) -> None:
        self.root = root
        self.lib = library(root)
        self.toml = config_toml(root)
        (root / "crash_hook.py").write_text(CRASH_HOOK)
        env = {"DASK_DISTRIBUTED__SCHEDULER__ALLOWED_FAILURES": "0"}  # one death: KilledWorker
        self.cluster = DaskCluster(root, hide=self.lib, env=env)
        for _ in range(2):
            self.cluster.add_worker(preload=root / "crash_hook.py")

    def study(self, library: str, out: str) -> subprocess.CompletedProcess[str]:
        """`liftd study LIBRARY -c … --scheduler … --out OUT` in the test's root."""
        args = ["-c", str(self.toml), "--scheduler", self.cluster.address, "--out", out]
        return liftd("study", library, *args, cwd=self.root)

    def client(self) -> distributed.Client:
        client = distributed.Client(self.cluster.address, timeout=60, set_as_default=False)
        client.wait_for_workers(
            len([w for w in self.cluster.workers if w.poll() is None]), timeout=120
        )
        return client

    def config(self) -> StudyConfig:
        settings = load_settings(str(self.toml))
        return study_config(settings, settings.channel, 3600.0)


@pytest.fixture(scope="module")
def setup(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Setup]:
    s = Setup(tmp_path_factory.mktemp("cluster"))
    try:
        s.client().close()
        yield s
    finally:
        s.cluster.stop()


@pytest.fixture(scope="module")
def local(setup: Setup) -> dict:
    r = liftd(
        "study", "library", "-c", str(setup.toml), "--jobs", "2", "--out", "local", cwd=setup.root
    )
    assert r.returncode == 1, r.stderr  # the NC errors: rows, not the end
    return json.loads((setup.root / "local" / "report.json").read_text())


def test_the_workers_cannot_read_the_programs(setup: Setup) -> None:
    client = setup.client()
    try:
        cwd = client.run(os.getcwd)
        seen = client.run(os.path.exists, str(setup.lib / "demo.nc"))
    finally:
        client.close()
    assert len(cwd) == 2 and all(Path(d).parent == setup.root for d in cwd.values())
    assert not any(Path(d) == setup.root for d in cwd.values())  # not the client's: no paths
    if setup.cluster.hide is not None:  # root here: the library is an empty tmpfs for them
        assert not any(seen.values())


def test_the_report_equals_the_local_one_row_for_row(setup: Setup, local: dict) -> None:
    r = setup.study("library", "on_cluster")
    assert r.returncode == 1, r.stderr
    out = setup.root / "on_cluster"
    got = json.loads((out / "report.json").read_text())
    assert got["programs"] == local["programs"] and got["summary"] == local["summary"]
    assert got["study"] == local["study"]
    assert (out / "report.csv").read_text() == (setup.root / "local" / "report.csv").read_text()
    rows = {Path(row["program"]).name: row for row in got["programs"]}
    assert len(rows) == len(study_programs([str(setup.lib)])) == 28
    assert rows["two_sheets_global.nc"]["status"] == "ok"  # its lib/ file came with the task
    assert [rows[f"calls_shared_{k}.nc"]["lifts"] for k in range(3)] == [1, 1, 1]
    assert rows["latin1_comment.nc"]["status"] == "ok" and rows["latin1_comment.nc"]["lifts"] == 1
    error = rows["latin1_word.nc"]["errors"][0]
    assert (error["id"], error["line"]) == (990001, 2) and "unexpected character" in error[
        "message"
    ]
    run = got["run"]
    assert (run["scheduler"], run["workers"], run["jobs"]) == (setup.cluster.address, 2, 2)
    assert f"on the Dask cluster at {setup.cluster.address}" in r.stdout


@pytest.mark.parametrize("victims", [1, 2])
def test_a_worker_killed_during_a_study_leaves_every_program_with_a_row(
    setup: Setup, local: dict, victims: int
) -> None:
    """One worker, or both: then the settings scattered to them are lost with them, and Dask
    cancels the tasks that need them ("lost dependencies"): scattered again, run again."""
    client = setup.client()
    pids = client.run(os.getpid)  # the worker processes (their nannies start new ones)
    client.close()
    connected = dask_study.connect(setup.cluster.address, 60)
    programs = study_programs([str(setup.lib)])
    killed: list[int] = []

    def done(result: ProgramResult) -> None:
        if not killed:
            killed.extend(sorted(pids.values())[:victims])
            for pid in killed:
                os.kill(pid, signal.SIGKILL)

    try:
        rows = [
            r.row.to_json()
            for r in dask_study.run_programs(connected, programs, setup.config(), done)
        ]
    finally:
        dask_study.close(connected.client)
    assert killed
    want = {Path(row["program"]).name: row for row in local["programs"]}
    assert [Path(row["program"]).name for row in rows] == [Path(p).name for p in programs]
    for row in rows:  # run again on a live worker: the same row
        assert {**row, "program": ""} == {**want[Path(row["program"]).name], "program": ""}


def test_results_come_in_program_order_with_a_bounded_window(
    setup: Setup, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The client's bound: at most WINDOW_PER_THREAD × threads programs read and submitted
    and not yet handed on (2 with 1 per thread on the 2 workers)."""
    monkeypatch.setattr(dask_study, "WINDOW_PER_THREAD", 1)
    real_read = dask_study.read_one
    submitted: list[str] = []
    handed: list[str] = []
    held: list[int] = []

    def read(cfg, program, max_bytes=None):  # type: ignore[no-untyped-def]
        submitted.append(program)
        held.append(len(submitted) - len(handed))
        return real_read(cfg, program, max_bytes)

    monkeypatch.setattr(dask_study, "read_one", read)
    programs = study_programs([str(setup.lib)])[:8]
    setup.client().close()  # both workers back (a test before may have killed them)
    connected = dask_study.connect(setup.cluster.address, 60)
    try:
        for result in dask_study.run_programs(connected, programs, setup.config()):
            handed.append(result.row.program)
    finally:
        dask_study.close(connected.client)
    assert handed == programs == submitted and connected.threads == 2
    assert max(held) <= 2


def test_a_program_that_kills_its_worker_is_a_failed_row(setup: Setup) -> None:
    crash = setup.root / "crashing"
    crash.mkdir()
    for k in range(3):
        (crash / f"hop_{k}.nc").write_text(TINY.format(limit=30, x=50 + 10 * k))
    (crash / "crash_me.nc").write_text(TINY.format(limit=30, x=99))
    (crash / "recurse.nc").write_text(TINY.format(limit=30, x=98))
    r = setup.study("crashing", "crash_out")
    assert r.returncode == 1, r.stderr
    rows = list(csv.DictReader((setup.root / "crash_out" / "report.csv").open(newline="")))
    status = {Path(row["program"]).name: row["status"] for row in rows}
    assert status == {
        "crash_me.nc": "failed",
        "hop_0.nc": "ok",
        "hop_1.nc": "ok",
        "hop_2.nc": "ok",
        "recurse.nc": "failed",
    }
    assert "crash_me.nc: failed: the Dask workers running it died" in r.stderr
    assert "recurse.nc: failed: liftd failed: RecursionError: maximum recursion depth" in r.stderr


def _junk_server() -> tuple[socket.socket, int]:
    """A TCP peer that is no Dask scheduler: an HTTP error to every connection."""
    srv = socket.create_server(("127.0.0.1", 0))

    def serve() -> None:
        while True:
            try:
                conn, _ = srv.accept()
            except OSError:
                return
            with conn:
                conn.sendall(b"HTTP/1.1 400 Bad Request\r\n\r\n" * 4)

    threading.Thread(target=serve, daemon=True).start()
    return srv, srv.getsockname()[1]


def test_an_unreachable_scheduler_is_exit_2_within_the_timeout(tmp_path: Path) -> None:
    demo = str(REPO / "config" / "programs" / "demo.nc")
    with socket.socket() as s:  # a port nothing listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    srv, junk = _junk_server()
    try:
        for address, says in (
            (f"tcp://127.0.0.1:{port}", "Timed out trying to connect"),
            (f"tcp://127.0.0.1:{junk}", "does not answer as a Dask scheduler"),
            ("tcp://127.0.0.1", "not a scheduler address"),
        ):
            t0 = time.monotonic()
            r = liftd(
                "study",
                demo,
                "-c",
                CONFIG,
                "--scheduler",
                address,
                "--timeout",
                "2",
                "--out",
                "out",
                cwd=tmp_path,
            )
            assert r.returncode == 2, r.stderr
            assert f"cannot reach the Dask scheduler at {address} within 2 s" in r.stderr or (
                "not a scheduler address" in r.stderr
            )
            assert says in r.stderr and "Traceback" not in r.stderr
            assert time.monotonic() - t0 < 60  # start-up, 2 s, closing: bounded
    finally:
        srv.close()
    assert not (tmp_path / "out").exists()


def test_without_the_cluster_extra_the_option_says_how_to_install_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import liftd.sim  # noqa: PLC0415

    monkeypatch.delattr(liftd.sim, "cluster", raising=False)
    monkeypatch.setitem(sys.modules, "liftd.sim.cluster", None)  # as if distributed were absent
    demo = str(REPO / "config" / "programs" / "demo.nc")
    code = cli.main(
        [
            "study",
            demo,
            "-c",
            CONFIG,
            "--scheduler",
            "tcp://127.0.0.1:1",
            "--timeout",
            "1",
            "--out",
            str(tmp_path / "out"),
        ]
    )
    assert code == 2 and "pip install 'liftd[cluster]'" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_a_worker_of_another_liftd_version_is_refused(setup: Setup) -> None:
    (setup.root / "other_version.py").write_text(OTHER_VERSION)
    good = list(setup.cluster.workers)
    setup.cluster.add_worker(preload=setup.root / "other_version.py")
    setup.client().close()  # all three joined
    r = setup.study("library", "mixed")
    assert r.returncode == 2, r.stderr
    assert f"runs liftd 0.0.0+other, this client liftd {__version__}" in r.stderr
    assert not (setup.root / "mixed").exists()
    # one that joins after the check: its tasks refuse to run, the study stops, no row of it
    for proc in good:
        setup.cluster.kill(proc)
    client = setup.client()
    late = dask_study.Cluster(client, setup.cluster.address, 1, 1)  # as connected before it
    try:
        with pytest.raises(StudyStopped) as stop:
            list(dask_study.run_programs(late, study_programs([str(setup.lib)]), setup.config()))
    finally:
        dask_study.close(client)
    assert not stop.value.lost and stop.value.results == []
    assert f"runs liftd 0.0.0+other, this client liftd {__version__}" in str(stop.value)


def test_a_scheduler_that_goes_away_leaves_the_rows_so_far_and_exit_3(
    setup: Setup, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    for proc in list(setup.cluster.workers):
        setup.cluster.kill(proc)  # the other version's
    setup.cluster.add_worker()
    setup.client().close()
    real = dask_study.run_programs
    seen: list[ProgramResult] = []

    def killing(c, programs, cfg, on_done):  # type: ignore[no-untyped-def]
        def done(result: ProgramResult) -> None:
            on_done(result)
            seen.append(result)
            if len(seen) == 3:
                setup.cluster.kill(setup.cluster.scheduler)

        return real(c, programs, cfg, done)

    monkeypatch.setattr(dask_study, "run_programs", killing)
    out = setup.root / "lost"
    code = cli.main(["study", str(setup.lib), "-c", str(setup.toml), "--scheduler",
                     setup.cluster.address, "--out", str(out)])  # fmt: skip
    err = capsys.readouterr().err
    assert code == 3, err
    assert f"the Dask scheduler at {setup.cluster.address} went away" in err
    report = json.loads((out / "report.json").read_text())  # written to the end: valid JSON
    rows = report["programs"]
    assert 3 <= len(rows) < 28 and "went away" in report["run"]["stopped"]
    assert len(list(csv.DictReader((out / "report.csv").open(newline="")))) == len(rows)
