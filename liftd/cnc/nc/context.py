"""What the decoder knows of the channel: axes, lift axis and method, software limits, start
position, circle tolerance, slope and configured M functions (SI units)."""

from __future__ import annotations

from dataclasses import dataclass

from liftd.cnc.nc.blocks import ErrorId, NcFault
from liftd.cnc.params import ChannelParams, LiftMethod, SlopeType


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
