"""PLC writes as the GEO loop applies them at the start of a cycle."""

from __future__ import annotations

from liftd.cnc.snapshot import ChannelState, Command, GeoInputs, PlcSignal, PlcWrite
from liftd.runtime.plc_inputs import PlcInputs
from tests.support.ads_harness import snapshot


def test_levels_hold_and_commands_are_edges() -> None:
    plc = PlcInputs(auto=False, ack_delay_s=0.02)
    assert plc.inputs(None, 0.001) == GeoInputs()  # nothing written: what simulate feeds
    assert plc.apply(PlcWrite(PlcSignal.OVERRIDE, 0.5))  # changes: the loop logs it
    assert not plc.apply(PlcWrite(PlcSignal.OVERRIDE, 0.5))  # a PLC writing it every cycle
    assert plc.apply(PlcWrite(PlcSignal.FEED_HOLD, 1.0))
    assert plc.apply(PlcWrite(PlcSignal.START, 1.0))
    assert plc.apply(PlcWrite(PlcSignal.M_ACK, 1.0))
    plc.take()
    assert plc.inputs(None, 0.002) == GeoInputs(0.5, True, Command.START, True)
    assert plc.inputs(None, 0.003) == GeoInputs(0.5, True, Command.NONE, False)  # levels stay
    plc.apply(PlcWrite(PlcSignal.OVERRIDE, 7.0))
    plc.take()
    assert plc.inputs(None, 0.004).override == 2.0  # clamped to 200 %


def test_a_write_takes_effect_in_the_cycle_after_the_one_that_reads_it() -> None:
    """The read and its event in one cycle, the re-plan it causes in the next: the loop calls
    `apply` for what it drains and `take` at the start of the following cycle."""
    plc = PlcInputs(auto=False, ack_delay_s=0.02)
    assert plc.apply(PlcWrite(PlcSignal.OVERRIDE, 0.5))
    assert plc.apply(PlcWrite(PlcSignal.STOP, 1.0))
    assert plc.apply(PlcWrite(PlcSignal.M_ACK, 1.0))
    assert plc.staged
    assert plc.inputs(None, 0.001) == GeoInputs()  # the cycle that read them: not yet
    plc.take()
    assert not plc.staged
    assert plc.inputs(None, 0.002) == GeoInputs(0.5, False, Command.STOP, True)
    # a level written back before it took effect changes nothing against what is staged
    assert plc.apply(PlcWrite(PlcSignal.OVERRIDE, 1.0))
    assert not plc.apply(PlcWrite(PlcSignal.OVERRIDE, 1.0))
    assert plc.inputs(None, 0.003).override == 0.5
    plc.take()
    assert plc.inputs(None, 0.004) == GeoInputs()


def test_the_automatic_plc_acknowledges_but_never_undoes_a_plc_stop() -> None:
    plc = PlcInputs(auto=True, ack_delay_s=0.0)
    waiting_m = snapshot(m_pending=8)
    assert plc.inputs(waiting_m, 0.010).m_ack  # synchronised M: acknowledged
    held = snapshot(state=ChannelState.HOLD)
    assert plc.inputs(held, 0.020).command is Command.START  # after M00: continued
    plc.apply(PlcWrite(PlcSignal.STOP, 1.0))
    plc.take()
    assert plc.inputs(snapshot(), 0.030).command is Command.STOP
    assert plc.inputs(held, 0.040).command is Command.NONE  # stopped by the PLC: stays held
    plc.apply(PlcWrite(PlcSignal.START, 1.0))
    plc.take()
    assert plc.inputs(held, 0.050).command is Command.START


