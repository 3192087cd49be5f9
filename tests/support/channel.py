"""The demo machine's channel as parameters, without list files."""

from __future__ import annotations

import dataclasses

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


def shipped() -> ChannelParams:
    """The shipped machine's path axes (config/cnc: X 10 m/s², 500 m/s³; Y 8 m/s², 400 m/s³)."""
    ch = make_channel()
    y = dataclasses.replace(ch.axes[1], a_max=8.0, j_max=400.0)
    return dataclasses.replace(ch, axes=(ch.axes[0], y, ch.axes[2]))


def make_second_channel(
    method: LiftMethod = LiftMethod.LIFTING, channel_id: int = 2, first_axis: int = 4
) -> ChannelParams:
    """Head 2 of the two-head machine without files: channel 2, U V W (logical axes 4, 5, 6;
    W lifts), path-based Lifting unless asked otherwise."""
    ch = make_channel(method)
    names = ("U", "V", "W")
    axes = tuple(
        dataclasses.replace(ax, name=names[j], log_axis_nr=first_axis + j)
        for j, ax in enumerate(ch.axes)
    )
    return dataclasses.replace(ch, channel_id=channel_id, axes=axes, lift_axis="W")
