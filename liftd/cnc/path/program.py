"""Path preparation: decoded blocks → motion segments with limits, and the boundaries between
them with their transition caps, stops and actions (M functions, dwell, lift start/end, ...).

Boundary k lies before segment k; boundary 0 is the program start and boundary K (= number of
segments) the program end. Actions of a block that come "before its motion" (LIFT_START, M
functions output before the block) sit on the boundary before the block's segment, those "after
its motion" (LIFT_END, M functions output after the motion, M00, M02/M30, dwell, #FLUSH) on the
boundary after it. Blocks without motion put everything on the current boundary, in order.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import cast

from liftd.cnc.nc.blocks import Block, FlushKind, LiftEnd, LiftStart, MotionKind
from liftd.cnc.params import ChannelParams, MSync
from liftd.cnc.path.geometry import ArcSeg, LineSeg, Segment, Vec
from liftd.cnc.path.limits import segment_limits, transition
from liftd.cnc.pause import pause, release

INF = float("inf")


class ActionKind(enum.Enum):
    LIFT_START = "lift_start"
    LIFT_END = "lift_end"
    M_OUTPUT = "m_output"  # an M function is output to the PLC
    M_WAIT = "m_wait"  # wait for the acknowledge of an M function (sync types)
    M00 = "m00"  # programmed stop: wait for a start
    DWELL = "dwell"
    FLUSH = "flush"
    PROGRAM_END = "program_end"


@dataclass(frozen=True, slots=True)
class Action:
    kind: ActionKind
    line: int
    m_number: int = -1
    sync: MSync | None = None
    seconds: float = 0.0
    lift_start: LiftStart | None = None
    lift_end: LiftEnd | None = None


@dataclass(frozen=True, slots=True)
class PathSegment:
    index: int
    line: int
    geom: Segment
    s0: float  # global path position at the start of the segment (m)
    length: float
    v_phys: float  # velocity limit from the axes (m/s)
    feed: float  # programmed feed, capped by v_phys (m/s); G00 runs at v_phys
    a_max: float
    j_max: float
    rapid: bool
    v_lift: float = INF  # cap so a lift range takes at least Z's time (Advanced Lifting)
    v_lift_ov: float = INF  # reduced feed of a path-based lift range (scales with the override)

    def limited(self, v_lift_ov: float, a_max: float, j_max: float, v_lift: float) -> PathSegment:
        """A copy with a path-based lift range's limits (positional: ~4× faster than
        dataclasses.replace, which matters for 10 000 lift ranges)."""
        return PathSegment(
            self.index, self.line, self.geom, self.s0, self.length, self.v_phys, self.feed,
            a_max, j_max, self.rapid, v_lift, v_lift_ov,
        )  # fmt: skip


@dataclass(frozen=True, slots=True)
class Boundary:
    index: int
    s: float
    line: int  # source line of the last block that ends here (for display while waiting)
    v_cap: float  # transition velocity cap (limits.transition, adjacent segments); 0 at stops
    stop: bool  # the path must be at rest here
    conditional_stop: bool  # MVS_SNS: stop unless the M function was acknowledged in time
    actions: tuple[Action, ...]
    # the path acceleration may pass through (a tangent or small kink: limits.transition); a
    # run boundary of the table still needs the two segments' limits to agree
    smooth: bool = False
    kink: bool = False  # the tangent jumps here


@dataclass(frozen=True, slots=True)
class PathProgram:
    segments: tuple[PathSegment, ...]
    boundaries: tuple[Boundary, ...]
    start_position: Vec
    end_position: Vec

    @property
    def length(self) -> float:
        return self.boundaries[-1].s

    def block_velocities(self, k: int, override: float) -> tuple[float, float]:
        """Highest velocity of segment k at `override` (programmed feed within the axis and lift
        limits) and the velocity allowed at its end (corner rule; 0 at a stop); 0, 0 past the
        end."""
        if k >= len(self.segments):
            return 0.0, 0.0
        seg = self.segments[k]
        # nested 2-argument min: native in the compiled core (3 arguments: a generic call)
        v_max = min(min(min(seg.feed, seg.v_lift_ov) * override, seg.v_phys), seg.v_lift)  # noqa: PLW3301
        return v_max, min(self.boundaries[k + 1].v_cap, v_max)


_STOPPING = {
    ActionKind.M_WAIT,
    ActionKind.M00,
    ActionKind.DWELL,
    ActionKind.FLUSH,
    ActionKind.PROGRAM_END,
}


class _Builder:
    def __init__(self, ch: ChannelParams, start: Vec) -> None:
        self.ch = ch
        self.segments: list[PathSegment] = []
        self.actions: list[list[Action]] = [[]]
        self.lines: list[int] = [0]
        self.cond: list[bool] = [False]
        self.pos = start
        self.s = 0.0
        self.slope = ch.slope
        self.lift_target: tuple[int, float] | None = None  # (axis, POS) of the open range
        self.trans_vel_min = 0.0  # #TRANSVELMIN in effect (m/s; 0: off)
        self.v_min: list[float] = [0.0]  # per boundary: the one in effect at its next block

    def act(self, action: Action) -> None:
        self.actions[-1].append(action)
        self.lines[-1] = action.line

    def m_before(self, block: Block) -> None:
        for number in block.m_functions:
            sync = self.ch.m_sync_of(number)
            if sync in (MSync.MOS, MSync.MVS_SVS, MSync.MVS_SNS):
                self.act(Action(ActionKind.M_OUTPUT, block.line, number, sync))
            if sync is MSync.MVS_SVS:
                self.act(Action(ActionKind.M_WAIT, block.line, number, sync))

    def m_after(self, block: Block) -> None:
        for number in block.m_functions:
            sync = self.ch.m_sync_of(number)
            if number == 0:
                self.act(Action(ActionKind.M00, block.line, 0))
            elif sync in (MSync.MNS_SNS, MSync.MNE_SNS):
                self.act(Action(ActionKind.M_OUTPUT, block.line, number, sync))
                self.act(Action(ActionKind.M_WAIT, block.line, number, sync))
            elif sync is MSync.MVS_SNS:
                self.act(Action(ActionKind.M_WAIT, block.line, number, sync))
                self.cond[-1] = True

    def motion(self, block: Block) -> None:
        m = block.motion
        assert m is not None
        self.v_min[-1] = self.trans_vel_min
        geom: Segment
        if m.center is not None:
            geom = ArcSeg.make(m.start, m.end, m.center, m.sweep)
        else:
            geom = LineSeg.make(m.start, m.end)
        lim = segment_limits(geom, self.ch.axes, self.slope)
        rapid = m.kind is MotionKind.RAPID
        feed = lim.v_max if rapid else min(m.feed, lim.v_max)
        seg = PathSegment(
            len(self.segments),
            block.line,
            geom,
            self.s,
            geom.length,
            lim.v_max,
            feed,
            lim.a_max,
            lim.j_max,
            rapid,
        )
        self.segments.append(seg)
        self.s += geom.length
        self.pos = m.end
        self.actions.append([])
        self.lines.append(block.line)
        self.cond.append(False)
        self.v_min.append(0.0)

    def block(self, block: Block) -> None:
        if block.slope is not None:
            self.slope = block.slope
        if block.trans_vel_min is not None:
            self.trans_vel_min = block.trans_vel_min
        if block.lift_start is not None:
            self.act(Action(ActionKind.LIFT_START, block.line, lift_start=block.lift_start))
            start = block.lift_start
            self.lift_target = (self.ch.axis_names.index(start.axis), start.target)
        self.m_before(block)
        if block.motion is not None:
            self.motion(block)
        if block.dwell is not None:  # a G04 block's M functions "after" come after its time
            self.act(Action(ActionKind.DWELL, block.line, seconds=block.dwell))
        self.m_after(block)
        if block.flush is not None and block.flush is not FlushKind.CONTINUE:
            self.act(Action(ActionKind.FLUSH, block.line))
        if block.lift_end is not None:
            self.act(Action(ActionKind.LIFT_END, block.line, lift_end=block.lift_end))
            if self.lift_target is not None:  # the lift axis is at POS after the range
                z, target = self.lift_target
                self.pos = (*self.pos[:z], target, *self.pos[z + 1 :])
        if block.program_end:
            self.act(Action(ActionKind.PROGRAM_END, block.line))


def _is_stop(actions: list[Action]) -> bool:
    if any(a.kind in _STOPPING for a in actions):
        return True
    # a lift range without path motion (its start and its end on one boundary): the path waits
    # for Z. One range ending where the next starts (LIFT_END, then LIFT_START) is no reason to
    # stop: the path goes on and each range lands at its own POS (vendor §3, single-block LIFT).
    started = False
    for a in actions:
        if a.kind is ActionKind.LIFT_START:
            started = True
        elif a.kind is ActionKind.LIFT_END and started:
            return True
    return False


def prepare(blocks: tuple[Block, ...], ch: ChannelParams, start: Vec) -> PathProgram:
    """Build the path program of decoded `blocks` for channel `ch` starting at `start`."""
    b = _Builder(ch, start)
    for block in blocks:
        b.block(block)
        pause()  # ~5 µs of work a block
    segs = b.segments
    bounds: list[Boundary] = []
    for k, actions in enumerate(b.actions):
        stop = k == 0 or k == len(segs) or _is_stop(actions)
        cap = 0.0
        smooth = kink = False
        if k > 0 and k < len(segs):
            prev, nxt = segs[k - 1], segs[k]
            tr = transition(
                prev.geom.tangent(prev.length),
                prev.geom.normal_curvature(prev.length),
                nxt.geom.tangent(0.0),
                nxt.geom.normal_curvature(0.0),
                ch.axes,
                ch.cycle_time,
                INF not in (prev.j_max, nxt.j_max),
                max(prev.a_max, nxt.a_max),
                ch.corr_v_trans_jerk,
                ch.mode_trans_jerk,
                b.v_min[k],
            )
            smooth, kink = tr.smooth, tr.kink
            if not stop:
                cap = min(prev.v_phys, nxt.v_phys, tr.v_cap)
        s = segs[k].s0 if k < len(segs) else b.s
        bounds.append(
            Boundary(k, s, b.lines[k], cap, stop, b.cond[k], tuple(actions), smooth, kink)
        )
        pause()  # a transition velocity a boundary
    release(cast(list[object], b.actions))  # a list per boundary, copied to the tuples
    release(cast(list[object], b.lines))
    return PathProgram(tuple(segs), tuple(bounds), start, b.pos)
