"""`liftd simulate` as users and other tools rely on it (docs/reference/design.md §3.1–3.3)."""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from liftd import cli
from liftd.sim import compare, plot
from liftd.sim import simulate as sim_module
from tests.support.paths import REPO

pytestmark = pytest.mark.integration
DEMO = str(REPO / "config" / "programs" / "demo.nc")
CONTRACT_COLUMNS = [
    "t",
    "line",
    "x",
    "y",
    "z",
    "v_path",
    "override",
    "lift_active",
    "lift_suppressed",
]
LIFT_KEYS = {
    "start_line",
    "end_line",
    "method",
    "suppressed",
    "z_start",
    "z_target",
    "pos_limit",
    "peak",
    "mean_clearance",
    "t_start",
    "t_end",
    "arrival_error",
    "path_delay_s",
    # compatible extensions of docs/reference/design.md §3.3
    "duration_s",
    "z_a_max_ratio",
    "premature",
    "open",  # the program stopped inside the range (issue 15 item 6)
}


def simulate(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "liftd", "simulate", *args],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )


@pytest.fixture(scope="module")
def demo_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict, list[list[str]], Path]:
    out = tmp_path_factory.mktemp("demo")
    trace = out / "demo.csv"
    png = out / "demo.png"
    r = simulate(DEMO, "--trace", str(trace), "--plot", str(png), "--json")
    assert r.returncode == 0, r.stderr
    with trace.open(newline="") as f:
        rows = list(csv.reader(f))
    return json.loads(r.stdout), rows, png


def test_trace_columns_and_one_row_per_cycle(demo_run: tuple[dict, list[list[str]], Path]) -> None:
    summary, rows, _ = demo_run
    assert rows[0][: len(CONTRACT_COLUMNS)] == CONTRACT_COLUMNS
    assert rows[0][len(CONTRACT_COLUMNS) :] == ["lift_phase", "vz", "az", "state", "override_max"]
    data = rows[1:]
    assert len(data) == summary["cycles"]
    dt = summary["cycle_time_s"]
    assert [float(r[0]) for r in data[:3]] == pytest.approx([dt, 2 * dt, 3 * dt])
    assert float(data[-1][0]) == pytest.approx(summary["duration_s"])
    assert {r[7] for r in data} == {"0", "1"} and {r[8] for r in data} == {"0", "1"}
    assert all(r[6] == "1.000000" for r in data)  # override fraction, 1.0 = 100 %


def test_summary_schema(demo_run: tuple[dict, list[list[str]], Path]) -> None:
    summary, _, _ = demo_run
    assert set(summary) == {
        "cycle_time_s",
        "duration_s",
        "cycles",
        "method",
        "lifts",
        "limits",
        "z_overload",
        "errors",
        "step_cpu_us",
    }
    assert summary["method"] == "advanced" and summary["errors"] == []
    assert len(summary["lifts"]) == 5
    for lift in summary["lifts"]:
        assert set(lift) == LIFT_KEYS
        assert lift["arrival_error"] <= 0.001  # mm
        assert lift["z_a_max_ratio"] <= 1.0 + 1e-9 and not lift["premature"]
    assert max(x["z_a_max_ratio"] for x in summary["lifts"]) > 0.9  # Z uses its a_max
    overload = summary["z_overload"]
    assert overload["warning_cycles"] == overload["error_cycles"] == 0
    assert (overload["warning_ratio"], overload["error_ratio"]) == (1.5, 2.0)  # list defaults
    assert {"z_v_max_ratio", "z_a_max_ratio", "z_j_max_ratio"} <= set(summary["limits"])
    # within the limits in the segments; over block transitions what the block-transition
    # parameters allow (issue 36: the demo's kinks step the axes' acceleration by up to j·dt)
    limits = summary["limits"]
    assert max(r for k, r in limits.items() if "_segment_" in k) <= 1 + 1e-9
    assert max(r for k, r in limits.items() if k.startswith("z_")) <= 1 + 1e-9  # the lift axis
    assert all(limits[f"{a}_transition_v_max_ratio"] <= 1 + 1e-9 for a in "xy")
    suppressed = [x for x in summary["lifts"] if x["suppressed"]]
    assert [x["start_line"] for x in suppressed] == [48]


