"""The demo machine's channel as parameters, without list files."""

from __future__ import annotations

from liftd.cnc.params import AxisParams, ChannelParams, LiftMethod, MSync, SlopeType


def make_channel(
    method: LiftMethod = LiftMethod.ADVANCED,
    lift_min_dist: float = 0.0,
    cycle_time: float = 1e-3,
    slope: SlopeType = SlopeType.TRAPEZ,
    z_limits: tuple[float, float] = (-0.005, 0.15),
    xy: tuple[float, float, float] = (1.5, 10.0, 500.0),
    z: tuple[float, float, float] = (1.0, 10.0, 500.0),
    look_ahead: int = 120,
) -> ChannelParams:
    """The demo machine's channel without files (X, Y, Z; Z lifts)."""
    v, a, j = xy
    zv, za, zj = z
    return ChannelParams(
        channel_id=1,
        axes=(
            AxisParams("X", 1, v, a, j, -0.001, 3.01),
            AxisParams("Y", 2, v, a, j, -0.001, 1.51),
            AxisParams("Z", 3, zv, za, zj, *z_limits),
        ),
        lift_axis="Z",
        lift_method=method,
        cycle_time=cycle_time,
        lift_min_dist=lift_min_dist,
        slope=slope,
        look_ahead_blocks=look_ahead,
        m_synch=((4, MSync.MVS_SVS), (5, MSync.MOS), (8, MSync.MNS_SNS)),
    )
