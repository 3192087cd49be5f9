"""The path core in closed loop: GeoTask.step driven with a virtual clock in plain loops."""

from __future__ import annotations

import math
import random

import numpy as np
import pytest

from liftd.cnc.nc import DecoderContext, decode
from liftd.cnc.params import MSync, SlopeType
from liftd.cnc.path.interpolator import Interpolator
from liftd.cnc.path.program import prepare
from liftd.cnc.path.table import build_table
from liftd.cnc.plc import Schedule, parse_feedhold_spec, parse_override_spec
from liftd.cnc.snapshot import ChannelState, Command, GeoInputs
from tests.support.channel import make_channel
from tests.support.closed_loop import events, fd_ratios, positions, run

TOL = 1 + 1e-9
MM = 1e-3

POLYLINE = "G01 X10 Y10 F6000\nX50\nY40\nX10 Y45\nX10 Y10\nM30\n"
ROUNDED = (
    "G01 X20 Y10 F9000\nX80\nG03 X90 Y20 I0 J10\nG01 Y60\nG03 X80 Y70 I-10 J0\nG01 X20\n"
    "G03 X10 Y60 I0 J-10\nG01 Y20\nG03 X20 Y10 I10 J0\nG02 I0 J5\nM30\n"
)
RAPID = "G00 X300 Y200 Z40\nG00 X10 Y10 Z1\nG01 X400 F30000\nM30\n"


def zigzag(n: int, step: float = 2.0, feed: float = 12000) -> str:
    lines = [f"G01 X10 Y10 F{feed}"]
    for i in range(n):
        lines.append(f"X{10 + (i + 1) * step:.3f} Y{10 + (i % 2) * 0.5:.3f}")
    lines.append("M30")
    return "\n".join(lines) + "\n"


def sched(override: str = "", hold: str = "") -> Schedule:
    return Schedule(tuple(parse_override_spec(override)), tuple(parse_feedhold_spec(hold)))


PROGRAMS = {"polyline": POLYLINE, "rounded": ROUNDED, "rapid": RAPID, "zigzag": zigzag(60)}


@pytest.mark.parametrize("name", PROGRAMS)
def test_reaches_every_end_point_and_ends_at_rest(name: str) -> None:
    ch = make_channel()
    text = PROGRAMS[name]
    snaps = run(ch, text)
    assert snaps[-1].state is ChannelState.READY
    assert [e[0] for e in events(snaps, "geo.program_end")]
    end = decode(text, DecoderContext.from_channel(ch)).blocks[-2].motion
    assert end is not None
    assert snaps[-1].positions == pytest.approx(end.end, abs=1e-12)
    assert snaps[-1].v_path == 0.0


@pytest.mark.parametrize("name", PROGRAMS)
@pytest.mark.parametrize(
    "schedule",
    [
        sched(),
        sched("0:100,0.15:150,0.4:30,0.6:200"),
        sched(hold="0.1:0.2,0.5:0.05"),
        sched("0.05:0,0.2:120", "0.35:0.1"),
    ],
    ids=["constant", "override-steps", "feed-hold", "override-zero"],
)
def test_axis_limits_hold_on_every_sampled_cycle(name: str, schedule: Schedule) -> None:
    ch = make_channel()
    snaps = run(ch, PROGRAMS[name], schedule)
    assert snaps[-1].state is ChannelState.READY
    ratios = fd_ratios(ch, snaps)
    assert ratios.max() <= TOL, ratios


def test_limits_hold_for_step_slope_without_jerk_check() -> None:
    ch = make_channel(slope=SlopeType.STEP)
    snaps = run(ch, ROUNDED, sched("0.2:170"))
    ratios = fd_ratios(ch, snaps)
    assert ratios[:2].max() <= TOL  # velocity and acceleration; STEP has no jerk limit


@pytest.mark.parametrize("cycle", [0.00025, 0.002, 0.01])
def test_limits_hold_at_other_cycle_times(cycle: float) -> None:
    ch = make_channel(cycle_time=cycle)
    snaps = run(ch, ROUNDED, sched("0.3:140"))
    assert fd_ratios(ch, snaps).max() <= TOL