def test_trace_agrees_with_the_summary(demo_run: tuple[dict, list[list[str]], Path]) -> None:
    summary, rows, _ = demo_run
    z = [float(r[4]) for r in rows[1:]]
    assert max(z) == pytest.approx(max(x["peak"] for x in summary["lifts"]), abs=1e-6)


def test_plot_is_a_png(demo_run: tuple[dict, list[list[str]], Path]) -> None:
    _, _, png = demo_run
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 20000


def test_same_run_twice_gives_identical_trace(tmp_path: Path) -> None:
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    for out in (a, b):
        r = simulate(
            DEMO, "--trace", str(out), "--override", "0:100,3:150,6:70", "--feedhold", "2:0.5"
        )
        assert r.returncode == 0, r.stderr
    assert a.read_bytes() == b.read_bytes()


@pytest.mark.parametrize("compare", [False, True])
def test_step_times_runs_every_cycle_alone_and_changes_nothing_else(
    tmp_path: Path, compare: bool
) -> None:
    """`--step-times` (each GEO step timed alone, issue 39 batches the quiet cycles otherwise):
    the same trace bytes and the same summary but for `step_cpu_us`."""
    runs: list[tuple[dict[str, object], list[bytes]]] = []
    for flags in ([], ["--step-times"]):
        trace = tmp_path / f"{len(runs)}.csv"
        extra = ["--compare"] if compare else []
        sched = ["--override", "0:100,3:150,6:70", "--feedhold", "2:0.5"]
        r = simulate(DEMO, "--trace", str(trace), "--json", *sched, *extra, *flags)
        assert r.returncode == 0, r.stderr
        doc = json.loads(r.stdout)
        for part in [doc, *(doc.get(m, {}) for m in ("advanced", "lifting"))]:
            part.pop("step_cpu_us", None)
        names = [trace.with_suffix(f".{m}.csv") for m in ("advanced", "lifting")]
        runs.append((doc, [p.read_bytes() for p in (names if compare else [trace])]))
    assert runs[0] == runs[1]


def test_step_times_turns_the_batches_off(monkeypatch: pytest.MonkeyPatch) -> None:
    seen: list[tuple[str, object]] = []
    real_sim, real_cmp = sim_module.simulate, compare.compare

    def spy_sim(*args: object, **kw: object) -> object:
        seen.append(("simulate", kw.get("batch", True)))
        return real_sim(*args, **kw)  # type: ignore[arg-type]

    def spy_cmp(*args: object, **kw: object) -> object:
        seen.append(("compare", args[7] if len(args) > 7 else kw.get("batch", True)))
        return real_cmp(*args, **kw)  # type: ignore[arg-type]

    monkeypatch.setattr(sim_module, "simulate", spy_sim)
    monkeypatch.setattr(compare, "compare", spy_cmp)
    for extra in ([], ["--compare"]):
        for flags in ([], ["--step-times"]):
            assert cli.main(["simulate", DEMO, *extra, *flags]) == 0
    assert seen == [
        ("simulate", True),
        ("simulate", False),
        ("compare", True),
        ("compare", False),
    ]


def test_program_error_exit_1_with_partial_trace(tmp_path: Path) -> None:
    prog = tmp_path / "bad.nc"
    prog.write_text("G01 X10 Y10 Z1 F6000\nX50\nQ3\nX80\nM30\n")
    trace = tmp_path / "bad.csv"
    r = simulate(str(prog), "--trace", str(trace), "--json")
    assert r.returncode == 1
    assert f"{prog}:3: error 990018:" in r.stderr
    summary = json.loads(r.stdout)
    assert summary["errors"][0]["line"] == 3 and summary["errors"][0]["id"] == 990018
    rows = trace.read_text().splitlines()
    assert float(rows[-1].split(",")[2]) == pytest.approx(50.0)  # ran up to the last good block


