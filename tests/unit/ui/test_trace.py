"""A trace CSV as views: the row of an instant rebuilt as a snapshot (so the catalogue's
getters give the page its symbols), what a trace does not have marked missing, and a file
that is not a trace of the channel refused with its line."""

from __future__ import annotations

from pathlib import Path

import pytest

import liftd.ui.trace as trace_mod
from liftd.objects.catalog import Catalog
from liftd.settings import load_settings
from liftd.sim.trace import TraceWriter
from liftd.ui.feed import Feed
from liftd.ui.trace import TraceError, load_traces, read_trace
from tests.support.paths import REPO
from tests.unit.ui.test_feed import CH, view


def write(path: Path, flags: list[tuple[bool, bool]]) -> None:
    with path.open("w") as f:
        w = TraceWriter(f, CH.axis_names)
        for k, (active, suppressed) in enumerate(flags, start=1):
            w.write(view(k, active=active, suppressed=suppressed, x=k * 1e-3).snapshot)
        w.flush()


def test_a_row_gives_the_same_symbols_as_the_live_view(tmp_path: Path) -> None:
    trace = tmp_path / "t.csv"
    write(trace, [(False, False), (True, False), (True, False), (False, False), (False, True)])
    views = load_traces(Catalog(CH), [str(trace)])
    feed = Feed(Catalog(CH), views.missing)
    feed.update(views.view(0.0025))  # between rows 2 and 3: row 2
    v = feed.values
    assert v["GEO.ch1.X.command_position"] == 20000 and v["GEO.ch1.Z.lift_active"] is True
    assert v["GEO.ch1.Z.lift_count"] == 1 and v["GEO.cycle"] == 2
    assert v["GEO.timing.lateness_max_us"] is None and v["GEO.ch1.feed_hold"] is None
    assert "GEO.ch1.state" not in views.missing and "PLC.ch1.override" in views.missing
    feed.update(views.view(0.005))
    assert feed.values["GEO.ch1.Z.lift_count"] == 2  # the suppressed hop counts too
    assert views.starts_between(0.002, 0.005) == {0: [True]}
    assert views.starts_between(0.0, 0.005) == {0: [False, True]}  # in order, each its kind
    assert views.starts_between(0.002, 0.003) == {}


@pytest.mark.parametrize(
    ("text", "fragment"),
    [
        ("t,line,x,y,v_path,override,lift_active,lift_suppressed\n", "line 1: the columns"),
        (
            "t,line,x,y,z,v_path,override,lift_active,lift_suppressed\n0.001,1,0,0,0,0,1,0\n",
            "line 2: 8 fields",
        ),
        (
            "t,line,x,y,z,v_path,override,lift_active,lift_suppressed\n0.001,1,0,0,zz,0,1,0,0\n",
            "line 2: could not convert",
        ),
        ("t,line,x,y,z,v_path,override,lift_active,lift_suppressed\n", "no rows"),
    ],
)
def test_not_a_trace_of_the_channel(tmp_path: Path, text: str, fragment: str) -> None:
    bad = tmp_path / "bad.csv"
    bad.write_text(text)
    with pytest.raises(TraceError) as exc:
        read_trace(str(bad), CH)
    assert str(bad) in str(exc.value) and fragment in str(exc.value)


def test_the_row_budget_is_for_all_the_channel_files(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Review #9b: MAX_ROWS bounds the run, not each of its files."""
    machine = load_settings(str(REPO / "config" / "liftd-2ch.toml")).machine
    catalog = Catalog([c.params for c in machine])
    paths = [tmp_path / "t.csv", tmp_path / "t.ch2.csv"]
    for path, c in zip(paths, machine, strict=True):
        with path.open("w") as f:
            w = TraceWriter(f, c.params.axis_names)
            for k in range(1, 6):
                snap = view(k).snapshot
                w.write(snap._replace(positions=(0.0,) * len(c.params.axes)))
            w.flush()
    names = [str(p) for p in paths]
    monkeypatch.setattr(trace_mod, "MAX_ROWS", 10)
    assert load_traces(catalog, names).traces[1] is not None
    monkeypatch.setattr(trace_mod, "MAX_ROWS", 8)
    with pytest.raises(TraceError, match=r"t\.ch2\.csv: line 5: more than 8 rows"):
        load_traces(catalog, names)
    assert read_trace(names[1], machine[1].params).n == 5  # one file alone is within it
