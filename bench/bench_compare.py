"""Advanced Lifting vs path-based Lifting (issue 5): clearance per lift on the demo and on six
more programs, Z overload under an override step to 150 % inside a lift, and the cost of
planning 10 000 path-based lift ranges in path preparation.

Figures to reach: advanced mean clearance ≥ path-based on every lift; under 150 % override
path-based Z exceeds its plan (z_a_max_ratio > 1) while Advanced stays ≤ 1.0; planning 10 000
ranges well under 1 s; `simulate --compare --plot` of one lift of ~400 s in bounded memory
(peak RSS of the process, against the same command on a lift of ~4 s).
Run: .venv/bin/python bench/bench_compare.py   (one JSON line per figure, ~1 min)
"""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.cli import parser  # noqa: E402
from liftd.cnc.geo_program import _couple_lifts  # noqa: E402
from liftd.cnc.lift.ranges import find_ranges  # noqa: E402
from liftd.cnc.nc import DecoderContext, decode  # noqa: E402
from liftd.cnc.params import ChannelParams, LiftMethod  # noqa: E402
from liftd.cnc.path.program import prepare  # noqa: E402
from liftd.cnc.plc import Schedule, parse_override_spec  # noqa: E402
from liftd.settings import load_settings  # noqa: E402
from liftd.sim.compare import compare  # noqa: E402
from tests.support.programs import nesting_program  # noqa: E402

START = "G90 G17 G94\n#SLOPE[TYPE=TRAPEZ]\nG00 X20 Y20 Z1\n"


def long_lifts() -> str:
    """Long travels (600–1200 mm) at rapid-like feed, high POS_LIMIT."""
    out = [START]
    for i, x in enumerate((700, 100, 1300, 200)):
        out.append(f"M04\nG01 Y{40 + 30 * i:.0f} F6000\nM05\n")
        out.append(f"Z[LIFT_START POS=1 POS_LIMIT=100]\nG01 X{x} F30000\nZ[LIFT_END]\n")
    return "".join(out) + "M30\n"


def short_hops() -> str:
    """Hops of 8–20 mm between small holes: Z has almost no time."""
    out = [START]
    x = 20.0
    for k in range(12):
        out.append("M04\nG02 I2 J0 F3000\nM05\n")
        x += 8 + k
        out.append(f"Z[LIFT_START POS=1 POS_LIMIT=30]\nG01 X{x:.1f} F24000\nZ[LIFT_END]\n")
    return "".join(out) + "M30\n"


def many_small_blocks() -> str:
    """A travel made of 35 short blocks (a polyline from CAM): look-ahead overflow."""
    out = [START, "Z[LIFT_START POS=1 POS_LIMIT=50]\n"]
    for i in range(35):
        out.append(f"G01 X{24 + 6 * i} Y{20 + (i % 2) * 1.5:.1f} F18000\n")
    out.append("Z[LIFT_END]\nM04\nG01 Y60 F6000\nM05\n")
    out.append("Z[LIFT_START POS=1 POS_LIMIT=50]\n")
    for i in range(12):
        out.append(f"G01 X{230 - 8 * i} Y{60 + (i % 2) * 2}\n")
    return "".join(out) + "Z[LIFT_END]\nM30\n"


def arcs_in_range() -> str:
    """Travels around obstacles on arcs, with feed changes inside the range."""
    out = [START]
    for k in range(4):
        y = 20 + 60 * k
        out.append("M04\nG01 X60 F6000\nM05\n")
        out.append("Z[LIFT_START POS=1 POS_LIMIT=45]\n")
        out.append(f"G02 X140 Y{y} I40 J0 F20000\nG01 X180 F12000\nG03 X220 Y{y + 40} I0 J40\n")
        out.append(f"G01 X20 Y{y + 60} F24000\nZ[LIFT_END]\n")
    return "".join(out) + "M30\n"


def target_changes() -> str:
    """Single-block lifts to new cutting heights (POS ≠ start) and one over POS_LIMIT."""
    return START + (
        "M04\nG01 X60 F6000\nM05\n"
        "G01 X160 F24000 Z[LIFT POS=5 POS_LIMIT=40]\n"
        "M04\nG01 Y60 F6000\nM05\n"
        "G01 X40 Y120 F24000 Z[LIFT POS=2 POS_LIMIT=25]\n"
        "M04\nG01 X60 F6000\nM05\n"
        "G01 X300 F24000 Z[LIFT POS=12 POS_LIMIT=60]\n"
        "M30\n"
    )


PROGRAMS = {
    "demo": (ROOT / "config" / "programs" / "demo.nc").read_text(),
    "nesting_40_parts": nesting_program(40),
    "long_lifts": long_lifts(),
    "short_hops": short_hops(),
    "many_small_blocks": many_small_blocks(),
    "arcs_in_range": arcs_in_range(),
    "target_changes": target_changes(),
}