def test_a_range_open_when_an_error_stops_the_program_is_listed(tmp_path: Path) -> None:
    """Issue 15 item 6: the lift the error interrupts is in `lifts`, as it was at the stop."""
    prog = tmp_path / "open.nc"
    prog.write_text(
        "G90 G17 G94\nG01 X10 Y10 Z1 F6000\n"
        "Z[LIFT_START POS=1 POS_LIMIT=40]\nG01 X60 F24000\nZ[LIFT_END]\n"  # closed, lines 3-5
        "Z[LIFT_START POS=1 POS_LIMIT=40]\nG01 X150 F24000\nQ3\nX200\nZ[LIFT_END]\nM30\n"
    )
    r = simulate(str(prog), "--json")
    assert r.returncode == 1 and f"{prog}:8: error 990018:" in r.stderr
    summary = json.loads(r.stdout)
    closed, stopped = summary["lifts"]
    assert (closed["start_line"], closed["end_line"], closed["open"]) == (3, 5, False)
    assert stopped["start_line"] == 6 and stopped["open"] is True
    assert stopped["end_line"] == 8  # LIFT_END was never read: where the program stopped
    assert stopped["t_end"] == summary["duration_s"]  # the cycle the program stopped in
    assert stopped["t_start"] >= closed["t_end"]  # back to back
    assert 1.0 < stopped["peak"] <= 40.0 and stopped["mean_clearance"] > 0.0  # Z rose so far
    assert stopped["arrival_error"] == pytest.approx(stopped["peak"] - 1.0, abs=1e-3)
    assert stopped["path_delay_s"] == 0.0

    r = simulate(str(prog), "--compare", "--json")
    assert r.returncode == 1
    both = json.loads(r.stdout)
    assert [x["open"] for x in both["advanced"]["lifts"]] == [False, True]
    assert [x["open"] for x in both["lifting"]["lifts"]] == [False, True]
    pair = both["lifts"][1]
    assert pair["advanced"]["open"] and pair["lifting"]["open"]
    assert pair["clearance_ratio"] is None and pair["peak_ratio"] is None  # cut short
    assert both["totals"]["min_clearance_ratio"] == both["lifts"][0]["clearance_ratio"]


@pytest.mark.parametrize(
    ("args", "code", "fragment"),
    [
        (["--override", "0:250"], 2, "PERCENT <= 200"),
        (["--override", "x"], 2, "expected T:PERCENT"),
        (["--feedhold", "1:-2"], 2, "DURATION > 0"),
        (["--trace", "/nonexistent/dir/x.csv"], 3, "cannot write the trace"),
        (["--plot", "/nonexistent/dir/x.png"], 3, "x.png: error: cannot write the plot"),
        (["--max-time", "-1"], 2, "--max-time -1.0: must be > 0 s"),
        (["--max-time", "0"], 2, "must be > 0 s"),
    ],
)
def test_bad_options(args: list[str], code: int, fragment: str) -> None:
    r = simulate(DEMO, *args)
    assert r.returncode == code and fragment in r.stderr


def test_missing_program_and_config(tmp_path: Path) -> None:
    r = simulate(str(tmp_path / "none.nc"))
    assert r.returncode == 1 and "cannot read program" in r.stderr
    r = simulate(DEMO, "-c", str(tmp_path / "none.toml"))
    assert r.returncode == 2


