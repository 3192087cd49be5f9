"""The whole CNC the start-up list describes: one `GeoTask` per channel in one GEO task.

`Machine.step(inputs, t)` is one GEO cycle: every channel steps to the same t, in channel order
(ascending logical channel id, the order of `sda_mds[i]` in the start-up list), each with its
own PLC inputs and its own program. Channels share nothing but the cycle: a lift, an error or
a feed hold in one channel does not touch another (the real CNC runs its channels in one
interpolator cycle the same way, docs/reference/isg-cnc.md §1.2). Pure: time is passed in, no IO, no
logging.

The rules a machine keeps (the configuration reports them with file and line first; here
they are a ValueError, a bug of the caller):

* channel ids are distinct (one task per logical channel);
* every channel has the same GEO cycle time;
* no logical axis (`log_achs_nr`) belongs to two channels.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from liftd.cnc.geo_task import GeoTask
from liftd.cnc.params import ChannelParams
from liftd.cnc.snapshot import GeoInputs, GeoSnapshot


@dataclass(frozen=True, slots=True)
class ChannelProgram:
    """One channel of the machine and the NC program it runs ("" for none: it idles)."""

    channel: ChannelParams
    program_text: str = ""
    autostart: bool = True


def check_channels(channels: Sequence[ChannelParams]) -> None:
    """Raise ValueError unless `channels` can run as one machine (rules above)."""
    if not channels:
        raise ValueError("a machine has at least one channel")
    ids = [ch.channel_id for ch in channels]
    if len(set(ids)) != len(ids):
        raise ValueError(f"channel ids used twice: {ids}")
    if len({ch.cycle_time for ch in channels}) != 1:
        raise ValueError("all channels run in the same GEO cycle")
    owner: dict[int, int] = {}
    for ch in channels:
        for ax in ch.axes:
            other = owner.setdefault(ax.log_axis_nr, ch.channel_id)
            if other != ch.channel_id:
                raise ValueError(
                    f"logical axis {ax.log_axis_nr} ({ax.name}) is in channels {other} "
                    f"and {ch.channel_id}"
                )


class Machine:
    """The GEO task of all channels: `tasks[i]` is the channel at machine index i."""

    def __init__(self, channels: Sequence[ChannelProgram]) -> None:
        ordered = sorted(channels, key=lambda c: c.channel.channel_id)
        check_channels([c.channel for c in ordered])
        self.tasks: list[GeoTask] = [
            GeoTask(c.channel, c.program_text, autostart=c.autostart) for c in ordered
        ]
        self.channel_ids: tuple[int, ...] = tuple(c.channel.channel_id for c in ordered)
        self.cycle_time = ordered[0].channel.cycle_time

    def __len__(self) -> int:
        return len(self.tasks)

    def index_of(self, channel_id: int) -> int:
        """Machine index of logical channel `channel_id` (ValueError if it is not one)."""
        return self.channel_ids.index(channel_id)

    def step(self, inputs: Sequence[GeoInputs], t: float) -> list[GeoSnapshot]:
        """One GEO cycle: every channel to time t with its own inputs, in channel order."""
        tasks = self.tasks
        if len(inputs) != len(tasks):
            raise ValueError(f"{len(inputs)} inputs for {len(tasks)} channels")
        # an index loop: zip(..., strict=True) parses its keyword in every call (~1 µs cold,
        # 7 % of the GEO process's CPU, perf of `liftd run`, 2026-12-01)
        return [tasks[i].step(inputs[i], t) for i in range(len(tasks))]

    def step_channel(self, index: int, inputs: GeoInputs, t: float) -> GeoSnapshot:
        """One channel's share of a cycle (a driver that times each channel on its own);
        stepping every channel this way in index order is `step`."""
        return self.tasks[index].step(inputs, t)

    def replace(self, index: int, task: GeoTask) -> None:
        """Swap channel `index`'s task at its program boundary (a reload); same channel id,
        same cycle time, its axes still its own."""
        old = self.tasks[index]
        if task.ch.channel_id != old.ch.channel_id:
            raise ValueError(f"channel {old.ch.channel_id} replaced by {task.ch.channel_id}")
        channels = [t.ch for t in self.tasks]
        channels[index] = task.ch
        check_channels(channels)
        self.tasks[index] = task
