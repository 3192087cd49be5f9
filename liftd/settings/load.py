"""Load the configuration: liftd.toml (`config_file`) plus the ISG lists it points at, checked
across channels and mapped to the core's parameters. Every problem names file, line, key and
value.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from liftd.cnc import units
from liftd.cnc.params import AxisParams, ChannelParams
from liftd.settings.cnc_lists import ChannelLists, read_channel_lists, startup_channels
from liftd.settings.config_file import ConfigError, find_config, parse_config_text, toml_line
from liftd.settings.isg_list import Problem, Severity
from liftd.settings.model import AdsSection, ChannelSection, LiftdConfig
from liftd.settings.ui import ui_token


@dataclass(frozen=True, slots=True)
class ChannelSettings:
    """One channel of the machine: its parameters and what it runs."""

    params: ChannelParams
    program: Path | None  # None: the channel idles in READY
    autostart: bool = True
    repeat: bool = False


@dataclass(frozen=True, slots=True)
class Settings:
    """Everything liftd needs from its configuration files.

    `channel` and `program` are the channel `[cnc] channel` names (its trace is OUT.csv, its
    summary the top level of simulate's JSON, the PLC's default); `channels` are all channels
    of the start-up list in channel order, that one included (at `primary`)."""

    path: Path  # the liftd.toml that was used
    config: LiftdConfig
    channel: ChannelParams
    program: Path | None
    warnings: tuple[Problem, ...]
    files: tuple[str, ...]  # every file read, for messages and reloads
    subroutine_dirs: tuple[Path, ...] = ()  # [nc] subroutine_dirs, resolved
    channels: tuple[ChannelSettings, ...] = ()  # empty: only `channel`
    primary: int = 0  # index of `channel` in `channels`
    ui_token: str | None = None  # [ui] token or the content of [ui] token_file

    def __repr__(self) -> str:  # the token stays out of tracebacks and logs
        return f"Settings(path={self.path!r})"

    @property
    def machine(self) -> tuple[ChannelSettings, ...]:
        """Every channel in channel order (the primary one with `[program]`)."""
        if self.channels:
            return self.channels
        prog = self.config.program
        return (ChannelSettings(self.channel, self.program, prog.autostart, prog.repeat),)

    @property
    def primary_index(self) -> int:
        return self.primary if self.channels else 0

    def channel_by_id(self, channel_id: int) -> ChannelSettings | None:
        return next((c for c in self.machine if c.params.channel_id == channel_id), None)


def load_settings(explicit: str | None = None, program: str | None = None) -> Settings:
    """Load liftd.toml and the CNC lists. Raises ConfigError with every problem found."""
    path = find_config(explicit)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        reason = getattr(exc, "strerror", None) or str(exc)
        raise ConfigError(
            [Problem(Severity.ERROR, str(path), None, None, None, f"cannot read: {reason}")]
        ) from None
    config = parse_config_text(text, str(path))
    base = path.parent
    program_path: Path | None = None
    if program is not None:
        program_path = Path(program)
    elif config.program.file:
        program_path = base / config.program.file
    startup = base / config.cnc.startup_list
    nc = config.nc
    # the lists liftd.toml names itself: one that cannot be read is its line, key and value
    # (read_channel_lists, which knows only the path, would name the list alone)
    located: list[Problem] = []
    where = _Where(str(path), text, located)
    named = (
        (("cnc", "startup_list"), config.cnc.startup_list, "start-up list"),
        (("nc", "tool_list"), nc.tool_list, "tool list"),
        (("nc", "zero_offset_list"), nc.zero_offset_list, "zero-offset list"),
    )
    readable: dict[str, Path | None] = {}
    for loc, value, what in named:
        if not value:
            readable[loc[1]] = None
            continue
        reason = _unreadable(base / value)
        if reason is not None:
            where.error(loc, value, f"cannot read the {what} {base / value}: {reason}")
        readable[loc[1]] = base / value if reason is None else None
    if readable["startup_list"] is None:  # nothing else can be checked without it
        raise ConfigError(located)
    ids, problems = startup_channels(startup, config.cnc.channel)
    problems = located + problems  # an unreadable tool list hides no other problem
    lists, more = read_channel_lists(
        startup, config.cnc.channel, readable["tool_list"], readable["zero_offset_list"]
    )
    problems += more
    where = _Where(str(path), text, problems)
    _ads_budgets(config.ads, where)
    token = ui_token(config.ui, base, str(path), text, problems)
    if lists is not None:
        names = [ax.name for ax in lists.axes]
        if config.cnc.lift_axis not in names:
            where.error(
                ("cnc", "lift_axis"),
                config.cnc.lift_axis,
                f"not an axis of channel {config.cnc.channel} (axes: {', '.join(names)})",
            )
    zero_offsets = lists.zero_offsets if lists is not None else ()
    if lists is not None:
        zero_offsets = _zero_offsets(config, text, str(path), lists.axes, zero_offsets, problems)
    others = _other_channels(config, base, startup, ids, where)
    if lists is not None and others is not None:
        _shared_axes(config.cnc.channel, lists, others, problems)
    problems = list(dict.fromkeys(problems))  # the start-up list is read once per channel
    if lists is None or others is None or any(p.severity is Severity.ERROR for p in problems):
        raise ConfigError(problems)
    tools = dict(lists.tool_radii)
    for key, radius_mm in nc.tools.items():
        tools[int(key[1:])] = units.mm_to_m(radius_mm)
    channel = _params(
        config,
        lists,
        config.cnc.lift_axis,
        tuple(sorted(tools.items())),
        zero_offsets,
        "G53" in nc.zero_offsets,
    )
    prog = config.program
    machine = [ChannelSettings(channel, program_path, prog.autostart, prog.repeat)]
    files = [str(path), *lists.files]
    for table, other, lift_axis in others:
        params = _params(config, other, lift_axis, other.tool_radii, other.zero_offsets, False)
        program_file = base / table.program if table is not None and table.program else None
        machine.append(
            ChannelSettings(
                params,
                program_file,
                table.autostart if table else True,
                table.repeat if table else False,
            )
        )
        files += [f for f in other.files if f not in files]
    machine.sort(key=lambda c: c.params.channel_id)
    return Settings(
        path=path,
        config=config,
        channel=channel,
        program=program_path,
        warnings=tuple(p for p in problems if p.severity is Severity.WARNING),
        files=tuple(files),
        subroutine_dirs=tuple(base / d for d in nc.subroutine_dirs),
        channels=tuple(machine),
        primary=[c.params.channel_id for c in machine].index(channel.channel_id),
        ui_token=token,
    )


def _ads_budgets(ads: AdsSection, where: _Where) -> None:
    """A connection's budget holds a request and a reply of a frame each; the server's holds
    a connection's."""
    if ads.connection_budget_bytes < 2 * ads.max_frame_bytes:
        where.error(("ads", "connection_budget_bytes"), ads.connection_budget_bytes,
                    f"below 2 × max_frame_bytes ({2 * ads.max_frame_bytes})")  # fmt: skip
    if ads.budget_bytes < ads.connection_budget_bytes:
        where.error(("ads", "budget_bytes"), ads.budget_bytes,
                    f"below connection_budget_bytes ({ads.connection_budget_bytes})")  # fmt: skip


