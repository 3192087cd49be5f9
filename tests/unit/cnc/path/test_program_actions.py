"""What a boundary does, in order: a G04 block's M functions around its time."""

from __future__ import annotations

from liftd.cnc.nc import DecoderContext, decode
from liftd.cnc.path.program import ActionKind, prepare
from tests.support.channel import make_channel


def test_a_dwell_comes_after_the_blocks_m_functions_before_and_before_those_after() -> None:
    ch = make_channel()
    blocks = decode(
        "G01 X10 F600\nG04 X0.5 M04 M05 M08\nG01 X20\nM30\n", DecoderContext.from_channel(ch)
    ).blocks
    program = prepare(blocks, ch, (0.0, 0.0, 0.0))
    at = next(b for b in program.boundaries if any(a.line == 2 for a in b.actions))
    done = [(a.kind, a.m_number) for a in at.actions if a.line == 2]
    K = ActionKind
    # M04 and M05 are output (and M04 waited for) before the time; M08 ("after") after it
    assert done == [
        (K.M_OUTPUT, 4),
        (K.M_WAIT, 4),
        (K.M_OUTPUT, 5),
        (K.DWELL, -1),
        (K.M_OUTPUT, 8),
        (K.M_WAIT, 8),
    ]
    assert at.stop