def test_override_and_feed_hold_act_smoothly() -> None:
    ch = make_channel()
    snaps = run(ch, "G01 X10 Y10 F30000\nX600\nM30\n", sched("0.3:50", "0.6:0.3"))
    v = np.array([s.v_path for s in snaps])
    t = np.array([s.t for s in snaps])
    on_x = np.array([s.segment == 1 for s in snaps])[1:]  # the X-only block
    dv = np.abs(np.diff(v)) / ch.cycle_time
    assert dv[on_x].max() <= ch.axis("X").a_max * TOL  # no velocity jumps
    held = v[(t > 0.75) & (t < 0.9)]
    assert held.max() == 0.0  # stopped during the hold
    cruise = v[(t > 0.5) & (t < 0.6)]
    assert cruise == pytest.approx(0.25, rel=1e-6)  # 500 mm/s at 50 %


def test_path_velocity_respects_feed_and_override() -> None:
    ch = make_channel()
    snaps = run(ch, "G01 X10 Y10 F6000\nX400\nM30\n", sched("0:150"))
    assert max(s.v_path for s in snaps) == pytest.approx(0.15, rel=1e-6)


def prepared(text: str, look_ahead: int = 120, lead: int = 300) -> Interpolator:
    ch = make_channel(look_ahead=look_ahead)
    blocks = decode(text, DecoderContext.from_channel(ch)).blocks
    program = prepare(blocks, ch, (0.0, 0.0, 0.0))
    return Interpolator(program, build_table(program), look_ahead, 1e-3, lead)


@pytest.mark.parametrize("seed", range(12))
@pytest.mark.parametrize("override", [0.6, 1.0, 1.8])
def test_remaining_time_is_exact_in_the_committed_future_and_a_lower_bound_beyond(
    seed: int, override: float
) -> None:
    rng = random.Random(seed)
    pts = [(10.0, 10.0)]
    for _ in range(rng.randint(4, 25)):
        x, y = pts[-1]
        pts.append((x + rng.uniform(0.3, 40.0), y + rng.uniform(-20.0, 20.0) * rng.random()))
    feed = rng.choice([3000, 12000, 30000, 60000])
    mark = len(pts) - rng.randint(0, 2)  # an M function (MOS) after this block: reported
    text = (
        f"G01 X{pts[0][0]} Y{pts[0][1] + 20} F{feed}\n"
        + "".join(
            f"X{x:.3f} Y{y + 20:.3f}{' M05' if i == mark else ''}\n"
            for i, (x, y) in enumerate(pts[1:], start=2)
        )
        + "M30\n"
    )
    ip = prepared(text, lead=rng.choice([20, 300]))
    ip.set_inputs(override, False)
    ip.resume(0.0)
    end = len(ip.program.segments)  # the last motion's end: a stop (M30, or a decoding error)
    k_to = next((b.index for b in ip.program.boundaries if b.actions and b.index > 0), end)
    dt = 1e-3
    predictions: list[tuple[float, bool]] = []
    actual = None
    t = 0.0
    while actual is None and t < 60:
        t += dt
        for c in ip.advance(t):
            if c.boundary == k_to:
                actual = c.t
        if actual is None:
            predictions.append((ip.arrival(k_to), ip.exact(k_to)))
        if ip.stopped_at is not None and actual is None:
            if ip.stopped_at == len(ip.program.segments):
                break
            ip.resume(t)
    assert actual is not None
    assert all(p <= actual + 1e-12 for p, _ in predictions)  # never later than the truth
    exact = [p for p, e in predictions if e]
    assert exact and all(abs(p - actual) <= 1e-9 for p in exact)


def test_remaining_time_beyond_the_look_ahead_is_a_lower_bound() -> None:
    ip = prepared(zigzag(40), look_ahead=8, lead=5)
    ip.set_inputs(1.0, False)
    ip.resume(0.0)
    far = len(ip.program.segments)
    estimate = ip.arrival(far)
    t = 0.0
    while ip.stopped_at != far:
        t += 1e-3
        ip.advance(t)
    assert estimate <= t


