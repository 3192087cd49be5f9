"""A recorded run as views: the trace CSV of `simulate --trace` / `run --trace`
(docs/reference/design.md §3.2, one per channel: OUT.csv and its OUT.chN.csv siblings) read into
columns, and the `GeoView` of any instant rebuilt from its row, so the page shows a trace through
the same catalogue getters as a live run.

What a trace does not record is `missing` (null on the page): the PLC's inputs beyond the
override in effect, errors, the M function pending, the block, the loop's timing and the ADS
counters. `lift_count` is counted from the rows: a range whose flags rise from FALSE (two
ranges whose flags stay TRUE from one to the next count as one)."""

from __future__ import annotations

import csv
from array import array
from bisect import bisect_right
from dataclasses import dataclass
from pathlib import Path

from liftd.cnc.params import ChannelParams
from liftd.cnc.snapshot import ChannelState, GeoSnapshot, LiftPhase, LoopStats
from liftd.objects.catalog import Catalog, GeoView

REQUIRED = ("v_path", "override", "lift_active", "lift_suppressed")
EXTRA = ("lift_phase", "vz", "az", "state", "override_max")
MM = 1e3
# rows of all the run's channel files together: ~2.4 GB at the 119 B a row measured (review of
# issue 38: the columns, the counts and the reader's transients); a larger run is refused, not
# swapped in
MAX_ROWS = 20_000_000


class TraceError(Exception):
    """The trace cannot be shown (unreadable, not a trace of this configuration's channel)."""


@dataclass
class ChannelTrace:
    params: ChannelParams
    path: str
    columns: dict[str, array[float]]  # name → values, one per row
    counts: array[int]  # lifts started up to each row (rising flags)

    @property
    def n(self) -> int:
        return len(self.columns["t"])


def read_trace(path: str, ch: ChannelParams, max_rows: int = MAX_ROWS) -> ChannelTrace:
    """Read one channel's trace (at most `max_rows` rows); raises TraceError naming the file,
    line and what is wrong."""
    axes = [a.lower() for a in ch.axis_names]
    try:
        f = open(path, encoding="utf-8", newline="")  # noqa: SIM115
    except OSError as exc:
        raise TraceError(f"{path}: cannot read the trace: {exc.strerror}") from None
    with f:
        reader = csv.reader(f)
        try:
            head = next(reader, None)
        except (csv.Error, UnicodeDecodeError) as exc:
            raise TraceError(f"{path}: line 1: not a trace: {exc}") from None
        want = ["t", "line", *axes, *REQUIRED]
        if head is None or head[: len(want)] != want:
            raise TraceError(
                f"{path}: line 1: the columns must begin {','.join(want)} (DESIGN §3.2, the "
                f"axes of channel {ch.channel_id}), not {','.join((head or [])[: len(want)])}"
            )
        names = [h for h in head if h in (*want, *EXTRA)]
        index = {h: head.index(h) for h in names}
        cols = {h: array("d") for h in names}
        lineno = 1
        try:
            for lineno, row in enumerate(reader, start=2):
                if len(row) != len(head):
                    raise TraceError(
                        f"{path}: line {lineno}: {len(row)} fields, the header has {len(head)}"
                    )
                for h in names:
                    cols[h].append(float(row[index[h]]))
                if lineno - 1 > max_rows:
                    raise TraceError(
                        f"{path}: line {lineno}: more than {MAX_ROWS} rows in the run's traces"
                    )
        except (ValueError, csv.Error, UnicodeDecodeError) as exc:
            raise TraceError(f"{path}: line {lineno}: {exc}") from None
    if not len(cols["t"]):
        raise TraceError(f"{path}: no rows")
    counts = array("q")
    n, was = 0, False
    for a, s in zip(cols["lift_active"], cols["lift_suppressed"], strict=True):
        on = a > 0.5 or s > 0.5
        n += on and not was
        was = on
        counts.append(n)
    return ChannelTrace(ch, path, cols, counts)


