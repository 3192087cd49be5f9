"""`liftd study`'s parts: the worker's result per program, the pool (order, bounded window,
a worker that dies), the aggregates in bounded memory, and the progress bar."""

from __future__ import annotations

import io
import os
from pathlib import Path

import pytest

from liftd.cnc.params import NcFile, NcSources
from liftd.sim import report, study
from liftd.sim.progress import ProgressBar
from liftd.sim.study import ProgramResult, ProgramRow, RunSettings, Status, StudyConfig
from tests.support.channel import make_channel

PROGRAM = (
    "G90 G17 G94\nG00 X10 Y10 Z1\nM04\nG01 X20 F6000\nM05\n"
    "Z[LIFT_START POS=1 POS_LIMIT=30]\nG01 X{x} F24000\nZ[LIFT_END]\nM30\n"
)


def sources(path: Path, text: str) -> NcSources:
    """The study's `read_sources`, without files."""
    return NcSources(str(path))


def dying_sources(path: Path, text: str) -> NcSources:
    """Kills its worker process for programs named die*.nc (a crash in native code)."""
    if path.name.startswith("die"):
        os._exit(3)
    return NcSources(str(path))


def failing_sources(path: Path, text: str) -> NcSources:
    raise ZeroDivisionError("a bug")


def config(read: study.Sources = sources, max_time: float = 60.0) -> StudyConfig:
    return StudyConfig(RunSettings(make_channel(), 0.02, max_time), read)


def library(tmp_path: Path, n: int, name: str = "p{k:02d}.nc") -> list[str]:
    out = []
    for k in range(n):
        path = tmp_path / name.format(k=k)
        path.write_text(PROGRAM.format(x=60 + 20 * k))
        out.append(str(path))
    return out


def test_a_program_becomes_one_row_of_its_comparison(tmp_path: Path) -> None:
    (program,) = library(tmp_path, 1)
    result = study.run_one(config(), program)
    row = result.row
    assert (row.status, row.lifts, row.compared, row.errors) == (Status.OK, 1, 1, ())
    assert row.clearance_advanced_mm is not None and row.clearance_lifting_mm is not None
    assert row.clearance_ratio_mean == pytest.approx(
        row.clearance_advanced_mm / row.clearance_lifting_mm, rel=1e-5
    )
    assert result.ratios == (row.clearance_ratio_mean,) and len(result.points) == 1
    assert result.max_rss_kib > 0
    csv_row = dict(zip(study.COLUMNS, row.csv_row(), strict=True))
    assert csv_row["status"] == "ok" and csv_row["errors"] == "0" and csv_row["why"] == ""
    assert row.to_json()["errors"] == []


def test_unreadable_programs_and_failures_of_liftd_are_rows(tmp_path: Path) -> None:
    row = study.run_one(config(), str(tmp_path / "none.nc")).row
    assert row.status is Status.UNREADABLE and "cannot read program" in row.why
    (program,) = library(tmp_path, 1)
    row = study.run_one(config(failing_sources), program).row
    assert row.status is Status.FAILED and "ZeroDivisionError: a bug" in row.why


def test_a_program_too_large_to_send_is_a_failed_row_with_its_size(tmp_path: Path) -> None:
    """The cluster's limit (read_one's max_bytes): the program alone, or with the subroutine
    files it calls; a local study (no limit) runs it."""
    (program,) = library(tmp_path, 1)
    size = Path(program).stat().st_size
    row = study.read_one(config(), program, max_bytes=size - 1)
    assert isinstance(row, ProgramResult) and row.row.status is Status.FAILED
    assert row.row.why.startswith("too large to send to the cluster: ")

    def big_file(path: Path, text: str) -> NcSources:
        return NcSources(str(path), (NcFile("big.nc", "big.nc", "N1 G01 X1\n" * 1000),))

    row = study.read_one(config(big_file), program, max_bytes=size + 1000)
    assert isinstance(row, ProgramResult) and "with its subroutine files" in row.row.why
    text, files = study.read_one(config(big_file), program, max_bytes=size + 20_000)  # type: ignore[misc]
    assert text == Path(program).read_text() and files.files[0].name == "big.nc"
    assert study.run_one(config(), program).row.status is Status.OK


def test_bytes_that_are_not_utf8_are_read_as_simulate_reads_them(tmp_path: Path) -> None:
    """In a comment (CP1252 from a Windows CAM): the program runs; in a word: ISG 990001 at its
    line, a row that says why."""
    comment = tmp_path / "comment.nc"
    comment.write_bytes(b"( St\xe4rke )\n" + PROGRAM.format(x=80).encode())
    assert study.run_one(config(), str(comment)).row.status is Status.OK
    word = tmp_path / "word.nc"
    word.write_bytes(b"G90 G17 G94\nG01 X1\xe40 Y10 Z1 F6000\nM30\n")
    row = study.run_one(config(), str(word)).row
    assert row.status is Status.ERROR and (row.errors[0].error_id, row.errors[0].line) == (
        990001,
        2,
    )