def test_a_reload_keeps_the_plcs_levels_and_what_was_staged() -> None:
    """The loop replaces a channel's inputs when it takes a new configuration. The override
    and the feed hold the PLC wrote stay in effect (a new configuration neither releases a
    feed hold nor puts the path back to 100 %); a write read in that cycle was logged as taking
    effect in the next one, so it does; edges already taken (an acknowledge, a START) are not
    repeated."""
    old = PlcInputs(auto=False, ack_delay_s=0.02)
    old.apply(PlcWrite(PlcSignal.OVERRIDE, 0.4))
    old.apply(PlcWrite(PlcSignal.FEED_HOLD, 1.0))
    old.apply(PlcWrite(PlcSignal.START, 1.0))
    old.take()
    assert old.inputs(None, 0.001) == GeoInputs(0.4, True, Command.START, False)
    new = PlcInputs(auto=False, ack_delay_s=0.02)
    new.carry_over(old)
    assert not new.staged and new.inputs(None, 0.002) == GeoInputs(0.4, True, Command.NONE, False)
    assert not new.apply(PlcWrite(PlcSignal.OVERRIDE, 0.4))  # the same level again: no change
    assert new.apply(PlcWrite(PlcSignal.FEED_HOLD, 0.0))  # the hold's release is one
    old.apply(PlcWrite(PlcSignal.START, 1.0))
    old.apply(PlcWrite(PlcSignal.OVERRIDE, 0.7))
    old.apply(PlcWrite(PlcSignal.M_ACK, 1.0))
    new = PlcInputs(auto=False, ack_delay_s=0.02)
    new.carry_over(old)
    assert new.staged
    assert new.inputs(None, 0.003) == GeoInputs(0.4, True, Command.NONE, False)  # not yet
    new.take()
    assert new.inputs(None, 0.004) == GeoInputs(0.7, True, Command.START, True)


def test_the_loops_own_start_is_requested_once_and_undelivered_commands_survive_a_reload() -> None:
    """A reload's autostart and a repeat may both ask for START at one program boundary: one
    START. Two PLC commands read in one cycle reach the task one a cycle; a reload between them
    does not drop the second."""
    plc = PlcInputs(auto=False, ack_delay_s=0.02)
    plc.request(Command.START)
    plc.request(Command.START)
    assert plc.inputs(None, 0.001).command is Command.START
    assert plc.inputs(None, 0.002).command is Command.NONE
    plc.apply(PlcWrite(PlcSignal.STOP, 1.0))
    plc.apply(PlcWrite(PlcSignal.START, 1.0))
    plc.take()
    assert plc.inputs(None, 0.003).command is Command.STOP
    new = PlcInputs(auto=False, ack_delay_s=0.02)
    new.carry_over(plc)
    assert new.inputs(None, 0.004).command is Command.START
    assert new.inputs(None, 0.005).command is Command.NONE


def test_a_held_start_stays_first_and_what_follows_waits_behind_it() -> None:
    """While the loop prepares the run a START loads (preparer.py), the START is held: the
    levels and the acknowledge go on, the commands keep their order behind it."""
    plc = PlcInputs(auto=False, ack_delay_s=0.02)
    for sig in (PlcSignal.START, PlcSignal.STOP, PlcSignal.M_ACK):
        plc.apply(PlcWrite(sig, 1.0))
    plc.apply(PlcWrite(PlcSignal.OVERRIDE, 0.5))
    plc.take()
    ready = snapshot(state=ChannelState.READY)
    assert plc.start_next(ready) and plc.backlog == 2
    assert plc.inputs(ready, 0.001, hold_start=True) == GeoInputs(0.5, False, Command.NONE, True)
    assert plc.inputs(ready, 0.002, hold_start=True).command is Command.NONE
    assert plc.backlog == 2
    assert plc.inputs(ready, 0.003).command is Command.START  # prepared: in order
    assert plc.inputs(ready, 0.004).command is Command.STOP
    assert not plc.start_next(ready) and plc.backlog == 0


def test_the_automatic_plcs_start_after_m00_is_held_too() -> None:
    plc = PlcInputs(auto=True, ack_delay_s=0.0)
    held = snapshot(state=ChannelState.HOLD)
    assert plc.start_next(held)
    assert plc.inputs(held, 0.010, hold_start=True).command is Command.NONE
    assert plc.inputs(held, 0.020).command is Command.START
