"""What crosses the process boundary: snapshot + loop timing, PLC inputs, events (a pipe read
may end anywhere inside a record)."""

from __future__ import annotations

from liftd.cnc.snapshot import ChannelState, Event, LiftPhase, LoopStats, PlcSignal, PlcWrite
from liftd.runtime.records import (
    MAX_EVENT_TEXT,
    EventReader,
    SnapshotCodec,
    pack_event,
    pack_input,
    unpack_input,
)
from tests.support.ads_harness import snapshot


def test_snapshot_and_stats_round_trip_bit_exactly() -> None:
    codec = SnapshotCodec(3)
    snap = snapshot(
        cycle=123_456,
        t=123.456,
        state=ChannelState.HOLD,
        positions=(0.1 + 0.2, -1e-7, 0.15),
        v_path=0.123456789012345,
        override=0.75,
        lift_active=True,
        lift_suppressed=True,
        lift_phase=LiftPhase.DOWN,
        lift_vz=-0.98,
        m_pending=8,
        error_id=21558,
        error_line=14,
        events=(Event("lift.start", 1.0, 3),),
        lift_axis=0,
        lift_counts=(2, 0, 4_000_000_000),
    )
    stats = LoopStats(123_456, 7, 45.5, 130.25, 12.0, 480.0, 3, 210.5, 2)
    raw = codec.pack(snap, stats)
    assert len(raw) == codec.size
    back, back_stats = codec.unpack(raw)
    assert back == snap._replace(events=())  # events travel through the event pipe instead
    assert back.positions[0] == 0.1 + 0.2 and back_stats == stats


def test_plc_inputs_round_trip() -> None:
    for w in (PlcWrite(PlcSignal.OVERRIDE, 1.25), PlcWrite(PlcSignal.M_ACK, 1.0)):
        assert unpack_input(pack_input(w)) == w


def test_event_reader_reassembles_records_however_the_pipe_cuts_them() -> None:
    events = [
        Event("lift.start", 0.123, 20, 1.0, ""),
        Event("geo.error", 4.5, 33, 21558.0, "LIFT already active — LIFT_END expected"),
        Event("custom.name", 1.0, 2, 0.5, "a name not in the table travels in the text"),
        Event("geo.rt_setting", 0.0, 0, 0.0, "x" * (MAX_EVENT_TEXT + 500)),
    ]
    stream = b"".join(pack_event(e) for e in events)
    for chunk in (1, 3, 7, len(stream)):
        reader = EventReader()
        got = []
        for i in range(0, len(stream), chunk):
            got += reader.feed(stream[i : i + chunk])
        assert got[:3] == events[:3], chunk
        assert got[3].name == "geo.rt_setting"
        assert len(got[3].text.encode()) <= MAX_EVENT_TEXT  # bounded: one atomic pipe write
        assert len(got) == 4