def _unreadable(file: Path) -> str | None:
    """Why `file` cannot be read, or None when it can."""
    try:
        with file.open("rb"):
            return None
    except OSError as exc:
        return exc.strerror or type(exc).__name__
    except ValueError as exc:  # a NUL in the name (valid TOML): no such file
        return str(exc)


class _Where:
    """Problems located in liftd.toml."""

    def __init__(self, file: str, text: str, problems: list[Problem]) -> None:
        self.file, self.text, self.problems = file, text, problems

    def error(self, loc: tuple[str | int, ...], value: object, message: str) -> None:
        key = ".".join(str(p) for p in loc)
        shown = None if value is None else str(value)
        self.problems.append(
            Problem(Severity.ERROR, self.file, toml_line(self.text, loc), key, shown, message)
        )


def _params(
    config: LiftdConfig,
    lists: ChannelLists,
    lift_axis: str,
    tools: tuple[tuple[int, float], ...],
    zero_offsets: tuple[tuple[int, tuple[float, ...]], ...],
    g53_configured: bool,
) -> ChannelParams:
    return ChannelParams(
        channel_id=lists.channel_id,
        axes=lists.axes,
        lift_axis=lift_axis,
        lift_method=lists.lift_method,
        cycle_time=config.cnc.cycle_time_us * 1e-6,
        lift_min_dist=lists.lift_min_dist,
        slope=lists.slope,
        look_ahead_blocks=lists.look_ahead_blocks,
        max_radius_diff=lists.max_radius_diff,
        m_synch=lists.m_synch,
        corr_v_trans_jerk=lists.corr_v_trans_jerk,
        mode_trans_jerk=lists.mode_trans_jerk,
        path_prep_flags=lists.path_prep_flags,
        ipo_flags=lists.ipo_flags,
        tool_radii=tools,
        zero_offsets=zero_offsets,
        zero_offset_default=lists.zero_offset_default,
        g53_offsets=lists.g53_offsets or g53_configured,
        max_executed_blocks=config.nc.max_executed_blocks,
    )


_Other = tuple[
    ChannelSection | None, ChannelLists, str
]  # ([[channel]] table or None, its lists, lift axis)


