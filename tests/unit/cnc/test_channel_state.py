"""The channel's state machine on its own (cnc/channel_state.py): the rules at its top, each
transition with its event, without a program or a path."""

from __future__ import annotations

from liftd.cnc import events
from liftd.cnc.channel_state import ChannelStateMachine
from liftd.cnc.events import EventLog
from liftd.cnc.snapshot import ChannelState, Command


def machine() -> tuple[ChannelStateMachine, EventLog]:
    log = EventLog()
    return ChannelStateMachine(log), log


def names(log: EventLog) -> list[str]:
    out = [e.name for e in log.items]
    log.clear()
    return out


def test_a_stop_holds_only_once_the_path_is_at_rest_and_start_resumes() -> None:
    ch, log = machine()
    assert ch.takes_start(Command.START)
    ch.program_start(0.0, 1)
    assert ch.state is ChannelState.ACTIVE and ch.runs == 1
    assert not ch.request(Command.STOP) and ch.holding(feed_hold=False)
    assert not ch.stop_due(at_rest=False) and ch.state is ChannelState.ACTIVE
    assert ch.stop_due(at_rest=True)
    ch.stopped(0.5, 3)
    assert ch.state is ChannelState.HOLD and not ch.stop_requested
    ch.resume(0.7, 3)
    assert ch.state is ChannelState.ACTIVE and not ch.holding(feed_hold=False)
    assert names(log) == [events.PROGRAM_START, events.STOPPED, events.RESUME]


def test_a_reset_ends_an_error_and_its_ready_stands_until_a_start() -> None:
    ch, log = machine()
    ch.program_start(0.0, 1)
    ch.m_output(0.1, 2, 8, acknowledged=True)
    ch.error(0.2, 21558, 4, "oops")
    assert ch.state is ChannelState.ERROR and not ch.takes_start(Command.START)
    assert ch.request(Command.RESET) and not ch.stop_requested  # not ACTIVE: nothing brakes
    assert not ch.takes_start(Command.START)  # the RESET ends the program first
    assert ch.reset_due(at_rest=False)  # ERROR: the path does not move
    ch.reset_done(0.3, 4)
    assert ch.state is ChannelState.READY and ch.ready_after_reset
    assert (ch.error_id, ch.error_line, ch.m_pending) == (0, 0, -1)
    later, _ = machine()
    later.carry_over(ch)  # a reload's task takes over the channel
    assert later.ready_after_reset
    ch.program_start(0.4, 1)
    assert not ch.ready_after_reset
    assert names(log) == [events.PROGRAM_START, events.M_OUTPUT, events.ERROR, events.RESET,
                          events.PROGRAM_START]  # fmt: skip # the order of the calls above


def test_a_reset_of_a_moving_path_waits_for_rest() -> None:
    ch, _ = machine()
    ch.program_start(0.0, 1)
    assert ch.request(Command.RESET) and ch.stop_requested
    assert not ch.reset_due(at_rest=False) and ch.reset_due(at_rest=True)
    assert not ch.stop_due(at_rest=True)  # the RESET completes instead of a HOLD


def test_an_acknowledge_is_used_by_one_wait_from_its_time() -> None:
    ch, log = machine()
    ch.program_start(0.0, 1)
    ch.m_output(0.1, 2, 4, acknowledged=True)
    assert ch.m_pending == 4 and not ch.take_ack(4)
    assert ch.acknowledge(0.25, 2) == 4 and ch.m_pending == -1 and ch.ack_time == 0.25
    assert ch.take_ack(4) and not ch.take_ack(4)
    ch.m_output(0.3, 3, 5, acknowledged=False)
    assert ch.m_pending == -1
    ch.m00(0.4, 5)
    assert ch.state is ChannelState.HOLD
    assert names(log)[-2:] == [events.M_OUTPUT, events.M00]