def test_an_unfinished_program_says_why_and_counts_its_open_range_once(tmp_path: Path) -> None:
    """`why` of an unfinished row says the limit (it was empty), and the range both runs were
    inside when it stopped is one open range (it was counted once per run: open 2, lifts 1)."""
    program = tmp_path / "long.nc"
    program.write_text("G01 X10 Y10 Z1 F6000\nZ[LIFT_START POS=1 POS_LIMIT=30]\n"
                       "G01 X1000 F600\nZ[LIFT_END]\nM30\n")  # fmt: skip
    row = study.run_one(config(max_time=1.5), str(program)).row
    assert row.status is Status.UNFINISHED
    assert row.why == "did not finish within 1.5 s simulated (--max-time)"
    assert row.to_json()["errors"] == [] and (row.lifts, row.open) == (1, 1)


def test_results_come_in_program_order_with_a_bounded_window(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(study, "WINDOW_PER_JOB", 1)  # the parent's bound: 2 programs with 2 jobs
    programs = library(tmp_path, 6)
    completed = 0
    handed: list[str] = []
    held: list[int] = []

    def done(result: ProgramResult) -> None:
        nonlocal completed
        completed += 1
        held.append(completed - len(handed))  # finished, not yet handed on

    for result in study.run_programs(programs, config(), 2, done):
        handed.append(result.row.program)
    assert handed == programs and completed == 6
    assert max(held) <= 2


def test_a_worker_that_dies_fails_only_its_own_program(tmp_path: Path) -> None:
    programs = (
        library(tmp_path, 3) + library(tmp_path, 1, "die.nc") + library(tmp_path, 3, "q{k}.nc")
    )
    rows = [r.row for r in study.run_programs(programs, config(dying_sources), 2)]
    assert [r.program for r in rows] == programs
    assert [r.status for r in rows] == [Status.OK] * 3 + [Status.FAILED] + [Status.OK] * 3
    assert "worker process died" in rows[3].why


def _result(
    name: str, status: Status, ratios: tuple[float, ...], overload: int = 0
) -> ProgramResult:
    n = len(ratios)
    row = ProgramRow(
        name, status, lifts=n, compared=n, clearance_advanced_mm=2.0 if n else None,
        clearance_lifting_mm=1.0 if n else None, duration_advanced_s=10.0,
        duration_lifting_s=10.5, lifting_z_overload_cycles=overload,
        clearance_ratio_min=min(ratios, default=None),
    )  # fmt: skip
    return ProgramResult(row, tuple((2.0, 1.0) for _ in ratios), ratios, 1000)


def test_aggregate_sums_bins_and_keeps_bounded_samples() -> None:
    agg = report.Aggregate()
    for k in range(report.MAX_LISTED + 50):
        agg.add(_result(f"bad{k}.nc", Status.ERROR, ()))
    many = tuple(1.0 + 0.001 * k for k in range(report.RESERVOIR + 10))
    agg.add(_result("big.nc", Status.OK, many, overload=12))
    agg.add(_result("small.nc", Status.OK, (0.95, 50.0)))
    s = agg.summary()
    assert s["programs"] == report.MAX_LISTED + 52
    assert s["status"]["error"] == report.MAX_LISTED + 50 and s["status"]["ok"] == 2
    assert len(agg.not_run) == report.MAX_LISTED  # listed by name: the first ones only
    assert s["compared"] == len(many) + 2
    assert sum(s["clearance_ratio_histogram"]["counts"]) == len(many) + 2  # every lift binned
    assert s["clearance_ratio_histogram"]["counts"][0] == 1  # 0.95: below the first edge
    assert len(agg.lift_points.items) == report.RESERVOIR  # the scatter sample is bounded
    assert agg.lift_points.seen == len(many) + 2
    assert s["clearance_ratio_min"] == 0.95 and s["clearance_ratio_min_program"] == "small.nc"
    assert s["clearance_advanced_mm"] == 2.0 and s["clearance_ratio_of_means"] == 2.0
    assert (s["finished"], s["duration_advanced_s"], s["time_difference_s"]) == (2, 20.0, 1.0)
    assert s["lifting_z_overload_cycles"] == 12 and s["programs_with_lifting_overload"] == 1


class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_progress_bar_only_on_a_terminal() -> None:
    log = io.StringIO()
    bar = ProgressBar(3, log)
    for failed in (False, True, False):
        bar.advance(failed)
    bar.close()
    assert log.getvalue() == ""
    tty = Terminal()
    bar = ProgressBar(3, tty)
    bar.advance()
    bar.advance(failed=True)
    bar.advance()
    bar.close()
    out = tty.getvalue()
    assert out.startswith("\r[") and out.endswith("\n")
    last = out.rstrip("\n").split("\r")[-1]
    assert (
        " 3/3 programs, 1 with errors" in last
        and "#" * 10 in last
        and "." not in last.split("]")[0]
    )