def test_plot_without_matplotlib_says_how_to_get_it(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    monkeypatch.setattr(plot, "available", lambda: False)
    code = cli.main(["simulate", DEMO, "--plot", str(tmp_path / "x.png")])
    assert code == 3
    assert "pip install 'liftd[plot]'" in capsys.readouterr().err


def test_override_schedule_reaches_the_core(tmp_path: Path) -> None:
    trace = tmp_path / "o.csv"
    r = simulate(DEMO, "--override", "0:100,1:50", "--trace", str(trace))
    assert r.returncode == 0
    rows = list(csv.reader(trace.open()))[1:]
    assert {r[6] for r in rows if float(r[0]) > 1.001} == {"0.500000"}


def test_a_plot_it_cannot_write_is_a_bad_argument_before_the_run(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    """An unknown figure format, or the name of a trace it would overwrite, is exit 2 with one
    line (before: a matplotlib traceback and exit 1, or the trace silently replaced)."""
    cases = [
        (["--plot", str(tmp_path / "p.xyz")], "format 'xyz' not supported"),
        (["--trace", str(tmp_path / "s.png"), "--plot", str(tmp_path / "s.png")], "trace's file"),
        (
            [
                "--compare",
                "--trace",
                str(tmp_path / "c.png"),
                "--plot",
                str(tmp_path / "c.advanced.png"),
            ],
            "trace's file",
        ),
    ]
    for args, why in cases:
        assert cli.main(["simulate", DEMO, *args]) == 2, args
        err = capsys.readouterr().err
        assert why in err and "Traceback" not in err, err
    assert not list(tmp_path.iterdir())  # nothing written


def test_a_trace_write_that_fails_names_the_file() -> None:
    r = simulate(DEMO, "--trace", "/dev/full")
    assert r.returncode == 3
    assert r.stderr.startswith("/dev/full: error: cannot write the trace: No space left"), r.stderr


def test_a_reader_that_closes_stdout_ends_the_command_quietly() -> None:
    """`liftd objects | head -1`: exit 141 as for a tool SIGPIPE ended, no traceback (a pipe
    whose reader has already gone, so that the first write fails)."""
    read_end, write_end = os.pipe()
    os.close(read_end)
    try:
        r = subprocess.run([sys.executable, "-m", "liftd", "objects"], stdout=write_end,
                           stderr=subprocess.PIPE, text=True, timeout=60, check=False)  # fmt: skip
    finally:
        os.close(write_end)
    assert r.returncode == 141 and "Traceback" not in r.stderr, r.stderr


def _first_error_place(stderr: str) -> str:
    """`file:line` of the first error line of check or simulate (check adds :column)."""
    first = next(line for line in stderr.splitlines() if " error " in line)
    where = first.split(" error ")[0].rstrip(":")
    parts = where.split(":")
    return ":".join(parts[:2])


@pytest.mark.parametrize(
    ("files", "expected"),
    [
        # an error in a global subroutine file: simulate named the main program with the
        # subroutine's line (job.nc:3, a good line) where check said part.nc:3
        (
            {
                "part.nc": "G01 X60 Y60 F600\nG01 X70\nX80 Q5\nM17\n",
                "job.nc": "G90 G17\nG00 X20 Y20 Z1\nG01 X30 F6000\nL part.nc\nM30\n",
            },
            "part.nc:3",
        ),
        # a form feed in a comment ended the line for the decoder: every later line was off
        ({"job.nc": "G00 X20 Y20 Z1 (a\x0cb)\nG01 X30 F6000\n\nG01 X40 Q1\nM30\n"}, "job.nc:4"),
    ],
)
def test_check_and_simulate_name_the_same_line(
    tmp_path: Path, files: dict[str, str], expected: str
) -> None:
    for name, text in files.items():
        (tmp_path / name).write_text(text)
    job = str(tmp_path / "job.nc")
    config = str(REPO / "config" / "liftd.toml")
    checked = subprocess.run(
        [sys.executable, "-m", "liftd", "check", "-c", config, job],
        capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip
    simulated = simulate(job, "--json")
    assert checked.returncode == simulated.returncode == 1
    place = _first_error_place(checked.stderr)
    assert place == f"{tmp_path}/{expected}", checked.stderr
    assert _first_error_place(simulated.stderr) == place, simulated.stderr
    error = json.loads(simulated.stdout)["errors"][0]
    name, line = expected.split(":")
    assert str(error["line"]) == line
    assert error.get("file", job) == f"{tmp_path}/{name}"
