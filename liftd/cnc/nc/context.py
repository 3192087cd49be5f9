"""What the decoder knows of the channel: axes, lift axis and method, software limits, start
position, circle tolerance, slope, configured M functions, tool radii, zero offsets and the
subroutine files the caller read for the program (SI units)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from liftd.cnc.nc.blocks import ErrorId, Motion, NcFault
from liftd.cnc.params import ChannelParams, LiftMethod, NcSources, SlopeType
from liftd.cnc.path.geometry import ArcSeg

# Subroutine nesting: the TF5200 subroutine page says the depth is "fixed" by the system
# (https://infosys.beckhoff.com/content/1033/tf5200_programming_manual/206822155.html) without
# naming the number in our copy; ID 20360 reports the limit. liftd uses 20 levels below the
# main program, the figure of the ISG system parameter overview as we remember it
# (not confirmed from a page we could read).
MAX_CALL_DEPTH = 20


@dataclass(frozen=True, slots=True)
class DecoderContext:
    axis_names: tuple[str, ...]
    lift_axis: str
    lift_method: LiftMethod
    sw_limits: tuple[tuple[float, float], ...]  # (neg, pos) per axis, m
    start_position: tuple[float, ...]  # m
    max_radius_diff: float  # m, P-CHAN-00171
    slope: SlopeType
    configured_m: frozenset[int]
    tool_radii: dict[int, float] = field(default_factory=dict)  # D number -> m
    zero_offsets: dict[int, tuple[float, ...]] = field(default_factory=dict)  # group -> m
    zero_offset_default: int = 0  # group active at program start (P-ZERO-00002)
    g53_offsets: bool = False  # G53 applies group 0 (P-ZERO-00001)
    sources: NcSources = field(default_factory=NcSources)
    max_executed_blocks: int = 2_000_000
    max_call_depth: int = MAX_CALL_DEPTH

    @staticmethod
    def from_channel(ch: ChannelParams, start: tuple[float, ...] | None = None) -> DecoderContext:
        return DecoderContext(
            axis_names=ch.axis_names,
            lift_axis=ch.lift_axis,
            lift_method=ch.lift_method,
            sw_limits=tuple((ax.sw_limit_neg, ax.sw_limit_pos) for ax in ch.axes),
            start_position=start if start is not None else tuple(0.0 for _ in ch.axes),
            max_radius_diff=ch.max_radius_diff,
            slope=ch.slope,
            configured_m=frozenset(num for num, _ in ch.m_synch),
            tool_radii=dict(ch.tool_radii),
            zero_offsets=dict(ch.zero_offsets),
            zero_offset_default=ch.zero_offset_default,
            g53_offsets=ch.g53_offsets,
            sources=ch.nc_sources,
            max_executed_blocks=ch.max_executed_blocks,
        )

    def check_position(self, k: int, value: float, column: int) -> None:
        """NcFault 50041 / 50042 if axis k at `value` (m) is beyond a software limit."""
        neg, pos = self.sw_limits[k]
        name = self.axis_names[k]
        if value > pos + 1e-12:
            raise NcFault(
                ErrorId.SW_LIMIT_POS,
                column,
                f"{name} {value * 1e3:.4f} mm beyond the "
                f"positive software limit {pos * 1e3:.4f} mm (P-AXIS-00178)",
            )
        if value < neg - 1e-12:
            raise NcFault(
                ErrorId.SW_LIMIT_NEG,
                column,
                f"{name} {value * 1e3:.4f} mm beyond the "
                f"negative software limit {neg * 1e3:.4f} mm (P-AXIS-00177)",
            )

    def check_motion(self, motion: Motion, column: int) -> None:
        """NcFault 50041 / 50042 if the end of a motion, or an arc's extent, is beyond a software
        limit (the start was checked as the previous end)."""
        limits = self.sw_limits
        for k, (value, (neg, pos)) in enumerate(zip(motion.end, limits, strict=True)):
            if not neg - 1e-12 <= value <= pos + 1e-12:
                self.check_position(k, value, column)
        center = motion.center
        if center is not None:
            r = math.hypot(motion.start[0] - center[0], motion.start[1] - center[1])
            (n0, p0), (n1, p1) = limits[0], limits[1]
            if (
                n0 <= center[0] - r
                and center[0] + r <= p0
                and n1 <= center[1] - r
                and (center[1] + r <= p1)
            ):
                return  # the whole circle is inside: no need for the arc's extent
            arc = ArcSeg.make(motion.start, motion.end, center, motion.sweep)
            for k, (lo, hi) in enumerate(arc.axis_extent()):
                self.check_position(k, lo, column)
                self.check_position(k, hi, column)
