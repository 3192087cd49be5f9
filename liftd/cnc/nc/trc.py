"""Tool radius compensation (TRC) G40/G41/G42 in the G17 plane: the decoder hands over the
programmed blocks (machine coordinates), this module returns the blocks of the tool centre
path, lines and arcs, one programmed block late (a corner needs the next element).

ISG behaviour followed (TF5200 programming manual, tool radius compensation
https://infosys.beckhoff.com/content/1033/tf5200_programming_manual/207729163.html):
* G41 tool left of the contour, G42 right; the radius comes with the D word (tool data
  wz[i].radius, P-TOOL-00004); a negative radius swaps the side.
* Selection: the next motion block in the plane is the approach block and must be linear
  (ID 90008). G139 (default, "indirect"): the approach runs from the uncompensated position to
  the corner point of its own offset line with the first contour element, like any corner;
  G138 ("direct"): straight to the first element's compensated start point.
* Deselection (G40): the next motion block in the plane is the retract block and must be linear
  (the manual: departing blocks only for straight lines; no id found, liftd's own); default: it
  starts at the corner point with the last element, with G138: at the last element's
  compensated end point; it ends at the programmed (uncompensated) point.
* Contour change G41 <-> G42: a deselection and a selection in one linear block.
* Corners: an inner corner trims both elements at the intersection of their offsets; an outer
  corner gets a circular transition around the programmed corner point (G26-like; with a
  radius change at the corner, a straight transition). Elements that would run against the
  programmed contour are a contour violation ("Limits of TRC": an interim block in the opposite
  direction, https://infosys.beckhoff.com/content/1033/tf5200_programming_manual/207844107.html;
  no id documented, liftd's own). An arc whose offset radius is not positive is ID 90017.
* Blocks without motion in the plane (M functions, dwell, Z-only moves) wait with the held
  element and run at the corner point; more than MAX_NON_RELEVANT of them in a row is ID 90011.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from liftd.cnc.nc.blocks import Block, ErrorId, Motion, MotionKind, NcFault

Point = tuple[float, float]
EPS = 1e-9  # m: points closer than this are the same point
MAX_NON_RELEVANT = 1000  # blocks without plane motion held at one corner (ID 90011)
TWO_PI = 2.0 * math.pi


def _sub(a: Point, b: Point) -> Point:
    return (a[0] - b[0], a[1] - b[1])


def _dot(a: Point, b: Point) -> float:
    return a[0] * b[0] + a[1] * b[1]


def _cross(a: Point, b: Point) -> float:
    return a[0] * b[1] - a[1] * b[0]


def _dist(a: Point, b: Point) -> float:
    return math.hypot(a[0] - b[0], a[1] - b[1])


def _unit(v: Point) -> Point:
    n = math.hypot(v[0], v[1])
    return (v[0] / n, v[1] / n)


def _left(t: Point) -> Point:
    return (-t[1], t[0])


def _ccw_angle(a: float, b: float) -> float:
    """Angle from a to b counter-clockwise, in [0, 2π)."""
    return (b - a) % TWO_PI


class TrcFault(NcFault):
    """A TRC error found while finishing a held block: it belongs to `line` of `file`."""

    def __init__(self, error_id: ErrorId, message: str, block: Block) -> None:
        super().__init__(error_id, 1, message)
        self.block = block


class _Element:
    """One programmed element of the contour in the plane, with its offset geometry
    (tangents and offset points at both ends computed once)."""

    __slots__ = (
        "approach", "arc", "block", "ccw", "center", "direct", "p0", "p1", "q0", "q1", "r",
        "roff", "side", "start", "sweep", "t0", "t1",
    )  # fmt: skip

    def __init__(
        self, block: Block, side: int, r: float, start: Point, p0: Point, p1: Point,
        center: Point | None = None, sweep: float = 0.0, approach: bool = False,
    ) -> None:  # fmt: skip
        self.block = block
        self.side = side  # +1 left (G41), -1 right (G42)
        self.r = r  # tool radius, m
        self.start = start  # compensated start (trimmed by the previous corner, or approach)
        self.p0 = p0  # programmed start
        self.p1 = p1  # programmed end
        self.arc = center is not None
        self.center = center if center is not None else (0.0, 0.0)
        self.sweep = sweep  # programmed sweep, signed
        self.ccw = sweep > 0.0
        self.approach = approach  # start not offset (selection block)
        self.direct = False  # G138 approach: ends at the next element's compensated start
        self.roff = 0.0  # offset radius of an arc
        self.set_side(side)

    def set_side(self, side: int) -> None:
        self.side = side
        if not self.arc:
            p0, p1 = self.p0, self.p1
            dx, dy = p1[0] - p0[0], p1[1] - p0[1]
            length = math.hypot(dx, dy)
            tx, ty = dx / length, dy / length
            self.t0 = self.t1 = (tx, ty)
            k = side * self.r
            nx, ny = -ty * k, tx * k  # the left normal times the signed radius
            self.q0 = (p0[0] + nx, p0[1] + ny)
            self.q1 = (p1[0] + nx, p1[1] + ny)
            return
        c = self.center
        radius = _dist(self.p0, c)
        self.roff = radius - side * (1.0 if self.ccw else -1.0) * self.r
        r0 = _unit(_sub(self.p0, c))
        r1 = _unit(_sub(self.p1, c))
        self.t0 = _left(r0) if self.ccw else (r0[1], -r0[0])
        self.t1 = _left(r1) if self.ccw else (r1[1], -r1[0])
        k = self.roff
        self.q0 = (c[0] + k * r0[0], c[1] + k * r0[1])
        self.q1 = (c[0] + k * r1[0], c[1] + k * r1[1])

    def tangent(self, at_end: bool) -> Point:
        return self.t1 if at_end else self.t0

    def offset_point(self, at_end: bool) -> Point:
        return self.q1 if at_end else self.q0

    def intersections(self, other: _Element) -> list[Point]:
        """Points where the offset geometries (infinite line / full circle) meet."""
        if not self.arc and not other.arc:
            return _line_line(self.q0, self.t0, other.q0, other.t0)
        if not self.arc:
            return _line_circle(self.q0, self.t0, other.center, other.roff)
        if not other.arc:
            return _line_circle(other.q0, other.t0, self.center, self.roff)
        return _circle_circle(self.center, self.roff, other.center, other.roff)


def _line_line(q: Point, t: Point, q2: Point, t2: Point) -> list[Point]:
    den = _cross(t, t2)
    if abs(den) < 1e-15:
        return []
    u = _cross(_sub(q2, q), t2) / den
    return [(q[0] + u * t[0], q[1] + u * t[1])]


def _line_circle(q: Point, t: Point, c: Point, r: float) -> list[Point]:
    d = _sub(q, c)
    b = _dot(t, d)
    disc = b * b - (_dot(d, d) - r * r)
    if disc < -1e-18:
        return []
    root = math.sqrt(max(disc, 0.0))
    return [(q[0] + u * t[0], q[1] + u * t[1]) for u in (-b - root, -b + root)]


def _circle_circle(c1: Point, r1: float, c2: Point, r2: float) -> list[Point]:
    d = _dist(c1, c2)
    if d < EPS or d > r1 + r2 + EPS or d < abs(r1 - r2) - EPS:
        return []
    a = (r1 * r1 - r2 * r2 + d * d) / (2.0 * d)
    h = math.sqrt(max(r1 * r1 - a * a, 0.0))
    ex = ((c2[0] - c1[0]) / d, (c2[1] - c1[1]) / d)
    m = (c1[0] + a * ex[0], c1[1] + a * ex[1])
    return [(m[0] - h * ex[1], m[1] + h * ex[0]), (m[0] + h * ex[1], m[1] - h * ex[0])]


def _arc_sweep(center: Point, a: Point, b: Point, ccw: bool, full_if_closed: bool) -> float:
    """Signed sweep from a to b around center in the given direction."""
    ang_a = math.atan2(a[1] - center[1], a[0] - center[0])
    ang_b = math.atan2(b[1] - center[1], b[0] - center[0])
    delta = _ccw_angle(ang_a, ang_b) if ccw else _ccw_angle(ang_b, ang_a)
    if delta < 1e-12 and full_if_closed:
        delta = TWO_PI
    return delta if ccw else -delta


@dataclass(slots=True)
class Trc:
    """TRC state of a channel between blocks."""

    side: int = 0  # programmed: 0 G40, +1 G41, -1 G42
    radius: float = 0.0  # of the selected D word, m
    direct: bool = False  # G138 (True) / G139 (False, initial state)
    held: _Element | None = None
    after: list[Block] = field(default_factory=list)
    pending: str = ""  # "select" | "deselect" | "change" until the next plane motion
    radius_changed: bool = False
    # blocks go through TRC: compensation on, a held element, or a (de)selection pending
    engaged: bool = False

    def _update(self) -> None:
        self.engaged = self.side != 0 or self.held is not None or bool(self.pending)

    def set_side(self, side: int) -> None:
        if side == self.side:
            return
        if self.side == 0:
            self.pending = "select"
        elif side == 0:
            self.pending = "deselect"
        else:
            self.pending = "change"
        self.side = side
        self._update()

    def set_radius(self, radius: float) -> None:
        if radius != self.radius and self.held is not None:
            self.radius_changed = True
        self.radius = radius

    # -- blocks -------------------------------------------------------------------------------
    def process(self, block: Block) -> list[Block]:
        """Feed one decoded block; returns the blocks that are final now, in order."""
        try:
            return self._process(block)
        finally:
            self._update()

    def _process(self, block: Block) -> list[Block]:
        m = block.motion
        relevant = m is not None and (
            m.center is not None
            or abs(m.end[0] - m.start[0]) > EPS
            or abs(m.end[1] - m.start[1]) > EPS
        )
        if not relevant:
            if self.held is None:
                return [block]
            if len(self.after) >= MAX_NON_RELEVANT:
                raise NcFault(
                    ErrorId.TRC_NON_RELEVANT_BLOCKS,
                    1,
                    f"more than {MAX_NON_RELEVANT} blocks without motion in the plane while "
                    "tool radius compensation waits for the next contour element",
                )
            self.after.append(block)
            return []
        assert m is not None
        arc = m.center is not None
        if self.pending in ("select", "change"):
            if arc:
                raise NcFault(
                    ErrorId.TRC_SELECT_ARC,
                    1,
                    "tool radius compensation is selected with a circular block: the approach "
                    "block must be linear",
                )
            out: list[Block] = []
            start: Point = (m.start[0], m.start[1])
            if self.pending == "change" and self.held is not None:
                old = self.held
                end = old.offset_point(True)
                out.extend(self._finish(old, end, []))
                start = end
            self.pending = ""
            self.radius_changed = False
            self.held = self._element(block, start, approach=True)
            self.held.direct = self.direct
            return out
        if self.pending == "deselect":
            if arc:
                raise NcFault(
                    ErrorId.TRC_DESELECT_ARC,
                    1,
                    "tool radius compensation is deselected with a circular block: the retract "
                    "block must be linear",
                )
            self.pending = ""
            last = self.held
            if last is None:
                return [block]
            retract = self._element(block, (m.start[0], m.start[1]), approach=False)
            retract.set_side(last.side)
            if self.direct:
                a_end = last.offset_point(True)
                out = self._finish(last, a_end, [])
                start = a_end
            else:
                a_end, transition, start = self._corner(last, retract)
                out = self._finish(last, a_end, transition)
            self.held = None
            tail = (m.end[0], m.end[1])
            if _dot(_sub(tail, start), retract.tangent(False)) < -EPS:
                raise TrcFault(
                    ErrorId.TRC_CONTOUR_VIOLATION,
                    "contour violation: the retract block is shorter than the tool radius",
                    block,
                )
            out.append(_with_motion(block, _line_motion(m, start, tail)))
            return out
        if self.held is None:
            return [block]
        if arc and self.radius_changed:
            raise NcFault(
                ErrorId.TRC_RADIUS_CHANGE_ARC,
                1,
                "the tool radius changes with active TRC right before a circular block "
                "(change it with a linear block)",
            )
        self.radius_changed = False
        held = self.held
        nxt = self._element(block, (m.start[0], m.start[1]), approach=False)
        a_end, transition, b_start = self._corner(held, nxt)
        out = self._finish(held, a_end, transition)
        nxt.start = b_start
        self.held = nxt
        return out

    def flush(self) -> list[Block]:
        """End of the program, or an error: the held element ends at its offset end point."""
        held = self.held
        if held is None:
            return []
        self.held = None
        self._update()
        return self._finish(held, held.offset_point(True), [])

    # -- geometry -----------------------------------------------------------------------------
    def _element(self, block: Block, start: Point, approach: bool) -> _Element:
        m = block.motion
        assert m is not None
        side = self.side if self.side != 0 else 1
        r = self.radius
        if r < 0.0:  # a negative radius swaps the side (programming manual, TRC)
            side, r = -side, -r
        p0 = (m.start[0], m.start[1])
        p1 = (m.end[0], m.end[1])
        if m.center is None:
            return _Element(block, side, r, start, p0, p1, approach=approach)
        el = _Element(block, side, r, start, p0, p1, m.center, m.sweep, approach)
        if el.roff <= EPS:
            radius = _dist(p0, m.center)
            raise TrcFault(
                ErrorId.TRC_RADIUS_TOO_LARGE,
                f"tool radius {r * 1e3:.4f} mm is not smaller than the radius "
                f"{radius * 1e3:.4f} mm of the arc it compensates inside",
                block,
            )
        if not approach:
            el.start = el.q0
        return el

    def _corner(self, a: _Element, b: _Element) -> tuple[Point, list[Motion], Point]:
        """End of a, transition motions, start of b at their common programmed point."""
        qb = b.q0
        if a.approach and a.direct:
            return qb, [], qb
        qa = a.q1
        if abs(qa[0] - qb[0]) < EPS and abs(qa[1] - qb[1]) < EPS:
            return qa, [], qb
        ta = a.t1
        tb = b.t0
        turn = ta[0] * tb[1] - ta[1] * tb[0]
        inner = a.side * turn > 0.0 and a.side == b.side
        corner = a.p1
        if inner:
            points = a.intersections(b)
            if not points:
                raise TrcFault(
                    ErrorId.TRC_CONTOUR_VIOLATION,
                    "contour violation: the compensated elements do not meet at this corner "
                    "(tool radius too large for the contour)",
                    b.block,
                )
            q = points[0]
            if len(points) > 1 and _dist(points[1], corner) < _dist(q, corner):
                q = points[1]
            self._check_end(a, q)
            self._check_start(b, q)
            return q, [], q
        if a.r == b.r and a.side == b.side and a.r > 0.0:
            ccw = a.side < 0  # G41 goes round an outer corner clockwise, G42 counter-clockwise
            sweep = _arc_sweep(corner, qa, qb, ccw, full_if_closed=False)
            return qa, [_arc_motion(b.block, qa, qb, corner, sweep)], qb
        return qa, [_line_only(b.block, qa, qb)], qb

    def _check_end(self, a: _Element, q: Point) -> None:
        if not a.arc:
            t = a.t1
            if (q[0] - a.start[0]) * t[0] + (q[1] - a.start[1]) * t[1] < -EPS:
                raise TrcFault(
                    ErrorId.TRC_CONTOUR_VIOLATION,
                    "contour violation: the compensated path of this block would run against "
                    "the programmed direction (the element is shorter than the tool allows)",
                    a.block,
                )
            return
        new = abs(_arc_sweep(a.center, a.start, q, a.ccw, full_if_closed=True))
        if new > abs(a.sweep) + 1e-9 and _dist(a.start, q) > EPS:
            raise TrcFault(
                ErrorId.TRC_CONTOUR_VIOLATION,
                "contour violation: the compensated arc of this block would run backwards",
                a.block,
            )

    def _check_start(self, b: _Element, q: Point) -> None:
        if not b.arc:
            t, end = b.t0, b.q1
            if (end[0] - q[0]) * t[0] + (end[1] - q[1]) * t[1] < -EPS:
                raise TrcFault(
                    ErrorId.TRC_CONTOUR_VIOLATION,
                    "contour violation: the compensated path of this block would run against "
                    "the programmed direction (the element is shorter than the tool allows)",
                    b.block,
                )
            return
        new = abs(_arc_sweep(b.center, q, b.offset_point(True), b.ccw, full_if_closed=True))
        if new > abs(b.sweep) + 1e-9:
            raise TrcFault(
                ErrorId.TRC_CONTOUR_VIOLATION,
                "contour violation: the compensated arc of this block would run backwards",
                b.block,
            )

    def _finish(self, a: _Element, end: Point, transition: list[Motion]) -> list[Block]:
        """The held element as a compensated block, its transition, then the blocks that
        waited at its corner (their plane coordinates moved to where the tool is)."""
        m = a.block.motion
        assert m is not None
        out: list[Block] = []
        block = a.block
        if a.arc:
            sweep = _arc_sweep(a.center, a.start, end, a.ccw, full_if_closed=True)
            if abs(sweep) > abs(a.sweep) + 1e-9:  # a full circle stays one
                sweep = a.sweep
            motion = Motion(m.kind, _with_xy(m.start, a.start), _with_xy(m.end, end), m.feed,
                            a.center, sweep)  # fmt: skip
            out.append(_with_motion(block, motion))
        elif abs(a.start[0] - end[0]) > EPS or abs(a.start[1] - end[1]) > EPS:
            out.append(_with_motion(block, _line_motion(m, a.start, end)))
        else:
            out.append(_with_motion(block, None))
        for t in transition:
            out.append(Block(a.block.line, a.block.n, motion=t, file=a.block.file))
        where = transition[-1].end[:2] if transition else end
        if self.after:
            for waiting in self.after:
                bm = waiting.motion
                if bm is not None:
                    moved = bm._replace(start=_with_xy(bm.start, where),
                                        end=_with_xy(bm.end, where))  # fmt: skip
                    waiting = _with_motion(waiting, moved)  # noqa: PLW2901
                out.append(waiting)
            self.after = []
        return out


def _with_motion(block: Block, motion: Motion | None) -> Block:
    """The block with another motion (NamedTuple._replace is several times slower)."""
    return Block(block[0], block[1], motion, *block[3:])


def _with_xy(pos: tuple[float, ...], xy: tuple[float, ...]) -> tuple[float, ...]:
    return (xy[0], xy[1], *pos[2:])


def _line_motion(m: Motion, start: Point, end: Point) -> Motion:
    kind = m.kind if m.kind in (MotionKind.RAPID, MotionKind.LINEAR) else MotionKind.LINEAR
    return Motion(kind, _with_xy(m.start, start), _with_xy(m.end, end), m.feed)


def _arc_motion(nxt: Block, a: Point, b: Point, center: Point, sweep: float) -> Motion:
    m = nxt.motion
    assert m is not None
    kind = MotionKind.ARC_CCW if sweep > 0.0 else MotionKind.ARC_CW
    feed = m.feed
    return Motion(kind, _with_xy(m.start, a), _with_xy(m.start, b), feed, center, sweep)


def _line_only(nxt: Block, a: Point, b: Point) -> Motion:
    m = nxt.motion
    assert m is not None
    kind = MotionKind.RAPID if m.kind is MotionKind.RAPID else MotionKind.LINEAR
    return Motion(kind, _with_xy(m.start, a), _with_xy(m.start, b), m.feed)
