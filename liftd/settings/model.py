"""liftd.toml as frozen pydantic models (`extra="forbid"`, bounded fields).

The keys of DESIGN.md §3.4 are a contract; every other key has a default. Units that are not
SI are in the key name (`cycle_time_us`, `m_ack_delay_ms`).
"""

from __future__ import annotations

import ipaddress
import re
from typing import Annotated, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    StrictBool,
    StringConstraints,
    ValidationInfo,
    field_validator,
)

NET_ID = re.compile(r"^(\d{1,3})\.(\d{1,3})\.(\d{1,3})\.(\d{1,3})\.(\d{1,3})\.(\d{1,3})$")


def check_net_id(value: str) -> str:
    match = NET_ID.match(value)
    if match is None or any(int(part) > 255 for part in match.groups()):
        raise ValueError("an AMS NetId is six numbers 0..255 joined by dots, e.g. 127.0.0.1.1.1")
    return value


class _Section(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")

    @field_validator("*", mode="before")
    @classmethod
    def _a_number_is_written_as_one(cls, value: object, info: ValidationInfo) -> object:
        """A number key takes a TOML number: pydantic would read "1000" or true as one (a
        quoted or boolean value is a typo to point at, not to guess)."""
        field = cls.model_fields.get(info.field_name or "")
        if field is not None and field.annotation in (int, float) and isinstance(value, str | bool):
            kind = "a string" if isinstance(value, str) else "a boolean"
            raise ValueError(f"must be a number, not {kind}")
        return value


class CncSection(_Section):
    startup_list: str = "cnc/hochlauf.lis"  # relative to liftd.toml
    channel: int = Field(1, ge=1, le=12)  # logical channel id
    lift_axis: str = Field("Z", min_length=1, max_length=1)
    cycle_time_us: int = Field(1000, ge=250, le=10000)


class ProgramSection(_Section):
    file: str | None = None  # relative to liftd.toml; none: the channel idles until a reload
    autostart: StrictBool = True
    repeat: StrictBool = False


class ChannelSection(_Section):
    """A `[[channel]]` table: what liftd runs in a further channel of the start-up list (the
    channel `[cnc] channel` names keeps `[cnc] lift_axis` and `[program]`). Channels of the
    lists without a table idle in READY, serving their objects."""

    id: int = Field(ge=1, le=12)  # logical channel id (list index id − 1)
    lift_axis: str | None = Field(None, min_length=1, max_length=1)  # default: [cnc] lift_axis
    # if the channel has it, else the channel's last path axis
    program: str | None = None  # relative to liftd.toml; none: the channel idles
    autostart: StrictBool = True
    repeat: StrictBool = False


class AdsSection(_Section):
    host: str = "127.0.0.1"
    port: int = Field(48898, ge=0, le=65535)  # 0 = any free port (the real one is logged)
    net_id: str = "127.0.0.1.1.1"
    extra_net_ids: tuple[str, ...] = ()  # further NetIds this target answers for
    ams_ports: tuple[int, ...] = (551,)  # hosted AMS ports; 551 = GEO task
    max_connections: int = Field(64, ge=1, le=10000)
    max_frame_bytes: int = Field(1 << 20, ge=1024, le=64 << 20)
    max_sum_subcommands: int = Field(1000, ge=500, le=100000)
    max_handles_per_connection: int = Field(1024, ge=1, le=100000)
    max_notifications_per_connection: int = Field(512, ge=1, le=100000)
    min_notification_cycle_us: int = Field(1000, ge=100, le=10_000_000)
    write_queue_frames: int = Field(1024, ge=16, le=1_000_000)
    # bytes held for one connection (its replies, notifications and routed frames not yet
    # taken by its peer, and a request not yet complete): beyond it the connection is closed;
    # at least 2 × max_frame_bytes
    connection_budget_bytes: int = Field(4 << 20, ge=2048, le=1 << 34)
    # bytes held for all connections together: beyond it the one holding most is closed
    budget_bytes: int = Field(48 << 20, ge=2048, le=1 << 36)
    incomplete_frame_timeout_s: float = Field(10.0, gt=0.0, le=3600.0)
    # a connection that sent no valid AMS frame (nor a router port connect) is closed after this
    first_frame_timeout_s: float = Field(10.0, gt=0.0, le=3600.0)
    max_connections_per_ip: int = Field(32, ge=1, le=10000)
    system_service: StrictBool = True  # answer AMS port 10000 (state, device info) as TwinCAT
    # UDP discovery and add-route (TwinCAT broadcast search, pyads.add_route_to_plc) on
    # host:udp_port, subject to allow_ips / allow_net_ids; off unless asked for
    udp_discovery: StrictBool = False
    udp_port: int = Field(48899, ge=0, le=65535)  # 0 = any free port (tests)
    allow_ips: tuple[str, ...] = ("127.0.0.0/8", "::1/128")  # peer IP ranges; empty = all
    allow_net_ids: tuple[str, ...] = ()  # source NetIds; empty = all
    write_net_ids: tuple[str, ...] = ()  # NetIds allowed to write; empty = all allowed peers
    reject: Literal["close", "error"] = "close"  # unknown source: close, or answer 0x723

    @field_validator("net_id")
    @classmethod
    def _net_id(cls, value: str) -> str:
        return check_net_id(value)

    @field_validator("extra_net_ids", "allow_net_ids", "write_net_ids")
    @classmethod
    def _net_ids(cls, values: tuple[str, ...]) -> tuple[str, ...]:
        for value in values:
            check_net_id(value)
        return values

    @field_validator("allow_ips")
    @classmethod
    def _ips(cls, values: tuple[str, ...]) -> tuple[str, ...]:
        for value in values:
            ipaddress.ip_network(value, strict=False)
        return values

    @field_validator("ams_ports")
    @classmethod
    def _ports(cls, values: tuple[int, ...]) -> tuple[int, ...]:
        if not values or any(not 1 <= p <= 65535 for p in values):
            raise ValueError("AMS ports are 1..65535, at least one")
        return values


class PlcSection(_Section):
    """How the emulated CNC waits for the PLC (M-function acknowledge, M00 continue)."""

    m_ack: Literal["auto", "plc"] = "auto"  # auto: acknowledge after m_ack_delay_ms
    m_ack_delay_ms: float = Field(20.0, ge=0.0, le=60000.0)


class RtSection(_Section):
    """Best-effort real-time settings of the GEO loop process (each reported at start-up)."""

    sched_fifo_priority: int = Field(80, ge=0, le=99)  # 0 = do not ask for SCHED_FIFO
    cpu: int = Field(-1, ge=-1, le=1023)  # -1 = no pinning
    lock_memory: StrictBool = True
    hold_cpu_dma_latency: StrictBool = True
    timer_slack_ns: int = Field(1, ge=0, le=1_000_000)
    # how the loop waits for its next cycle: "sleep" (clock_nanosleep) or "spin" (busy-wait:
    # the CPU never idles, so each cycle starts with warm caches; costs that CPU entirely, pin
    # it with `cpu`; refused with SCHED_FIFO while the kernel limits real-time tasks'
    # share, sched_rt_runtime_us ≠ -1, which would stop the loop 50 ms a second; with a cpu,
    # the daemon's threads keep off it; README "Running it as a service")
    idle: Literal["sleep", "spin"] = "sleep"
    # the daemon stops serving and exits 3 when the GEO cycle counter stands still this long
    # (a stopped or hung loop; with no systemd watchdog, e.g. in Docker, this is the restart)
    stall_timeout_ms: int = Field(1000, ge=20, le=60_000)


class LogSection(_Section):
    level: Literal["debug", "info", "warning", "error"] = "info"
    format: Literal["auto", "json", "console"] = "auto"  # auto: JSON when not a TTY
    # log lines waiting for the writer thread; when it cannot keep up (a pipe nobody reads),
    # further lines are dropped and counted, never waited for
    queue_lines: int = Field(10_000, ge=100, le=1_000_000)


class UiSection(_Section):
    """The live view in the browser (liftd/ui/, README "Watching liftd live"): off unless asked
    (the shipped liftd.toml asks, on loopback). Control from the page needs `control = true`,
    a token (`token`, or `token_file` relative to liftd.toml: one of them) and a peer that
    `[ads] allow_ips` admits."""

    enabled: StrictBool = False
    host: str = "127.0.0.1"
    port: int = Field(8551, ge=0, le=65535)  # 0 = any free port (the real one is logged)
    control: StrictBool = False
    token: str | None = Field(None, min_length=16, max_length=256, pattern=r"^[!-~]+$")
    token_file: str | None = Field(None, min_length=1)
    # Host header names the page answers to besides IP literals and localhost (a name that
    # resolves to this machine only through an attacker's DNS, "DNS rebinding", is refused)
    hosts: tuple[str, ...] = ()
    max_connections: int = Field(16, ge=1, le=1000)  # open WebSockets; beyond: HTTP 503
    max_message_bytes: int = Field(4096, ge=256, le=1 << 20)  # a page's message; beyond: close
    rate_hz: int = Field(50, ge=1, le=50)  # updates a second to each page


class MetricsSection(_Section):
    prometheus_port: int = Field(0, ge=0, le=65535)  # 0 = off
    prometheus_host: str = "127.0.0.1"


ToolKey = Annotated[str, StringConstraints(pattern=r"^D\d{1,5}$")]  # D1, D12
ToolRadiusMm = Annotated[float, Field(ge=0.0, le=1000.0)]
ZeroOffsetKey = Literal["G53", "G54", "G55", "G56", "G57", "G58", "G59"]
OffsetMm = Annotated[float, Field(ge=-1e6, le=1e6)]


class NcSection(_Section):
    """What NC programs need beyond the ISG lists' channel data (issue 19)."""

    # searched for `L file.nc` after the program's own directory, relative to liftd.toml
    subroutine_dirs: tuple[str, ...] = ()
    # ISG tool list (wz[i].radius, P-TOOL-00004) and zero-offset list (np_grp[i].achse[j].versch,
    # P-ZERO-00003), relative to liftd.toml; default: werkz_data[i] / nullp_data[i] of the
    # start-up list (P-STUP-00010 / 00011)
    tool_list: str | None = None
    zero_offset_list: str | None = None
    # tool radius per D number in mm, over the tool list: D1 = 0.1
    tools: dict[ToolKey, ToolRadiusMm] = Field(default_factory=dict)
    # zero offsets in mm per axis, over the zero-offset list: G54 = { X = 1200.0, Y = 0.0 }
    zero_offsets: dict[ZeroOffsetKey, dict[str, OffsetMm]] = Field(default_factory=dict)
    # liftd prepares whole programs: subroutine calls and repetitions may expand a program to
    # at most this many executed blocks (decoding and planning cost ≈ 40 µs per block)
    max_executed_blocks: int = Field(2_000_000, ge=1_000, le=20_000_000)


class LiftdConfig(_Section):
    cnc: CncSection = CncSection()
    program: ProgramSection = ProgramSection()
    ads: AdsSection = AdsSection()
    plc: PlcSection = PlcSection()
    rt: RtSection = RtSection()
    log: LogSection = LogSection()
    metrics: MetricsSection = MetricsSection()
    ui: UiSection = UiSection()
    nc: NcSection = NcSection()
    channel: tuple[ChannelSection, ...] = ()  # [[channel]] tables
