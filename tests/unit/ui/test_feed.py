"""The page's values: the catalogue's getters on a view, deltas only of what changed, and a lift
whose flags were TRUE between two updates still shown as TRUE then FALSE (the pulse rule)."""

from __future__ import annotations

from liftd.cnc.snapshot import ChannelState, GeoSnapshot, LiftPhase, LoopStats
from liftd.objects.catalog import Catalog, GeoView
from liftd.settings import load_settings
from liftd.ui.feed import Feed
from tests.support.paths import REPO

CH = load_settings(str(REPO / "config" / "liftd.toml")).channel
ACTIVE, SUPPRESSED = "GEO.ch1.Z.lift_active", "GEO.ch1.Z.lift_suppressed"
COUNT = "GEO.ch1.Z.lift_count"


def view(
    cycle: int, active: bool = False, suppressed: bool = False, count: int = 0, x: float = 0.0
) -> GeoView:
    snap = GeoSnapshot(
        cycle,
        cycle * 1e-3,
        ChannelState.ACTIVE,
        7,
        0,
        (x, 0.0, 0.001),
        0.1,
        1.0,
        1.0,
        2.0,
        False,
        active,
        suppressed,
        LiftPhase.UP if active else LiftPhase.NONE,
        0.0,
        0.0,
        -1,
        0,
        0,
        (),
        0.0,
        0.0,
        2,
        (0, 0, count),
    )
    return GeoView(snap, LoopStats(cycles=cycle))


def flags(deltas: list[dict[str, object]], sym: str) -> list[object]:
    return [d[sym] for d in deltas if sym in d]


def test_values_are_the_ads_objects_in_their_units() -> None:
    feed = Feed(Catalog(CH))
    feed.update(view(1, x=0.0123456))
    v = feed.values
    assert v["GEO.ch1.X.command_position"] == 123456  # 0.1 µm
    assert v["GEO.ch1.override"] == 1000 and v["GEO.ch1.override_max"] == 2000  # 0.1 %
    assert v["GEO.ch1.path_velocity"] == 100000.0  # µm/s
    assert v[ACTIVE] is False and v["GEO.ch1.state"] == 4 and v["GEO.cycle"] == 1


def test_only_changes_are_sent() -> None:
    feed = Feed(Catalog(CH))
    feed.update(view(1))
    (delta,) = feed.update(view(2, x=0.001))
    assert set(delta) == {"GEO.cycle", "GEO.ch1.X.command_position"}
    assert feed.update(view(2, x=0.001)) == []


def test_a_flag_seen_by_sampling_changes_once() -> None:
    feed = Feed(Catalog(CH))
    feed.update(view(1))
    assert flags(feed.update(view(20, active=True, count=1)), ACTIVE) == [True]
    assert flags(feed.update(view(40, active=False, count=1)), ACTIVE) == [False]


def test_a_lift_between_two_updates_is_a_pulse() -> None:
    feed = Feed(Catalog(CH))
    feed.update(view(1))
    deltas = feed.update(view(20, count=1))  # TRUE for a cycle in between, FALSE again
    assert flags(deltas, ACTIVE) == [True, False]
    assert feed.values[ACTIVE] is False
    assert [s.on for s in feed.history[0]] == [False, True]  # the Z plot shades it


def test_a_suppressed_range_pulses_its_own_flag() -> None:
    feed = Feed(Catalog(CH))
    feed.update(view(1))
    deltas = feed.update(view(20, count=1), {0: [True]})
    assert flags(deltas, SUPPRESSED) == [True, False] and flags(deltas, ACTIVE) == []


def test_two_lifts_in_one_update_while_the_second_runs() -> None:
    feed = Feed(Catalog(CH))
    feed.update(view(1, active=True, count=1))
    deltas = feed.update(view(20, active=True, count=3))  # ended, one more, the third running
    assert flags(deltas, ACTIVE) == [False, True, False, True]


def test_a_range_that_ends_as_the_next_starts_shows_false_between() -> None:
    feed = Feed(Catalog(CH))
    feed.update(view(1))
    feed.update(view(20, active=True, count=1))
    deltas = feed.update(view(40, active=True, count=2))  # ended, a few cycles FALSE, the next
    assert flags(deltas, ACTIVE) == [False, True]


def test_each_range_between_two_updates_pulses_its_own_flag_in_order() -> None:
    feed = Feed(Catalog(CH))
    feed.update(view(1))
    deltas = feed.update(view(20, count=2), {0: [False, True]})  # active, then suppressed
    on = [(k, v) for d in deltas for k, v in d.items() if k in (ACTIVE, SUPPRESSED)]
    assert on == [(ACTIVE, True), (ACTIVE, False), (SUPPRESSED, True), (SUPPRESSED, False)]


def test_a_one_cycle_range_before_the_running_one_keeps_its_flag() -> None:
    feed = Feed(Catalog(CH))
    feed.update(view(1))
    deltas = feed.update(view(20, active=True, count=2), {0: [True, False]})
    on = [(k, v) for d in deltas for k, v in d.items() if k in (ACTIVE, SUPPRESSED)]
    assert on == [(SUPPRESSED, True), (SUPPRESSED, False), (ACTIVE, True)]
    feed = Feed(Catalog(CH))
    feed.update(view(1))
    deltas = feed.update(view(20, suppressed=True, count=2), {0: [False, True]})
    on = [(k, v) for d in deltas for k, v in d.items() if k in (ACTIVE, SUPPRESSED)]
    assert on == [(ACTIVE, True), (ACTIVE, False), (SUPPRESSED, True)]


def test_a_new_program_counts_from_zero() -> None:
    feed = Feed(Catalog(CH))
    feed.update(view(1, count=5))
    assert flags(feed.update(view(20, count=1)), ACTIVE) == [True, False]
    assert flags(feed.update(view(40, count=0)), ACTIVE) == []


def test_history_keeps_ten_seconds() -> None:
    feed = Feed(Catalog(CH))
    for k in range(0, 12000, 20):
        feed.update(view(k, x=k * 1e-6))
    hist = feed.full()["history"][0]
    assert 9.9 <= hist[-1][0] - hist[0][0] <= 10.0 and hist[-1][1][0] == 11.98
