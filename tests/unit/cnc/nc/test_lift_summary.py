"""`liftd check`'s line per lift range (issue 15): what the decoder knows of each range."""

from __future__ import annotations

import dataclasses

import pytest

from liftd.cnc.nc import DecoderContext, decode
from liftd.cnc.nc.lift_summary import LiftRangeSummary, LiftRangeTracker, describe
from liftd.cnc.params import LiftMethod, NcFile, NcSources
from tests.support.channel import make_channel

PROGRAM = """%L hop
Z[LIFT_START POS=1 POS_LIMIT=30]
G00 X[P1] Y0
Z[LIFT_END]
M17
%main
G01 X0 Y0 Z1 F6000
P1=100
LL hop
X101 Z[LIFT POS=1 POS_LIMIT=300]
Z[LIFT_START POS=40 POS_LIMIT=30]
X300
Z[LIFT_END]
Z[LIFT_START DOWN POS=30 POS_LIMIT=35]
G02 X320 Y0 I10 J0
Z[LIFT_END]
Z[LIFT_START POS=1 POS_LIMIT=60]
G01 X400
X1 Y2 Y3
M30
"""


def summaries(method: LiftMethod = LiftMethod.ADVANCED) -> list[LiftRangeSummary]:
    ch = dataclasses.replace(make_channel(method=method), lift_min_dist=0.005)
    tracker = LiftRangeTracker(ch.lift_min_dist)
    for block in decode(PROGRAM, DecoderContext.from_channel(ch)).blocks:
        tracker.feed(block)
    return tracker.finish()


def test_each_range_with_its_lines_path_limit_and_state() -> None:
    hop, single, beyond, down, open_ = summaries()
    assert (hop.start.line, hop.end_line, hop.length) == (2, 4, pytest.approx(0.1))
    assert not hop.suppressed and not hop.beyond_limit
    assert (single.start.line, single.end_line) == (10, 10)
    assert single.suppressed  # 1 mm < lift_min_dist 5 mm
    assert single.start.pos_limit == pytest.approx(0.15)  # held at the software limit
    assert single.start.limit_programmed == pytest.approx(0.3)
    assert beyond.beyond_limit and not beyond.suppressed
    assert down.beyond_limit and down.length == pytest.approx(0.01 * 3.141592653589793)
    assert open_.end_line is None and open_.length == pytest.approx(0.08)


def test_the_lines_a_user_reads() -> None:
    lines = [describe(r, LiftMethod.ADVANCED) for r in summaries()]
    assert lines[0] == (
        "lift 1: lines 2-4, Advanced Lifting, Z 1.000 -> POS 1.000 mm, limit 30.000 mm, "
        "path 100.000 mm: lifts (peak and nominal time: not planned by check)"
    )
    assert lines[1].startswith("lift 2: line 10, single block, Advanced Lifting")
    assert "limit 150.000 mm (POS_LIMIT 300.000 held at the software limit)" in lines[1]
    assert lines[1].endswith(
        "suppressed (path shorter than lift_min_dist, P-CHAN-00244): Z goes to POS"
    )
    assert lines[2].endswith("special case 1), path 199.000 mm: Z goes to POS at the start")
    assert lines[3].startswith(
        "lift 4: lines 14-16, DOWN, Advanced Lifting, Z 40.000 -> POS 30.000"
    )
    assert lines[4].startswith("lift 5: from line 17, ")
    assert lines[4].endswith(
        "open where the program stops: Z goes to 60.000 mm, the maximum lift height, and "
        "stays (vendor §2.1.1, §2.4)"
    )


def test_the_planner_hook_fills_peak_and_nominal_time() -> None:
    hop = summaries()[0]
    line = describe(hop, LiftMethod.ADVANCED, plan=lambda r: (0.0123, 0.456))
    assert line.endswith("lifts (planned peak 12.300 mm, nominal 0.456 s)")
    unplanned = describe(hop, LiftMethod.ADVANCED, plan=lambda r: None)  # beyond its horizon
    assert unplanned.endswith("lifts (peak and nominal time: beyond what check plans; "
                              "liftd simulate)")  # fmt: skip
    assert describe(hop, LiftMethod.LIFTING).endswith(", path 100.000 mm: lifts")


def test_a_range_spanning_two_files_names_each_end_with_its_file() -> None:
    liftsub = "Z[LIFT_START POS=1 POS_LIMIT=40]\nG01 X300 F24000\nM17\n"
    hop = "Z[LIFT_START POS=1 POS_LIMIT=40]\nG01 X350\nZ[LIFT_END]\nM17\n"
    main = "G01 X100 Y20 Z1 F6000\nL liftsub.nc\nG01 X400\nZ[LIFT_END]\nL hop.nc\nM30\n"
    files = (NcFile("liftsub.nc", "/s/liftsub.nc", liftsub), NcFile("hop.nc", "/s/hop.nc", hop))
    ch = dataclasses.replace(make_channel(), nc_sources=NcSources("main2.nc", files))
    tracker = LiftRangeTracker(0.0)
    for block in decode(main, DecoderContext.from_channel(ch)).blocks:
        tracker.feed(block)
    lines = [describe(r, LiftMethod.LIFTING, program="main2.nc") for r in tracker.finish()]
    assert lines[0].startswith("lift 1: lines /s/liftsub.nc:1 to main2.nc:4, ")
    assert lines[1].startswith("lift 2: lines /s/hop.nc:1-3, ")


def test_the_state_names_the_ranges_own_lift_axis() -> None:
    """A W lift in a second channel reads 'W goes to …' (it said Z for every axis)."""
    ranges = summaries()
    on_w = [dataclasses.replace(r, start=r.start._replace(axis="W")) for r in ranges]
    lines = [describe(r, LiftMethod.ADVANCED) for r in on_w]
    assert lines[1].endswith("P-CHAN-00244): W goes to POS")
    assert lines[2].endswith(": W goes to POS at the start")
    assert lines[4].endswith(": W goes to 60.000 mm, the maximum lift height, and stays "
                             "(vendor §2.1.1, §2.4)")  # fmt: skip
    assert not any(" Z " in line for line in lines)