def _other_channels(
    config: LiftdConfig, base: Path, startup: Path, ids: tuple[int, ...] | None, where: _Where
) -> list[_Other] | None:
    """The channels of the start-up list besides `[cnc] channel`, with their `[[channel]]`
    tables; None when any of them has an error (reported in `where`)."""
    if ids is None:
        return None
    ok = True
    primary = config.cnc.channel
    if primary not in ids:
        where.error(
            ("cnc", "channel"),
            primary,
            f"the start-up list {startup} describes channels "
            f"{', '.join(map(str, ids))} (kanal_anzahl)",
        )
        ok = False
    tables: dict[int, ChannelSection] = {}
    for k, entry in enumerate(config.channel):
        if entry.id not in ids:
            where.error(
                ("channel", k, "id"),
                entry.id,
                f"a [[channel]] table for channel {entry.id}, which the start-up list "
                f"{startup} does not have (channels {', '.join(map(str, ids))})",
            )
            ok = False
        elif entry.id == primary:
            where.error(
                ("channel", k, "id"),
                entry.id,
                f"channel {primary} is [cnc] channel: its program is [program] file, "
                "its lift axis [cnc] lift_axis",
            )
            ok = False
        elif entry.id in tables:
            where.error(("channel", k, "id"), entry.id, "two [[channel]] tables for one channel")
            ok = False
        tables[entry.id] = entry
    out: list[_Other] = []
    for cid in ids:
        if cid == primary:
            continue
        lists, problems = read_channel_lists(startup, cid)
        where.problems.extend(problems)
        if lists is None:
            ok = False
            continue
        table = tables.get(cid)
        names = [ax.name for ax in lists.axes]
        if table is not None and table.lift_axis is not None:
            lift_axis = table.lift_axis
            if lift_axis not in names:
                k = config.channel.index(table)
                where.error(
                    ("channel", k, "lift_axis"),
                    lift_axis,
                    f"not an axis of channel {cid} (axes: {', '.join(names)})",
                )
                ok = False
        else:
            lift_axis = config.cnc.lift_axis if config.cnc.lift_axis in names else names[-1]
        out.append((table, lists, lift_axis))
    return out if ok else None


def _shared_axes(
    primary: int, lists: ChannelLists, others: list[_Other], problems: list[Problem]
) -> None:
    """Two channels cannot share an axis (one logical axis, `log_achs_nr`, in one channel)."""
    owner: dict[int, int] = {ax.log_axis_nr: primary for ax in lists.axes}
    for _, other, _ in sorted(others, key=lambda o: o[1].channel_id):
        for ax, (file, line) in zip(other.axes, other.axis_refs, strict=True):
            first = owner.setdefault(ax.log_axis_nr, other.channel_id)
            if first != other.channel_id:
                problems.append(
                    Problem(
                        Severity.ERROR,
                        file,
                        line,
                        "log_achs_nr",
                        str(ax.log_axis_nr),
                        f"axis {ax.name} of channel {other.channel_id} is logical axis "
                        f"{ax.log_axis_nr}, which is already in channel {first}: two "
                        "channels cannot share an axis",
                    )
                )


def program_problem(settings: Settings, explicit: str | None = None) -> Problem | None:
    """A program `liftd run` would start cannot be read: an error naming the file, and the
    line, key and value of liftd.toml that name it (`[program] file`, or a `[[channel]]`
    table's `program`); None when every channel's program reads or it has none.
    `liftd check` reports the same as a program error instead."""
    try:
        text = settings.path.read_text(encoding="utf-8")
    except OSError:
        text = ""
    named: list[tuple[Path, tuple[str | int, ...], str]] = []
    if settings.program is not None:
        named.append((settings.program, ("program", "file"), settings.config.program.file or ""))
    base = settings.path.parent
    for n, table in enumerate(settings.config.channel):
        if table.program:
            named.append((base / table.program, ("channel", n, "program"), table.program))
    for program, loc, value in named:
        reason = _unreadable(program)
        if reason is None:
            continue
        if explicit is not None and loc[0] == "program":
            return Problem(
                Severity.ERROR, explicit, None, None, None, f"cannot read program: {reason}"
            )
        key = ".".join(str(part) for part in loc)
        return Problem(Severity.ERROR, str(settings.path), toml_line(text, loc), key, value,
                       f"cannot read the program {program}: {reason}")  # fmt: skip
    return None


def _zero_offsets(
    config: LiftdConfig,
    text: str,
    file: str,
    axes: tuple[AxisParams, ...],
    from_list: tuple[tuple[int, tuple[float, ...]], ...],
    problems: list[Problem],
) -> tuple[tuple[int, tuple[float, ...]], ...]:
    """The zero-offset list's groups with liftd.toml's [nc.zero_offsets] over them (mm)."""
    groups = {g: list(v) for g, v in from_list}
    names = [ax.name for ax in axes]
    for key, values in config.nc.zero_offsets.items():
        group = int(key[1:]) - 53
        row = groups.setdefault(group, [0.0] * len(axes))
        for name, mm in values.items():
            if name not in names:
                problems.append(
                    Problem(
                        Severity.ERROR,
                        file,
                        toml_line(text, ("nc", "zero_offsets", key, name)),
                        f"nc.zero_offsets.{key}.{name}",
                        str(mm),
                        f"not an axis of the channel (axes: {', '.join(names)})",
                    )
                )
                continue
            row[names.index(name)] = units.mm_to_m(mm)
    return tuple((g, tuple(v)) for g, v in sorted(groups.items()))
