"""`batch.run_quiet` equals `GeoTask.step` cycle for cycle: each quiet cycle's row holds what
that cycle's snapshot holds, the cycle that ends a batch is that snapshot, bit for bit (repr:
-0.0 and 0.0 differ), on the demo, a nesting job and programs with M functions, dwells, lift
ranges of both methods, an NC error inside a range; batches of every length."""

from __future__ import annotations

import random

import pytest

from liftd.cnc import batch
from liftd.cnc.geo_task import GeoTask
from liftd.cnc.params import ChannelParams, LiftMethod
from liftd.cnc.plc import Schedule, SimPlc
from liftd.cnc.snapshot import ChannelState, GeoSnapshot
from liftd.settings import load_settings
from liftd.sim.simulate import run_cycles
from tests.support.closed_loop import batch_row as row_of
from tests.support.paths import REPO
from tests.support.programs import nesting_program
from tests.support.scenarios import wide_scenario

CH = load_settings(str(REPO / "config" / "liftd.toml")).channel


def batched(ch: ChannelParams, text: str, seed: int) -> tuple[list[str], int]:
    """Every cycle of the run as `repr` of its row (quiet) or snapshot (not), the PLC answering
    as in `simulate`; batches of random length (1 … 300) after each quiet cycle; and how many
    cycles were rows."""
    rng = random.Random(seed)
    task, plc, width = GeoTask(ch, text), SimPlc(0.02), batch.row_width(len(ch.axes))
    dt, out, k, quiet, last = ch.cycle_time, [], 0, 0, None
    while k < 200_000:
        k += 1
        inputs = plc.inputs(last, k * dt, Schedule())
        rows: list[float] = []
        if last is not None and last.state is ChannelState.ACTIVE and last.m_pending < 0:
            snap = batch.run_quiet(task, inputs, k, rng.randint(1, 300), dt, rows)
        else:
            snap = task.step(inputs, k * dt)
        assert len(rows) % width == 0
        out += [repr(rows[i : i + width]) for i in range(0, len(rows), width)]
        quiet += len(rows) // width
        k += len(rows) // width
        out.append(repr(snap))
        last = snap
        ended = snap.state in (ChannelState.READY, ChannelState.ERROR) and task.runs
        if ended and snap.lift_vz == 0.0 and snap.lift_az == 0.0:
            break
    return out, quiet


def single(ch: ChannelParams, text: str, quiet_rows: list[str]) -> list[str]:
    """The same run by single steps, each cycle as `batched` should give it: its row where it
    was quiet and the batched run had a row there, else its snapshot."""
    task = GeoTask(ch, text)
    snaps = run_cycles(task, SimPlc(0.02), Schedule(), ch.cycle_time, 200.0)
    return [
        repr(row_of(s)) if q.startswith("[") and quiet(s) else repr(s)
        for s, q in zip(snaps, quiet_rows, strict=True)
    ]


def quiet(s: GeoSnapshot) -> bool:
    return s.state is ChannelState.ACTIVE and s.m_pending < 0 and not s.events


def nc_error_in_range() -> str:
    return (
        "G90 G01 X10 Y10 Z1 F6000\nZ[LIFT_START POS=1 POS_LIMIT=30]\nG01 X60 F12000\n"
        "G01 X80 Y30\nQ1 oops\nG01 X120\nZ[LIFT_END]\nG01 X140\nM30\n"
    )


CASES = {
    "demo": (CH, (REPO / "config" / "programs" / "demo.nc").read_text()),
    "nesting-6": (CH, nesting_program(6)),
    "nc-error-in-range": (CH, nc_error_in_range()),
    **{f"wide-{s}": (wide_scenario(s).channel, wide_scenario(s).text) for s in (3, 11, 29)},
    "wide-7-lifting": (
        wide_scenario(7, LiftMethod.LIFTING).channel,
        wide_scenario(7, LiftMethod.LIFTING).text,
    ),
}


@pytest.mark.parametrize("name", list(CASES))
def test_a_batch_is_its_single_steps(name: str) -> None:
    ch, text = CASES[name]
    got, quiet = batched(ch, text, seed=len(name))
    want = single(ch, text, got)
    assert len(got) == len(want)
    bad = [(i, g, w) for i, (g, w) in enumerate(zip(got, want, strict=True)) if g != w]
    assert bad[:3] == []
    assert quiet > 0.5 * len(got)  # most cycles ran as rows (else this compared little)
    if name == "nc-error-in-range":
        assert "ERROR" in got[-1]


def test_a_batch_of_one_is_a_step() -> None:
    """n = 1 runs the cycle as `step` and appends no row."""
    a, b = GeoTask(CH, nesting_program(1)), GeoTask(CH, nesting_program(1))
    plc = SimPlc(0.02)
    dt = CH.cycle_time
    last = None
    for k in range(1, 400):
        inputs = plc.inputs(last, k * dt, Schedule())
        rows: list[float] = []
        last = batch.run_quiet(a, inputs, k, 1, dt, rows)
        assert rows == []
        assert repr(last) == repr(b.step(inputs, k * dt))
