"""Build a G02/G03 circle in the G17 plane from the programmed words, with the ISG checks.

Centre by I/J (relative to the start under G162, absolute under G161) or by radius R (G163:
R > 0 shorter arc, R < 0 longer arc; a full circle with R is error 20034). The difference of
start and end radius must not exceed P-CHAN-00171 (error 21758); an accepted difference is
removed by moving the centre onto the perpendicular bisector (liftd's choice, documented in
docs/behaviour.md), so the arc is an exact circle through both points.
"""

from __future__ import annotations

import math

from liftd.cnc.nc.blocks import ErrorId, NcFault
from liftd.cnc.path.geometry import arc_sweep, center_from_radius, corrected_center

ROUNDING = 1e-9  # relative: a radius difference below it is floating-point rounding
# Positions are SGN32 in 0.1 µm on the CNC: "the end point of the circular arc may not exceed
# the maximum traverse range +- 2,14*10^5 mm of the axes" (TF5200 "Radius programming (R,
# G163)", https://infosys.beckhoff.com/content/1033/tccncprogramming/15556764811.html). A centre
# beyond it is ID 20054, "Corrected centre point out of data format" (its example: G02 X1
# R1000000, https://infosys.beckhoff.com/content/1031/tf5200_diagnosis/250663051.html). Here
# also for a centre programmed by I/J (no kernel id found for that case; 20054 is the closest):
# such a centre made the radius check's rounding tolerance (relative to the radius) absorb any
# difference, and a huge R gave a NaN centre that crashed the software-limit check.
MAX_COORDINATE = (2**31 - 1) * 1e-7  # m: 214748.3647 mm


def build_arc(
    start: tuple[float, ...],
    end: tuple[float, ...],
    ccw: bool,
    i_j: tuple[float | None, float | None],
    center_absolute: bool,
    radius: float | None,
    max_radius_diff: float,
    column: int,
) -> tuple[tuple[float, float], float]:
    """Return (centre, signed sweep) or raise NcFault."""
    if len(start) < 2:
        raise NcFault(ErrorId.ARC_GEOMETRY, column, "circles need two axes in the G17 plane")
    for k in range(2, len(start)):
        if abs(end[k] - start[k]) > 0.0:
            raise NcFault(
                ErrorId.HELIX,
                column,
                "circle with motion outside the G17 plane (helix) is not emulated",
            )
    p0 = (start[0], start[1])
    p1 = (end[0], end[1])
    if i_j != (None, None):
        i = i_j[0] or 0.0
        j = i_j[1] or 0.0
        center = (i, j) if center_absolute else (p0[0] + i, p0[1] + j)
        _check_centre(center, column)
        r0 = math.hypot(p0[0] - center[0], p0[1] - center[1])
        r1 = math.hypot(p1[0] - center[0], p1[1] - center[1])
        if r0 <= 0.0:
            raise NcFault(ErrorId.ARC_GEOMETRY, column, "circle centre equals the start point")
        diff = abs(r0 - r1)
        # Positions are mm × 1e-3 (+ zero offsets) in floating point, so an exact circle's two
        # radii can differ by a few ulps (demo.nc line 15 with P-CHAN-00171 = 0: 1e-17 m). Such
        # a difference is rounding, not geometry: it is absorbed by a tolerance of 1e-9 of the
        # coordinates' size (1 nm at 1 m), far below the CNC's 0.1 µm resolution and far above
        # the rounding of a few operations on doubles (~1e-16 relative).
        scale = max(abs(p0[0]), abs(p0[1]), abs(p1[0]), abs(p1[1]), r0, r1)
        if diff > max_radius_diff + ROUNDING * scale:
            raise NcFault(
                ErrorId.RADIUS_DIFFERENCE,
                column,
                f"end point not on the circle: start radius {r0 * 1e3:.4f} mm, end radius "
                f"{r1 * 1e3:.4f} mm, difference {diff * 1e3:.6f} mm > "
                f"{max_radius_diff * 1e3:.6f} mm (P-CHAN-00171)",
            )
        center = corrected_center(p0, p1, center)
    else:
        if radius is None:
            raise NcFault(ErrorId.ARC_GEOMETRY, column, "circle needs I/J or R")
        if math.hypot(p1[0] - p0[0], p1[1] - p0[1]) == 0.0:
            raise NcFault(
                ErrorId.FULL_CIRCLE_RADIUS,
                column,
                "full circle cannot be programmed with R; use I/J",
            )
        if abs(radius) > 2.0 * MAX_COORDINATE:  # r * r would overflow; the centre is beyond
            raise NcFault(
                ErrorId.CENTRE_OUT_OF_RANGE,
                column,
                f"R {radius * 1e3:.6g} mm puts the circle centre beyond the position data format "
                f"(±{MAX_COORDINATE * 1e3:.4f} mm)",
            )
        found = center_from_radius(p0, p1, radius, ccw)
        if found is None:
            raise NcFault(
                ErrorId.ARC_GEOMETRY,
                column,
                f"radius {abs(radius) * 1e3:.4f} mm is smaller than half the chord",
            )
        center = found
        _check_centre(center, column)
    return center, arc_sweep(p0, p1, center, ccw)


def _check_centre(center: tuple[float, float], column: int) -> None:
    for value in center:
        if not abs(value) <= MAX_COORDINATE:  # also NaN
            raise NcFault(
                ErrorId.CENTRE_OUT_OF_RANGE,
                column,
                f"circle centre {value * 1e3:.6g} mm beyond the position data format "
                f"(±{MAX_COORDINATE * 1e3:.4f} mm)",
            )
