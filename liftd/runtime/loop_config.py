"""What the daemon sends the GEO process over the control pipe (a pickle): the loop's
configuration. Plain picklable data (no pydantic, no files), kept out of the compiled loop
(`geo_loop` is compiled with mypyc, whose native classes do not pickle)."""

from __future__ import annotations

from dataclasses import dataclass, field

from liftd.cnc.params import ChannelParams
from liftd.runtime import rt


@dataclass(frozen=True, slots=True)
class ChannelConfig:
    """One channel of the loop and its program; plain picklable data."""

    channel: ChannelParams
    program_text: str
    program_name: str
    autostart: bool = True
    repeat: bool = False


@dataclass(frozen=True, slots=True)
class LoopConfig:
    """Everything the loop needs; plain picklable data (no pydantic, no files). `channels`
    in channel order (ascending channel id), the order of their snapshots in shared memory
    and of the PLC inputs' channel index."""

    channels: tuple[ChannelConfig, ...]
    m_ack_auto: bool = True
    m_ack_delay_s: float = 0.02
    rt: rt.RtRequest = field(default_factory=rt.RtRequest)
    max_behind: int = 100

    @property
    def cycle_time(self) -> float:
        return self.channels[0].channel.cycle_time