def test_dwell_stops_the_path_for_exactly_its_time() -> None:
    ch = make_channel()
    snaps = run(ch, "G01 X10 Y10 F6000\nG04 X0.25\nX40\nM30\n")
    t = np.array([s.t for s in snaps])
    moving = np.array([s.v_path > 0 for s in snaps])
    stop_start = t[np.argmax(~moving[5:]) + 5]
    resume = t[np.argmax(moving & (t > stop_start))]
    assert resume - stop_start == pytest.approx(0.25, abs=2e-3)


def test_synchronised_m_function_waits_for_the_acknowledge() -> None:
    ch = make_channel()
    text = "G01 X10 Y10 F6000\nM04\nX30\nM05\nX40\nM08\nX50\nM30\n"  # SVS, MOS, MNS_SNS
    acks: list[float] = []

    def inputs(t: float, last: object) -> GeoInputs:
        ack = bool(last is not None and last.m_pending >= 0 and t >= 0.5 * (len(acks) + 1))  # type: ignore[attr-defined]
        if ack:
            acks.append(t)
        return GeoInputs(m_ack=ack)

    snaps = run(ch, text, inputs=inputs, max_time=5)
    assert ch.m_sync_of(4) is MSync.MVS_SVS and ch.m_sync_of(8) is MSync.MNS_SNS
    out = events(snaps, "geo.m_output")
    assert [v for _, _, v in out] == [4.0, 5.0, 8.0]
    t_m04 = out[0][0]
    moving_between = [s for s in snaps if t_m04 < s.t < acks[0] and s.v_path > 0]
    assert not moving_between  # no motion before the acknowledge
    assert next(s.m_pending for s in snaps if t_m04 < s.t < acks[0]) == 4
    assert snaps[-1].state is ChannelState.READY and len(acks) == 2  # M05 (MOS) not waited for


def test_m00_waits_for_start_and_stop_command_holds() -> None:
    ch = make_channel()
    state: dict[str, float] = {}

    def inputs(t: float, last: object) -> GeoInputs:
        cmd = Command.NONE
        if last is not None and last.state is ChannelState.HOLD and "m00" not in state:  # type: ignore[attr-defined]
            state["m00"] = t
        if "m00" in state and t >= state["m00"] + 0.3 and "go" not in state:
            state["go"] = t
            cmd = Command.START
        return GeoInputs(command=cmd)

    snaps = run(ch, "G01 X10 Y10 F6000\nM00\nX40\nM30\n", inputs=inputs, max_time=5)
    assert snaps[-1].state is ChannelState.READY
    assert state["go"] - state["m00"] == pytest.approx(0.3, abs=2e-3)


def test_program_error_runs_to_the_last_good_block() -> None:
    ch = make_channel()
    snaps = run(ch, "G01 X10 Y10 F6000\nX40\nX50 Q1\nX60\nM30\n")
    last = snaps[-1]
    assert last.state is ChannelState.ERROR
    assert (last.error_id, last.error_line) == (990018, 3)
    assert last.positions == pytest.approx((0.04, 0.01, 0.0), abs=1e-12)


def test_same_inputs_give_bit_identical_snapshots() -> None:
    ch = make_channel()
    schedule = sched("0.2:130,0.5:40", "0.7:0.2")
    a = run(ch, ROUNDED, schedule)
    b = run(ch, ROUNDED, schedule)
    assert a == b


def test_positions_are_finite_and_on_the_programmed_path() -> None:
    ch = make_channel()
    snaps = run(ch, ROUNDED)
    p = positions(snaps)
    assert np.isfinite(p).all()
    # every sample of the full circle G02 I0 J5 around (20, 15) mm lies on it
    on_circle = [
        math.hypot(x - 0.02, y - 0.015)
        for x, y, _ in p
        if abs(math.hypot(x - 0.02, y - 0.015) - 0.005) < 1e-6
    ]
    assert len(on_circle) > 100
