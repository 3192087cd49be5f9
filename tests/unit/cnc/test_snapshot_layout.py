"""The snapshot's one layout (`GeoSnapshot` with each field's record format): the GEO task's
positional tuple type follows it, the binary record is made from it and the record format
has not changed for the readers of an existing record (the trace files, the shared memory)."""

from __future__ import annotations

import struct
from typing import get_args, get_type_hints

from liftd.cnc import events
from liftd.cnc.snapshot import GeoSnapshot, LiftPhase, LoopStats, SnapshotFields
from liftd.runtime.records import EVENT_IDS, EVENT_NAMES, MachineCodec, SnapshotCodec
from tests.support.ads_harness import snapshot


def test_the_positional_tuple_type_is_the_class_field_by_field() -> None:
    """`new_snapshot` takes `SnapshotFields`: one type per field, in the class's order."""
    hints = get_type_hints(GeoSnapshot)  # without the record formats
    assert get_args(SnapshotFields) == tuple(hints[name] for name in GeoSnapshot._fields)


def test_the_record_format_is_the_one_readers_know() -> None:
    """The format written before the layout became a table (ed20d52), for 1 … 5 axes."""
    for n in range(1, 6):
        legacy = f"<qdiii{n}ddddd???iddiiiddi{n}Iqqddddqdq"
        assert SnapshotCodec(n).fmt.format == legacy
        assert SnapshotCodec(n).size == struct.calcsize(legacy)


def test_every_field_but_the_events_round_trips_in_a_machine_record() -> None:
    """Each field gets a value of its own, so a field packed into another's place fails."""
    snaps = [
        snapshot(
            cycle=7 + k,
            t=0.5 + k,
            line=11 + k,
            segment=12 + k,
            positions=(1.5 + k, -2.5, 3.25),
            v_path=0.125 + k,
            override=0.25,
            override_requested=0.375,
            override_max=1.75,
            feed_hold=True,
            lift_active=False,
            lift_suppressed=True,
            lift_phase=LiftPhase.HOLD_LIMIT,
            lift_vz=-0.5,
            lift_az=2.5,
            m_pending=8,
            error_id=21558,
            error_line=14,
            v_block_max=0.625,
            v_block_end=0.0625,
            lift_axis=2,
            lift_counts=(1, 2 + k, 3),
        )
        for k in range(2)
    ]
    codec = MachineCodec([3, 3])
    stats = LoopStats(5, 1, 2.5, 3.5, 4.5, 5.5, 6, 7.5, 8)
    back, back_stats = codec.unpack(codec.pack(snaps, stats))
    assert list(back) == snaps and back_stats == stats
    assert back[0].lift_phase is LiftPhase.HOLD_LIMIT and back[1].state is snaps[1].state


def test_event_records_number_the_names_as_before() -> None:
    """An event record's id is its name's index: the order is the record format."""
    ids = {events.PROGRAM_START: 1, events.RESET: 5, events.LIFT_Z_ACC_ERROR: 18}
    assert {name: EVENT_IDS[name] for name in ids} == ids
    assert EVENT_NAMES[25] == events.LIFT_ABORTED == "lift.aborted"
    assert len(set(EVENT_NAMES)) == len(EVENT_NAMES)