def clearance(ch: ChannelParams) -> None:
    for name, text in PROGRAMS.items():
        res = compare(ch, text, Schedule(), 0.02, program=name)
        pairs = [p for p in res.summary.lifts if p.clearance_ratio is not None]
        ratios = [p.clearance_ratio for p in pairs if p.clearance_ratio is not None]
        print(
            json.dumps(
                {
                    "bench": "clearance_advanced_vs_lifting",
                    "program": name,
                    "lifts": len(pairs),
                    "min_ratio": min(ratios),
                    "mean_ratio": round(sum(ratios) / len(ratios), 4),
                    "all_advanced_at_least_lifting": min(ratios) >= 1.0,
                    "premature_lifts": sum(bool(p.lifting and p.lifting.premature) for p in pairs),
                    "duration_s": res.summary.totals.duration_s.to_json(),
                    "errors": [
                        e.to_json()
                        for e in res.summary.advanced.errors + res.summary.lifting.errors
                    ],
                }
            ),
            flush=True,
        )


def override_step(ch: ChannelParams) -> None:
    # the demo's first lift runs from t ≈ 5.31 s to 6.20 s: step to 150 % inside it; then the
    # whole demo at 150 % (every lift at 1.5 × its planned path velocity)
    for spec, lift in (("0:100,5.5:150", 0), ("0:150", None)):
        res = compare(ch, PROGRAMS["demo"], Schedule(tuple(parse_override_spec(spec))), 0.02)
        pairs = res.summary.lifts if lift is None else (res.summary.lifts[lift],)
        print(
            json.dumps(
                {
                    "bench": "override_150",
                    "override": spec,
                    "lift_lines": [[p.start_line, p.end_line] for p in pairs],
                    "advanced_z_a_max_ratio": max(
                        p.advanced.z_a_max_ratio for p in pairs if p.advanced
                    ),
                    "lifting_z_a_max_ratio": [p.lifting.z_a_max_ratio for p in pairs if p.lifting],
                    "lifting_warning_cycles": res.summary.lifting.z_overload.warning_cycles,
                    "lifting_error_cycles": res.summary.lifting.z_overload.error_cycles,
                    "advanced_overload_cycles": res.summary.totals.z_overload_cycles.advanced,
                }
            ),
            flush=True,
        )


def planning_cost(ch: ChannelParams) -> None:
    lifting = dataclasses.replace(ch, lift_method=LiftMethod.LIFTING)
    text = nesting_program(10001)
    start = tuple(0.0 for _ in ch.axes)
    blocks = decode(text, DecoderContext.from_channel(lifting, start)).blocks
    path = prepare(blocks, lifting, start)
    ranges = find_ranges(path, lifting)
    best = float("inf")
    for _ in range(3):
        t0 = time.perf_counter()
        _couple_lifts(path, ranges, lifting)
        best = min(best, time.perf_counter() - t0)
    print(
        json.dumps(
            {
                "bench": "plan_path_based_ranges",
                "ranges": len(ranges),
                "seconds_best_of_3": round(best, 3),
                "us_per_range": round(best / len(ranges) * 1e6, 1),
            }
        ),
        flush=True,
    )


def one_lift(seconds: float) -> str:
    """One lift range of about `seconds` at F300 (a to-and-fro travel, within the limits)."""
    out = ["G90 G01 X10 Y10 Z1 F6000\nZ[LIFT_START POS=20 POS_LIMIT=25]\n"]
    leg = min(200.0, seconds * 5.0)  # mm, at 5 mm/s
    legs = max(1, round(seconds * 5.0 / leg))
    out += [
        f"G01 X{10 + leg if i % 2 == 0 else 10} Y{10 + 0.1 * i:.1f} F300\n" for i in range(legs)
    ]
    out.append("Z[LIFT_END]\nG01 Z1 F6000\nM30\n")
    return "".join(out)


def long_lift_memory() -> None:
    """Peak RSS of `liftd simulate --compare --plot` (a fresh process each) for one lift of
    ~4 s and of ~400 s: the per-lift samples are bounded (compare.MAX_ROWS)."""
    config = str(ROOT / "config" / "liftd.toml")
    with tempfile.TemporaryDirectory() as tmp:
        for seconds in (4.0, 400.0):
            prog = Path(tmp) / f"lift{seconds:.0f}.nc"
            prog.write_text(one_lift(seconds))
            cmd = [sys.executable, "-c", PEAK_RSS, "simulate", str(prog), "-c", config,
                   "--compare", "--json", "--plot", str(Path(tmp) / "p.png")]  # fmt: skip
            out = subprocess.run(cmd, capture_output=True, text=True, check=True, cwd=ROOT)
            summary, peak = out.stdout.rsplit("\n", 2)[:2]
            duration = json.loads(summary)["totals"]["duration_s"]
            print(
                json.dumps(
                    {
                        "bench": "compare_plot_peak_rss",
                        "lift_s_about": seconds,
                        "duration_s": duration,
                        "peak_rss_mib": round(int(peak) / 1024, 1),
                    }
                ),
                flush=True,
            )


PEAK_RSS = """import resource, sys
from liftd import cli
sys.argv[0] = "liftd"
code = cli.main(sys.argv[1:])
print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)
"""


def main() -> None:
    parser(__doc__).parse_args()
    ch = load_settings(str(ROOT / "config" / "liftd.toml")).channel
    clearance(ch)
    override_step(ch)
    planning_cost(ch)
    long_lift_memory()


if __name__ == "__main__":
    main()
