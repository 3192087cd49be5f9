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

from dataclasses import dataclass, field

from liftd.cnc.nc.blocks import Block, ErrorId, Motion, MotionKind, NcFault
from liftd.cnc.nc.offsets import EPS, Element, Point, arc_sweep, dist, dot, sub

MAX_NON_RELEVANT = 1000  # blocks without plane motion held at one corner (ID 90011)


class TrcFault(NcFault):
    """A TRC error found while finishing a held block: it belongs to `line` of `file`."""

    def __init__(self, error_id: ErrorId, message: str, block: Block) -> None:
        super().__init__(error_id, 1, message)
        self.block = block


@dataclass(slots=True)
class Trc:
    """TRC state of a channel between blocks."""

    side: int = 0  # programmed: 0 G40, +1 G41, -1 G42
    radius: float = 0.0  # of the selected D word, m
    direct: bool = False  # G138 (True) / G139 (False, initial state)
    held: Element | None = None
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
            if dot(sub(tail, start), retract.tangent(False)) < -EPS:
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
    def _element(self, block: Block, start: Point, approach: bool) -> Element:
        m = block.motion
        assert m is not None
        side = self.side if self.side != 0 else 1
        r = self.radius
        if r < 0.0:  # a negative radius swaps the side (programming manual, TRC)
            side, r = -side, -r
        p0 = (m.start[0], m.start[1])
        p1 = (m.end[0], m.end[1])
        if m.center is None:
            return Element(block, side, r, start, p0, p1, approach=approach)
        el = Element(block, side, r, start, p0, p1, m.center, m.sweep, approach)
        if el.roff <= EPS:
            radius = dist(p0, m.center)
            raise TrcFault(
                ErrorId.TRC_RADIUS_TOO_LARGE,
                f"tool radius {r * 1e3:.4f} mm is not smaller than the radius "
                f"{radius * 1e3:.4f} mm of the arc it compensates inside",
                block,
            )
        if not approach:
            el.start = el.q0
        return el

    def _corner(self, a: Element, b: Element) -> tuple[Point, list[Motion], Point]:
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
            if len(points) > 1 and dist(points[1], corner) < dist(q, corner):
                q = points[1]
            self._check_end(a, q)
            self._check_start(b, q)
            return q, [], q
        if a.r == b.r and a.side == b.side and a.r > 0.0:
            ccw = a.side < 0  # G41 goes round an outer corner clockwise, G42 counter-clockwise
            sweep = arc_sweep(corner, qa, qb, ccw, full_if_closed=False)
            return qa, [_arc_motion(b.block, qa, qb, corner, sweep)], qb
        return qa, [_line_only(b.block, qa, qb)], qb

    def _check_end(self, a: Element, q: Point) -> None:
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
        new = abs(arc_sweep(a.center, a.start, q, a.ccw, full_if_closed=True))
        if new > abs(a.sweep) + 1e-9 and dist(a.start, q) > EPS:
            raise TrcFault(
                ErrorId.TRC_CONTOUR_VIOLATION,
                "contour violation: the compensated arc of this block would run backwards",
                a.block,
            )

    def _check_start(self, b: Element, q: Point) -> None:
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
        new = abs(arc_sweep(b.center, q, b.offset_point(True), b.ccw, full_if_closed=True))
        if new > abs(b.sweep) + 1e-9:
            raise TrcFault(
                ErrorId.TRC_CONTOUR_VIOLATION,
                "contour violation: the compensated arc of this block would run backwards",
                b.block,
            )

    def _finish(self, a: Element, end: Point, transition: list[Motion]) -> list[Block]:
        """The held element as a compensated block, its transition, then the blocks that
        waited at its corner (their plane coordinates moved to where the tool is)."""
        m = a.block.motion
        assert m is not None
        out: list[Block] = []
        block = a.block
        if a.arc:
            sweep = arc_sweep(a.center, a.start, end, a.ccw, full_if_closed=True)
            if abs(sweep) > abs(a.sweep) + 1e-9:  # a full circle stays one
                sweep = a.sweep
            motion = Motion(
                m.kind, _with_xy(m.start, a.start), _with_xy(m.end, end), m.feed, a.center, sweep
            )
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
                    moved = bm._replace(
                        start=_with_xy(bm.start, where), end=_with_xy(bm.end, where)
                    )
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
