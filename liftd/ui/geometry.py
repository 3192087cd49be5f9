"""A program as the page draws it: the prepared path in the plane of the channel's first two
axes (mm), each lift range on it with its method, POS and POS_LIMIT, and the program's lines
for the block text. Built once per program off the event loop (decode + path preparation, the
same code the GEO task runs, without the lift planning: ~15 µs a block)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from liftd.cnc.lift.ranges import LiftRange, find_ranges
from liftd.cnc.nc import DecoderContext, decode
from liftd.cnc.params import ChannelParams, LiftMethod
from liftd.cnc.path.geometry import ArcSeg
from liftd.cnc.path.program import PathProgram, prepare

MM = 1e3
MAX_POINTS = 40_000  # points of the drawn path; a longer program is drawn decimated
ARC_STEP_RAD = math.radians(6.0)
MAX_LINE_CHARS = 200


@dataclass(frozen=True, slots=True)
class Geometry:
    channel_id: int
    drawing: dict[str, Any]  # what the page gets (JSON)
    ranges: tuple[tuple[int, int, dict[str, Any]], ...]  # (start line, end line, as drawn)
    lines: tuple[str, ...]  # the program's own lines (1-based: lines[n - 1])

    def block_text(self, line: int) -> str:
        if 1 <= line <= len(self.lines):
            return self.lines[line - 1][:MAX_LINE_CHARS]
        return ""

    def open_range(self, line: int) -> dict[str, Any] | None:
        """The range whose lines hold `line` (the open one while a lift flag or phase is on)."""
        for start, end, rng in self.ranges:
            if start <= line <= (end if end > 0 else 1 << 31):
                return rng
        return None


def _points(path: PathProgram, k0: int, k1: int) -> list[tuple[float, float]]:
    pts: list[tuple[float, float]] = []
    segs = path.segments
    if not segs or k0 >= len(segs):
        return pts
    start = segs[k0].geom.start
    pts.append((start[0] * MM, start[1] * MM))
    for seg in segs[k0:k1]:
        g = seg.geom
        if isinstance(g, ArcSeg) and g.length > 0.0:
            n = max(2, min(64, math.ceil(abs(g.sweep) / ARC_STEP_RAD)))
            for i in range(1, n + 1):
                p = g.position(g.length * i / n)
                pts.append((p[0] * MM, p[1] * MM))
        else:
            pts.append((g.end[0] * MM, g.end[1] * MM))
    return pts


def _thin(pts: list[tuple[float, float]], limit: int) -> list[list[float]]:
    step = max(1, math.ceil(len(pts) / limit))
    kept = pts[::step]
    if pts and kept[-1] != pts[-1]:
        kept.append(pts[-1])
    return [[round(x, 3), round(y, 3)] for x, y in kept]


def _method(rng: LiftRange, ch: ChannelParams) -> str:
    if rng.suppressed or rng.beyond_limit:
        return "direct"  # Z straight to POS (suppressed, or POS_LIMIT without effect)
    if ch.lift_method is LiftMethod.LIFTING and rng.k_end > rng.k_start:
        return "lifting"  # path-based: z(s)
    return "advanced"  # time-based (path-based Lifting's ranges without path motion too)


def build(ch: ChannelParams, text: str, start: tuple[float, ...] | None = None) -> Geometry:
    """The drawing of program `text` in channel `ch`, prepared from `start` (default: 0)."""
    home = start if start is not None else tuple(0.0 for _ in ch.axes)
    lines = tuple(text.splitlines())
    base: dict[str, Any] = {
        "channel": ch.channel_id, "axes": list(ch.axis_names), "lift_axis": ch.lift_axis,
        "method": ch.lift_method.value, "path": [], "ranges": [], "error": None,
    }  # fmt: skip
    try:
        result = decode(text, DecoderContext.from_channel(ch, home))
        path = prepare(result.blocks, ch, home)
        ranges = find_ranges(path, ch)
    except Exception as exc:  # the page still shows the live values
        base["error"] = f"the path cannot be drawn: {type(exc).__name__}: {exc}"
        return Geometry(ch.channel_id, base, (), lines)
    if len(ch.axes) < 2:
        return Geometry(ch.channel_id, base, (), lines)
    base["path"] = _thin(_points(path, 0, len(path.segments)), MAX_POINTS)
    drawn = []
    budget = MAX_POINTS // max(1, len(ranges))
    for rng in ranges:
        k_end = rng.k_end if rng.k_end >= 0 else len(path.segments)
        spec = rng.start
        item = {
            "start_line": spec.line, "end_line": rng.end_line, "axis": spec.axis,
            "method": _method(rng, ch), "suppressed": rng.suppressed,
            "pos": round(spec.target * MM, 4), "pos_limit": round(spec.pos_limit * MM, 4),
            "path": _thin(_points(path, rng.k_start, k_end), max(2, budget)),
        }  # fmt: skip
        drawn.append((spec.line, rng.end_line, item))
    base["ranges"] = [d[2] for d in drawn]
    if result.first_error is not None:
        err = result.first_error
        base["error"] = f"NC error {err.id} in line {err.line}: {err.message}"
    return Geometry(ch.channel_id, base, tuple(drawn), lines)
