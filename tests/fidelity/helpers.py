"""Small helpers shared by the fidelity tests."""

from __future__ import annotations

from liftd.cnc.geo_task import GeoTask
from liftd.cnc.nc import DecoderContext, DecodeResult, Severity, decode
from liftd.cnc.params import ChannelParams
from liftd.cnc.snapshot import ChannelState, GeoSnapshot
from tests.support.closed_loop import run_task

MM = 1e-3


def decoded(ch: ChannelParams, text: str) -> DecodeResult:
    return decode(text, DecoderContext.from_channel(ch))


def ids(result: DecodeResult, severity: Severity) -> list[tuple[int, int]]:
    """(id, line) of the problems of one severity."""
    return [(e.id, e.line) for e in result.errors if e.severity is severity]


def run_z(ch: ChannelParams, text: str) -> tuple[list[GeoSnapshot], list[float]]:
    """Run the program in the GEO task to its end; the snapshots and Z per cycle (m)."""
    _, snaps = run_task(ch, text)
    assert snaps[-1].state is ChannelState.READY, snaps[-1]
    return snaps, [s.positions[2] for s in snaps]


# the vendor's §2.2.3 case 2 program up to its LIFT_START (its POS=12 POS_LIMIT=40)
FLUSH_HEAD = "N10 G01 X10 Y10 F6000\nN20 X40 Z2\nN30 Z[LIFT_START POS=12 POS_LIMIT=40]\n"


def flush_run(
    ch: ChannelParams, blocks: str, end: str = "N100 X100\n"
) -> tuple[GeoTask, list[GeoSnapshot]]:
    """FLUSH_HEAD, `blocks` (with the #FLUSH), LIFT_END, `end`, M30, run to its end: one range
    that lands."""
    task, snaps = run_task(ch, f"{FLUSH_HEAD}{blocks}N90 Z[LIFT_END]\n{end}M30\n")
    assert snaps[-1].state is ChannelState.READY
    (rec,) = task.lift.records  # one range: no implicit LIFT_END + LIFT_START
    assert rec.arrival_error <= 1e-9
    return task, snaps


def on_return(snaps: list[GeoSnapshot], x: float) -> GeoSnapshot:
    """The cycle nearest to X = x after the path's largest X (a flush's own stop lasts less
    than a cycle)."""
    k = max(range(len(snaps)), key=lambda i: snaps[i].positions[0])
    return min(snaps[k:], key=lambda s: abs(s.positions[0] - x))