class TraceViews:
    """Every channel's trace of one run; `view(t)` is the machine at time t."""

    def __init__(self, catalog: Catalog, traces: list[ChannelTrace | None]) -> None:
        self.catalog = catalog
        self.traces = traces
        present = [tr for tr in traces if tr is not None]
        if not present:
            raise TraceError("no channel has a trace")
        self.t0 = min(tr.columns["t"][0] for tr in present)
        self.t1 = max(tr.columns["t"][-1] for tr in present)
        self.dt = catalog.channel.cycle_time
        prefixes = ["GEO.timing.", "GEO.ads.", "PLC."]
        suffixes = [
            ".feed_hold",
            ".override_requested",
            ".m_pending",
            ".error_id",
            ".error_line",
            ".block",
            ".max_path_velocity",
            ".max_path_velocity_block_end",
        ]
        for i, tr in enumerate(traces):
            geo = f"GEO.ch{catalog.channels[i].channel_id}."
            if tr is None:
                prefixes.append(geo)
                continue
            for column in ("lift_phase", "state", "override_max"):
                if column not in tr.columns:
                    prefixes.append(geo + column)
            if "lift_phase" not in tr.columns:
                prefixes.append(f"{geo}{tr.params.lift_axis}.lift_phase")
        self.missing = frozenset(
            o.symbol
            for o in catalog.objects
            if o.symbol.startswith(tuple(prefixes)) or o.symbol.endswith(tuple(suffixes))
        )

    def row(self, i: int, t: float) -> int:
        tr = self.traces[i]
        if tr is None:
            return -1
        return max(0, bisect_right(tr.columns["t"], t) - 1)

    def snapshot(self, i: int, k: int) -> GeoSnapshot:
        tr = self.traces[i]
        ch = self.catalog.channels[i]
        if tr is None or k < 0:
            return GeoSnapshot(
                0,
                0.0,
                ChannelState.READY,
                0,
                0,
                tuple(0.0 for _ in ch.axes),
                0.0,
                1.0,
                1.0,
                1.0,
                False,
                False,
                False,
                LiftPhase.NONE,
                0.0,
                0.0,
                -1,
                0,
                0,
                (),
            )
        c = tr.columns
        axis = ch.lift_axis_index
        counts = [0] * len(ch.axes)
        counts[axis] = tr.counts[k]

        def col(name: str, default: float) -> float:
            return c[name][k] if name in c else default

        return GeoSnapshot(
            round(c["t"][k] / self.dt),
            c["t"][k],
            ChannelState(int(col("state", ChannelState.ACTIVE))),
            int(c["line"][k]),
            0,
            tuple(c[a.lower()][k] / MM for a in ch.axis_names),
            c["v_path"][k] / MM,
            c["override"][k],
            c["override"][k],
            col("override_max", c["override"][k]),
            False,
            c["lift_active"][k] > 0.5,
            c["lift_suppressed"][k] > 0.5,
            LiftPhase(int(col("lift_phase", 0))),
            col("vz", 0.0) / MM,
            col("az", 0.0) / MM,
            -1,
            0,
            0,
            (),
            0.0,
            0.0,
            axis,
            tuple(counts),
        )

    def view(self, t: float) -> GeoView:
        snaps = tuple(self.snapshot(i, self.row(i, t)) for i in range(len(self.traces)))
        stats = LoopStats(cycles=snaps[0].cycle)
        return GeoView(snaps[0], stats, channels=snaps if len(snaps) > 1 else ())

    def starts_between(self, t_a: float, t_b: float) -> dict[int, list[bool]]:
        """Per channel, the ranges whose flags rose in (t_a, t_b], in order: suppressed or
        not (the feed's pulse rule); the rows are looked at only where the count rose."""
        out: dict[int, list[bool]] = {}
        for i, tr in enumerate(self.traces):
            if tr is None:
                continue
            ka, kb = max(self.row(i, t_a), 0), self.row(i, t_b)
            if kb <= ka or tr.counts[kb] == tr.counts[ka]:
                continue
            sup = tr.columns["lift_suppressed"]
            out[i] = [
                sup[k] > 0.5 for k in range(ka + 1, kb + 1) if tr.counts[k] > tr.counts[k - 1]
            ]
        return out


def load_traces(catalog: Catalog, paths: list[str], primary: int = 0) -> TraceViews:
    """The traces of a run, in channel order; a sibling (OUT.chN.csv) that does not exist is a
    channel without a trace. The primary channel's (OUT.csv, at `primary`) must exist."""
    traces: list[ChannelTrace | None] = []
    left = MAX_ROWS  # one budget for all the files
    for i, (ch, path) in enumerate(zip(catalog.channels, paths, strict=True)):
        if i != primary and not Path(path).exists():
            traces.append(None)
            continue
        tr = read_trace(path, ch, left)
        left -= tr.n
        traces.append(tr)
    return TraceViews(catalog, traces)
