"""A program as the page draws it: one point budget for the path and its lift ranges (the
ranges are spans of the drawn path), encoded once, the open range found by its lines without
its drawing, and the hub that hands the drawing out by version, never in a hello or a frame."""

from __future__ import annotations

import json

import pytest

from liftd.objects.catalog import Catalog
from liftd.ui import geometry
from liftd.ui.hub import LiveHub, LiveSession, range_extras
from tests.support.ui import hops_program
from tests.unit.ui.test_feed import CH, view


def test_path_and_ranges_share_one_point_budget(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(geometry, "MAX_POINTS", 100)
    geo = geometry.build(CH, hops_program(300))
    drawing = json.loads(geo.encoded)
    assert len(geo.ranges) == 300 and drawing["error"] is None
    assert len(drawing["path"]) <= 101  # the points drawn, ranges included
    n = len(drawing["path"])
    for i0, i1, method in drawing["ranges"]:  # spans of the drawn path, bounded by it
        assert 0 <= i0 <= i1 < n and method == "advanced"
    assert len(drawing["ranges"]) <= n


def test_an_undecimated_drawing_keeps_each_range_apart() -> None:
    geo = geometry.build(CH, hops_program(5))
    drawing = json.loads(geo.encoded)
    assert len(drawing["ranges"]) == 5
    (x0, _), (x1, _) = (drawing["path"][i] for i in drawing["ranges"][0][:2])
    assert (x0, x1) == (20.0, 50.0)  # the first hop: X20 → X50 (mm)


def test_the_open_range_is_found_by_its_lines_without_its_drawing() -> None:
    geo = geometry.build(CH, hops_program(2000))
    starts = [r[0] for r in geo.ranges]
    assert starts == sorted(starts)
    first, last = geo.ranges[0], geo.ranges[-1]
    got = geo.open_range(first[0])
    assert got is not None and got["start_line"] == first[0] and "path" not in got
    assert got["pos"] == 1.0 and got["pos_limit"] == 20.0 and got["method"] == "advanced"
    assert geo.open_range(first[1])["end_line"] == first[1]  # type: ignore[index]
    assert geo.open_range(first[1] + 1) is None  # the cut between two hops
    assert geo.open_range(last[0] + 1)["start_line"] == last[0]  # type: ignore[index]
    assert geo.open_range(1) is None
    v = view(5, active=True, count=1)
    v = v._replace(snapshot=v.snapshot._replace(line=first[0]))
    extras = range_extras([geo], v)
    assert len(json.dumps(extras)) < 400  # a frame's extras: the range's lines and POS only


def test_the_hub_hands_out_the_drawing_by_version_not_in_a_hello() -> None:
    hub = LiveHub(Catalog(CH), lambda: view(1), lambda: [])
    geo = geometry.build(CH, hops_program(50))
    hub.set_geometry(0, geo)
    hello = LiveSession(hub).hello()
    (version,) = hello["state"]["x"]["geometry"]
    assert isinstance(version, int)
    assert hub.drawing(0, version) is geo.encoded  # encoded once, served as it is
    assert '"path"' not in json.dumps(hello) and '"path"' in geo.encoded.decode()
    hub.set_geometry(0, geometry.build(CH, hops_program(3)))
    assert hub.drawing(0, version) is None  # stale: the page gets the new version next
    assert hub.drawing(0, version + 1) is not None and hub.drawing(5, version + 1) is None
