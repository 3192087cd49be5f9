"""A program as the page draws it: the prepared path in the plane of the channel's first two
axes (mm), each lift range on it with its method, POS and POS_LIMIT, and the program's lines
for the block text. Built and encoded once per program, a long one in a process of its own
(decode + path preparation, the same code the GEO task runs, without the lift planning: ~15 µs
a block; the compiled core and the JSON encoder do not let go of the GIL, a thread would stall
the event loop the ADS server shares: `liftd/service/ui_host.py`)."""

from __future__ import annotations

import json
import math
from bisect import bisect_right
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from liftd.cnc.lift.ranges import LiftRange, find_ranges
from liftd.cnc.nc import DecoderContext, decode
from liftd.cnc.params import ChannelParams, LiftMethod
from liftd.cnc.path.geometry import ArcSeg
from liftd.cnc.path.program import PathProgram, prepare

MM = 1e3
MAX_POINTS = 40_000  # points drawn (path and ranges); a longer program is drawn decimated
ARC_STEP_RAD = math.radians(6.0)
MAX_LINE_CHARS = 200


@dataclass(frozen=True, slots=True)
class Geometry:
    """One channel's program as the page draws it. `encoded`: the drawing (JSON, UTF-8), built
    and encoded once, off the event loop, served as it is (`/drawing/…`); `ranges`: each range's
    (start line, end line, axis, method, suppressed, POS mm, POS_LIMIT mm), by start line."""

    channel_id: int
    encoded: bytes
    ranges: tuple[tuple[int, int, str, str, bool, float, float], ...]
    lines: tuple[str, ...]  # the program's own lines (1-based: lines[n - 1])
    starts: tuple[int, ...] = ()  # each range's start line (bisect)

    def block_text(self, line: int) -> str:
        if 1 <= line <= len(self.lines):
            return self.lines[line - 1][:MAX_LINE_CHARS]
        return ""

    def open_range(self, line: int) -> dict[str, Any] | None:
        """The range whose lines hold `line` (the open one while a lift flag or phase is on):
        the last one starting at or before it, by bisection (ranges do not nest)."""
        k = bisect_right(self.starts, line) - 1
        if k < 0:
            return None
        start, end, axis, method, suppressed, pos, pos_limit = self.ranges[k]
        if line > (end if end > 0 else 1 << 31):
            return None
        return {
            "start_line": start,
            "end_line": end,
            "axis": axis,
            "method": method,
            "suppressed": suppressed,
            "pos": pos,
            "pos_limit": pos_limit,
        }


def _points(path: PathProgram) -> tuple[list[tuple[float, float]], list[int]]:
    """The path's points and, per segment (and its end), the index of its start point."""
    pts: list[tuple[float, float]] = []
    at: list[int] = []
    segs = path.segments
    if not segs:
        return pts, [0]
    start = segs[0].geom.start
    pts.append((start[0] * MM, start[1] * MM))
    for seg in segs:
        at.append(len(pts) - 1)
        g = seg.geom
        if isinstance(g, ArcSeg) and g.length > 0.0:
            n = max(2, min(64, math.ceil(abs(g.sweep) / ARC_STEP_RAD)))
            for i in range(1, n + 1):
                p = g.position(g.length * i / n)
                pts.append((p[0] * MM, p[1] * MM))
        else:
            pts.append((g.end[0] * MM, g.end[1] * MM))
    at.append(len(pts) - 1)
    return pts, at


def _thin(pts: list[tuple[float, float]], step: int) -> list[list[float]]:
    kept = pts[::step]
    if pts and (len(pts) - 1) % step:
        kept.append(pts[-1])
    return [[round(x, 3), round(y, 3)] for x, y in kept]


def _method(rng: LiftRange, ch: ChannelParams) -> str:
    if rng.suppressed or rng.beyond_limit:
        return "direct"  # Z straight to POS (suppressed, or POS_LIMIT without effect)
    if ch.lift_method is LiftMethod.LIFTING and rng.k_end > rng.k_start:
        return "lifting"  # path-based: z(s)
    return "advanced"  # time-based (path-based Lifting's ranges without path motion too)


def _spans(
    ranges: Sequence[LiftRange], at: list[int], step: int, n: int, ch: ChannelParams
) -> list[list[Any]]:
    """Each range as [first, last point of the drawn path, method]; ranges that meet on the
    drawn (decimated) path with the same method are one span: at most a span a point."""
    out: list[list[Any]] = []
    for rng in ranges:
        k_end = rng.k_end if rng.k_end >= 0 else len(at) - 1
        i0 = min(at[min(rng.k_start, len(at) - 1)] // step, n - 1)
        i1 = min(-(-at[min(k_end, len(at) - 1)] // step), n - 1)
        method = _method(rng, ch)
        if out and out[-1][2] == method and i0 <= out[-1][1]:
            out[-1][1] = max(out[-1][1], i1)
        else:
            out.append([i0, max(i0, i1), method])
    return out


def build(ch: ChannelParams, text: str, start: tuple[float, ...] | None = None) -> Geometry:
    """The drawing of program `text` in channel `ch`, prepared from `start` (default: 0), at
    most MAX_POINTS points for the path and its ranges together (the ranges are spans of it)."""
    home = start if start is not None else tuple(0.0 for _ in ch.axes)
    lines = tuple(text.splitlines())
    base: dict[str, Any] = {
        "channel": ch.channel_id,
        "axes": list(ch.axis_names),
        "lift_axis": ch.lift_axis,
        "method": ch.lift_method.value,
        "path": [],
        "ranges": [],
        "error": None,
    }
    try:
        result = decode(text, DecoderContext.from_channel(ch, home))
        path = prepare(result.blocks, ch, home)
        ranges = find_ranges(path, ch)
    except Exception as exc:  # the page still shows the live values
        base["error"] = f"the path cannot be drawn: {type(exc).__name__}: {exc}"
        return Geometry(ch.channel_id, _encode(base), (), lines)
    if len(ch.axes) < 2:
        return Geometry(ch.channel_id, _encode(base), (), lines)
    pts, at = _points(path)
    step = max(1, math.ceil(len(pts) / MAX_POINTS))
    base["path"] = _thin(pts, step)
    base["ranges"] = _spans(ranges, at, step, max(1, len(base["path"])), ch)
    info = sorted(
        (
            rng.start.line,
            rng.end_line,
            rng.start.axis,
            _method(rng, ch),
            rng.suppressed,
            round(rng.start.target * MM, 4),
            round(rng.start.pos_limit * MM, 4),
        )
        for rng in ranges
    )
    if result.first_error is not None:
        err = result.first_error
        base["error"] = f"NC error {err.id} in line {err.line}: {err.message}"
    return Geometry(ch.channel_id, _encode(base), tuple(info), lines, tuple(r[0] for r in info))


def _encode(drawing: dict[str, Any]) -> bytes:
    return json.dumps(drawing, separators=(",", ":"), allow_nan=False).encode()
