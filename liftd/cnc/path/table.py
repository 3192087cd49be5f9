"""What the path tracker needs to know about a prepared path, in flat lists built once in path
preparation (never in the GEO cycle).

* **Ceilings.** Segment k may run at V_k(ov) = min(F_k · ov, C_k): F_k the programmed feed
  (soft: scaled by the override; a path-based lift range's reduced feed is part of it), C_k the
  hard cap from the axes and an Advanced lift range (never scaled).
* **Runs.** A boundary is *continuous* when the path is tangent there (or, with
  `limits.SMOOTH_KINKS`, its kink small enough to carry the path acceleration through:
  `Boundary.smooth`), and both segments' acceleration and jerk limits agree within
  RUN_LIMIT_TOL (collinear polyline blocks, pieces of one circle). A run is a maximal sequence of
  segments joined by continuous boundaries: inside a run the path acceleration is continuous;
  at a run boundary (a larger corner, a change of the limits, a stop) it is zero, as the
  transition rule of `limits.py` assumes. Each run has one acceleration and one jerk limit (the
  smallest of its segments).
* **Constraints.** Boundary b is a constraint when the path may have to be slower there than in
  the segments around it: a stop, a conditional stop (MVS_SNS), a run boundary, a transition cap
  below the axis caps, or a ceiling drop. `next_constraint[b]` is the first constraint at or
  after b, so the tracker skips the plain boundaries of a polyline in O(1).
* **Sums for lower bounds.** `sum_l_f[k]`, `sum_l_c[k]`: Σ L/F and Σ L/C over the segments
  before k: beyond a few constraints a remaining time is bounded below by max(ΣL/F / ov, ΣL/C).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TypeVar

from liftd.cnc.path.program import PathProgram
from liftd.cnc.pause import EVERY, pause

INF = float("inf")
TANGENT_TOL = 1e-9  # |Δ direction cosine| below which a transition counts as tangent
LIMIT_TOL = 1e-9  # relative difference below which two limits count as equal
RUN_LIMIT_TOL = 0.05  # relative difference of the limits two segments of one run may have


def _close(x: float, y: float) -> bool:
    """Limits close enough for one run (which keeps the lower): the projections of the axis
    limits on the two lines of a small kink differ by a few per cent."""
    if x == y:
        return True
    return abs(x - y) <= RUN_LIMIT_TOL * max(abs(x), abs(y))


def _same(x: float, y: float) -> bool:
    if x == y:
        return True
    return abs(x - y) <= LIMIT_TOL * max(abs(x), abs(y))


@dataclass(frozen=True, slots=True)
class PathTable:
    # per segment k (n segments)
    s0: tuple[float, ...]
    feed: tuple[float, ...]  # F_k (m/s), scaled by the override
    cap: tuple[float, ...]  # C_k (m/s), never scaled
    run: tuple[int, ...]  # run index of segment k
    # per boundary b (n + 1 boundaries; b lies before segment b, b = n is the program end)
    s: tuple[float, ...]
    point_cap: tuple[float, ...]  # transition cap at b (m/s); 0 at stops
    stop: tuple[bool, ...]  # the path always rests here
    conditional: tuple[bool, ...]  # MVS_SNS: rests here unless acknowledged in time
    gate: tuple[bool, ...]  # run boundary: the path acceleration is zero here
    constraint: tuple[bool, ...]
    replan: tuple[bool, ...]  # the tracker re-plans when it reaches b (ceiling or run changes)
    needs_time: tuple[bool, ...]  # b has actions: its exact passing time is reported
    next_constraint: tuple[int, ...]  # first constraint boundary ≥ b (n + 1 boundaries)
    next_gate: tuple[int, ...]  # first run boundary (or stop) ≥ b
    # per constraint boundary b: the next constraint after it with a lower feed, a lower hard
    # cap (min of the transition and axis caps); n + 1 where none (`Constraints.collect`)
    lower_feed: tuple[int, ...]
    lower_hard: tuple[int, ...]
    sum_l_f: tuple[float, ...]  # Σ_{j<b} L_j / F_j
    sum_l_c: tuple[float, ...]  # Σ_{j<b} L_j / C_j
    # per run
    run_a: tuple[float, ...]
    run_j: tuple[float, ...]

    @property
    def n(self) -> int:
        return len(self.s0)

    def ceiling(self, k: int, ov: float) -> float:
        """Highest path velocity in segment k at override ov."""
        f = self.feed[k] * ov
        c = self.cap[k]
        return f if f < c else c

    def entry_cap(self, b: int, ov: float) -> float:
        """Highest velocity at boundary b entering segment b (0 at the program end)."""
        if b >= self.n:
            return 0.0
        v = self.ceiling(b, ov)
        p = self.point_cap[b]
        return p if p < v else v


def build_table(path: PathProgram) -> PathTable:
    """The table of `path`: one pass per list, each pausing every EVERY + 1 items (pause.py;
    the passes are ~0.1–0.3 µs an item)."""
    segs = path.segments
    bounds = path.boundaries
    n = len(segs)
    s0: list[float] = []
    feed: list[float] = []
    cap: list[float] = []
    for k, seg in enumerate(segs):
        s0.append(seg.s0)
        feed.append(min(seg.feed, seg.v_lift_ov))
        cap.append(min(seg.v_phys, seg.v_lift))
        if not k & EVERY:
            pause()
    gate = [True] * (n + 1)
    for k in range(1, n):
        prev, nxt = segs[k - 1], segs[k]
        t_in = prev.geom.tangent(prev.length)
        t_out = nxt.geom.tangent(0.0)
        tangent = all(abs(x - y) <= TANGENT_TOL for x, y in zip(t_in, t_out, strict=True))
        smooth = tangent or bounds[k].smooth
        limits = _close(prev.a_max, nxt.a_max) and _close(prev.j_max, nxt.j_max)
        gate[k] = not (smooth and limits) or bounds[k].stop or bounds[k].conditional_stop
        if not k & EVERY:
            pause()
    run_of = [0] * n
    run_a: list[float] = []
    run_j: list[float] = []
    for k, seg in enumerate(segs):
        if k == 0 or gate[k]:
            run_a.append(seg.a_max)
            run_j.append(seg.j_max)
        else:
            run_a[-1] = min(run_a[-1], seg.a_max)
            run_j[-1] = min(run_j[-1], seg.j_max)
        run_of[k] = len(run_a) - 1
        if not k & EVERY:
            pause()
    s: list[float] = []
    point_cap: list[float] = []
    stop: list[bool] = []
    conditional: list[bool] = []
    needs_time: list[bool] = []
    for bd in bounds:
        s.append(bd.s)
        point_cap.append(0.0 if bd.stop else bd.v_cap)
        stop.append(bd.stop)
        conditional.append(bd.conditional_stop)
        needs_time.append(bool(bd.actions))
        if not bd.index & EVERY:
            pause()
    constraint = [True] * (n + 1)
    replan = [True] * (n + 1)
    for k in range(1, n):
        changes = not (_same(feed[k], feed[k - 1]) and _same(cap[k], cap[k - 1]))
        drop = not _same(feed[k], feed[k - 1]) and feed[k] < feed[k - 1]
        drop = drop or (not _same(cap[k], cap[k - 1]) and cap[k] < cap[k - 1])
        low_point = point_cap[k] < min(cap[k - 1], cap[k]) * (1.0 - LIMIT_TOL)
        constraint[k] = gate[k] or conditional[k] or drop or low_point
        replan[k] = constraint[k] or changes
        if not k & EVERY:
            pause()
    next_con = [n] * (n + 1)
    following = n
    for b in range(n, -1, -1):
        if constraint[b]:
            following = b
        next_con[b] = following
        if not b & EVERY:
            pause()
    next_gate = [n] * (n + 1)
    following = n
    for b in range(n, -1, -1):
        if gate[b] or stop[b] or conditional[b]:
            following = b
        next_gate[b] = following
        if not b & EVERY:
            pause()
    lower_feed = _next_lower(feed, constraint, n)
    hard = [min(point_cap[k], cap[k]) for k in range(n)]
    lower_hard = _next_lower(hard, constraint, n)
    sum_f = [0.0] * (n + 1)
    sum_c = [0.0] * (n + 1)
    for k, seg in enumerate(segs):
        sum_f[k + 1] = sum_f[k] + (seg.length / feed[k] if feed[k] > 0.0 else INF)
        sum_c[k + 1] = sum_c[k] + (seg.length / cap[k] if cap[k] > 0.0 else INF)
        if not k & EVERY:
            pause()
    return PathTable(
        s0=_frozen(s0),
        feed=_frozen(feed),
        cap=_frozen(cap),
        run=_frozen(run_of),
        s=_frozen(s),
        point_cap=_frozen(point_cap),
        stop=_frozen(stop),
        conditional=_frozen(conditional),
        gate=_frozen(gate),
        constraint=_frozen(constraint),
        replan=_frozen(replan),
        needs_time=_frozen(needs_time),
        next_constraint=_frozen(next_con),
        next_gate=_frozen(next_gate),
        lower_feed=_frozen(lower_feed),
        lower_hard=_frozen(lower_hard),
        sum_l_f=_frozen(sum_f),
        sum_l_c=_frozen(sum_c),
        run_a=_frozen(run_a),
        run_j=_frozen(run_j),
    )


def _next_lower(values: list[float], constraint: list[bool], n: int) -> list[int]:
    """For each constraint boundary b in 1 … n − 1: the next constraint boundary after it whose
    segment's value is lower (a monotonic stack, one pass), n + 1 where none; n + 1 elsewhere.
    The first constraint after b below any x ≤ values[b] lies on this chain from b."""
    out = [n + 1] * (n + 1)
    stack: list[int] = []
    for b in range(n - 1, 0, -1):
        if constraint[b]:
            x = values[b]
            while stack and values[stack[-1]] >= x:
                stack.pop()
            out[b] = stack[-1] if stack else n + 1
            stack.append(b)
        if not b & EVERY:
            pause()
    return out


T = TypeVar("T")


def _frozen(items: list[T]) -> tuple[T, ...]:
    """The list as a tuple, and a pause point (a list of 70 000 items: ~0.3 ms here)."""
    out = tuple(items)
    pause()
    return out
