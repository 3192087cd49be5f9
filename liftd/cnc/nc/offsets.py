"""Offset geometry of contour elements in the G17 plane, for tool radius compensation
(trc.py): a programmed line or arc with its tangents and offset points at both ends, and where
the offset geometries of two elements (infinite lines, full circles) meet."""

from __future__ import annotations

import math

from liftd.cnc.nc.blocks import Block

Point = tuple[float, float]
EPS = 1e-9  # m: points closer than this are the same point
TWO_PI = 2.0 * math.pi


def sub(a: Point, b: Point) -> Point:
    return (a[0] - b[0], a[1] - b[1])


def dot(a: Point, b: Point) -> float:
    return a[0] * b[0] + a[1] * b[1]


def cross(a: Point, b: Point) -> float:
    return a[0] * b[1] - a[1] * b[0]


def dist(a: Point, b: Point) -> float:
    return math.hypot(a[0] - b[0], a[1] - b[1])


def unit(v: Point) -> Point:
    n = math.hypot(v[0], v[1])
    return (v[0] / n, v[1] / n)


def left(t: Point) -> Point:
    return (-t[1], t[0])


def ccw_angle(a: float, b: float) -> float:
    """Angle from a to b counter-clockwise, in [0, 2π)."""
    return (b - a) % TWO_PI


class Element:
    """One programmed element of the contour in the plane, with its offset geometry
    (tangents and offset points at both ends computed once)."""

    __slots__ = (
        "approach",
        "arc",
        "block",
        "ccw",
        "center",
        "direct",
        "p0",
        "p1",
        "q0",
        "q1",
        "r",
        "roff",
        "side",
        "start",
        "sweep",
        "t0",
        "t1",
    )

    def __init__(
        self,
        block: Block,
        side: int,
        r: float,
        start: Point,
        p0: Point,
        p1: Point,
        center: Point | None = None,
        sweep: float = 0.0,
        approach: bool = False,
    ) -> None:
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
        radius = dist(self.p0, c)
        self.roff = radius - side * (1.0 if self.ccw else -1.0) * self.r
        r0 = unit(sub(self.p0, c))
        r1 = unit(sub(self.p1, c))
        self.t0 = left(r0) if self.ccw else (r0[1], -r0[0])
        self.t1 = left(r1) if self.ccw else (r1[1], -r1[0])
        k = self.roff
        self.q0 = (c[0] + k * r0[0], c[1] + k * r0[1])
        self.q1 = (c[0] + k * r1[0], c[1] + k * r1[1])

    def tangent(self, at_end: bool) -> Point:
        return self.t1 if at_end else self.t0

    def offset_point(self, at_end: bool) -> Point:
        return self.q1 if at_end else self.q0

    def intersections(self, other: Element) -> list[Point]:
        """Points where the offset geometries (infinite line / full circle) meet."""
        if not self.arc and not other.arc:
            return line_line(self.q0, self.t0, other.q0, other.t0)
        if not self.arc:
            return line_circle(self.q0, self.t0, other.center, other.roff)
        if not other.arc:
            return line_circle(other.q0, other.t0, self.center, self.roff)
        return circle_circle(self.center, self.roff, other.center, other.roff)


def line_line(q: Point, t: Point, q2: Point, t2: Point) -> list[Point]:
    den = cross(t, t2)
    if abs(den) < 1e-15:
        return []
    u = cross(sub(q2, q), t2) / den
    return [(q[0] + u * t[0], q[1] + u * t[1])]


def line_circle(q: Point, t: Point, c: Point, r: float) -> list[Point]:
    d = sub(q, c)
    b = dot(t, d)
    disc = b * b - (dot(d, d) - r * r)
    if disc < -1e-18:
        return []
    root = math.sqrt(max(disc, 0.0))
    return [(q[0] + u * t[0], q[1] + u * t[1]) for u in (-b - root, -b + root)]


def circle_circle(c1: Point, r1: float, c2: Point, r2: float) -> list[Point]:
    d = dist(c1, c2)
    if d < EPS or d > r1 + r2 + EPS or d < abs(r1 - r2) - EPS:
        return []
    a = (r1 * r1 - r2 * r2 + d * d) / (2.0 * d)
    h = math.sqrt(max(r1 * r1 - a * a, 0.0))
    ex = ((c2[0] - c1[0]) / d, (c2[1] - c1[1]) / d)
    m = (c1[0] + a * ex[0], c1[1] + a * ex[1])
    return [(m[0] - h * ex[1], m[1] + h * ex[0]), (m[0] + h * ex[1], m[1] - h * ex[0])]


def arc_sweep(center: Point, a: Point, b: Point, ccw: bool, full_if_closed: bool) -> float:
    """Signed sweep from a to b around center in the given direction."""
    ang_a = math.atan2(a[1] - center[1], a[0] - center[0])
    ang_b = math.atan2(b[1] - center[1], b[0] - center[0])
    delta = ccw_angle(ang_a, ang_b) if ccw else ccw_angle(ang_b, ang_a)
    if delta < 1e-12 and full_if_closed:
        delta = TWO_PI
    return delta if ccw else -delta
