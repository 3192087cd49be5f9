"""Small helpers shared by the fidelity tests."""

from __future__ import annotations

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
