"""An offline reference for the path's program time (issue 36, item 3): the time-optimal
jerk-limited velocity profile over the same prepared path as the GEO core (its ceilings,
transition caps, stops, run boundaries and run limits, the look-ahead window's stop), without
the cycle's bounds (no candidate limit, no margins, no step grid, unbounded time).

The profile is a chain of *nodes* with zero acceleration: the stops, the run boundaries (zero
path acceleration there by the model's rule), the boundaries whose own cap lies below a
neighbouring ceiling or where the ceiling changes by more than 2 %, and those where the
look-ahead window binds (the velocity from which the path can stop at the window's end, `look_ahead` segments
after the segment it is in). Between two nodes the limits are constant and the ceiling nearly
(the piece runs at its highest), so
the time-optimal motion from one node's velocity to the next is one ruckig position profile
(accelerate, cruise at the ceiling, brake: checked by ruckig itself, which also times it). The
node velocities are the highest that every later node stays reachable from (a backward pass)
and that can be reached from the earlier ones (a forward pass), with the closed forms of the
jerk-limited velocity change (path/velocity.py, reach_velocity), each checked by ruckig.

What it leaves out: the core carries the path acceleration through boundaries where nothing
binds (this puts zero acceleration at every binding cap and run boundary: slower than the
core where the core passes such a point accelerating), and it keeps µm margins, plans within
24 constraints at once and in steps of a cycle (slower than this). A known flaw: a piece
that spans a ceiling change whose point does not bind runs under the piece's highest ceiling,
which is faster than the path may go where the lower ceiling holds (seed 195: a 100 mm line
at F6000 × 0.77 followed by F52627 and a corner 0.7 mm later: the reference runs the line at
the higher feed; core / reference 1.38). The bench reports both directions
(bench/bench_reference.py).

It is therefore no lower bound: zero acceleration at a cap that is no run boundary is a
restriction the core does not have (seed 15: the core passes a collinear boundary 0.5 mm before
a sharp corner braking at 36 mm/s, the chain asks 23 mm/s there with zero acceleration; core /
reference 0.996). bench/reference_bound.py is the lower bound; the optimum lies between.
"""

from __future__ import annotations

from dataclasses import dataclass

from ruckig import InputParameter, Ruckig, RuckigError, Trajectory

from liftd.cnc.path.program import PathProgram
from liftd.cnc.path.table import PathTable
from liftd.cnc.path.velocity import change_distance, reach_velocity

INF = float("inf")
# a ceiling that changes by less than this (the axes' projected velocity limit on a slightly bent
# polyline) is no node: the piece runs at the highest of them (a relaxation: faster)
CEILING_STEP = 0.02
EDGE = 1e-6  # a piece this close to the length of its velocity change alone is that change


@dataclass(frozen=True, slots=True)
class Reference:
    time: float  # s, from rest at the program start to rest at its end
    nodes: int
    pieces_refused: int  # ruckig refused a piece at the passes' velocities (lowered, retried)


class Piece:
    """One ruckig position profile between two nodes."""

    def __init__(self) -> None:
        self.r = Ruckig(1)
        self.inp = InputParameter(1)
        self.inp.target_acceleration = [0.0]
        self.inp.current_acceleration = [0.0]
        self.inp.min_velocity = [0.0]
        self.traj = Trajectory(1)

    def time(self, length: float, v0: float, v1: float, top: float, a: float, j: float) -> float:
        """The time-optimal profile's duration. Where the two velocities are as far apart as
        the length allows (the passes put them there: `reach_velocity`), the profile is the
        velocity change alone, point-symmetric about its middle: 2·L / (v0 + v1). Ruckig,
        given such an edge case, returned a longer profile (seed 2: 0.2 mm from 1.1 to
        25.9 mm/s, 17.1 ms for the change's 14.8), and the core was "faster than the
        reference" there."""
        if v0 + v1 > 0.0 and change_distance(v0, v1, a, j) >= length * (1.0 - EDGE):
            return 2.0 * length / (v0 + v1)
        inp = self.inp
        inp.current_position = [0.0]
        inp.current_velocity = [v0]
        inp.target_position = [length]
        inp.target_velocity = [v1]
        inp.max_velocity = [max(top, v0, v1)]
        inp.max_acceleration = [a]
        inp.max_jerk = [j]
        self.r.calculate(inp, self.traj)
        return float(self.traj.duration)


def reference_time(prog: PathProgram, tb: PathTable, look_ahead: int, ov: float) -> Reference:
    """The reference program time at a constant override `ov` (no waits: the programs of the
    corpus have none but their end)."""
    n = tb.n
    la = max(1, look_ahead)
    ceil = [tb.ceiling(k, ov) for k in range(n)]

    def limits(k: int) -> tuple[float, float]:
        r = tb.run[min(k, n - 1)]
        return tb.run_a[r], tb.run_j[r]

    def stop(b: int) -> bool:
        return b == 0 or b >= n or tb.stop[b] or tb.conditional[b]

    def gate(b: int) -> bool:
        return stop(b) or tb.gate[b]

    def own_cap(b: int) -> float:
        return 0.0 if stop(b) else min(ceil[b - 1], ceil[b], tb.point_cap[b])

    def changes(b: int) -> bool:  # the ceiling changes by more than CEILING_STEP
        if b == 0 or b >= n:
            return False
        lo, hi = min(ceil[b - 1], ceil[b]), max(ceil[b - 1], ceil[b])
        return hi > lo * (1.0 + CEILING_STEP)

    cand = [gate(b) or changes(b) or own_cap(b) < min(ceil[b - 1], ceil[b]) for b in range(n + 1)]

    def allowed(b: int, caps: dict[int, float], end: int) -> float:
        """The highest velocity at b from which every candidate after it up to `end` (its cap
        `caps`) stays reachable, as the core keeps them: each one of its run directly (the path
        acceleration passes them), the run's end with zero acceleration (its own value in
        `caps`, computed before)."""
        best = INF
        a, j = limits(b)
        for k in range(b + 1, end + 1):
            if k in caps:
                best = min(best, reach_velocity(caps[k], tb.s[k] - tb.s[b], a, j))
            if gate(k) or k == end:
                break
        return best

    # the look-ahead window's stop as seen from segment b − 1, when the path reaches b
    window = [INF] * (n + 1)
    for b in range(1, n):
        w = b - 1 + la
        if w >= n:
            continue  # the program's end lies within: the pass below keeps it
        caps = {w: 0.0}
        for k in range(w - 1, b, -1):
            if cand[k]:
                caps[k] = min(own_cap(k), allowed(k, caps, w)) if gate(k) else own_cap(k)
        window[b] = allowed(b, caps, w)
    # backward over the whole program: every later candidate reachable
    e: dict[int, float] = {n: 0.0}
    for b in range(n - 1, -1, -1):
        if cand[b] or window[b] < INF:
            top = min(own_cap(b), window[b]) if b > 0 else 0.0
            e[b] = min(top, allowed(b, e, n)) if gate(b) else top
    # the velocity at each candidate: what the ones after it allow (directly within its run)
    # and what the path can have reached from the last run boundary and the last candidate
    # it had to slow down for (zero acceleration there)
    u: dict[int, float] = {}
    last_gate, slow = 0, 0
    for b in sorted(e):
        if b == 0:
            u[0] = 0.0
            continue
        a, j = limits(b - 1)
        v = min(e[b], allowed(b, e, n))
        v = min(v, reach_velocity(u[last_gate], tb.s[b] - tb.s[last_gate], a, j))
        v = min(v, reach_velocity(u[slow], tb.s[b] - tb.s[slow], a, j))
        u[b] = v
        if gate(b):
            last_gate = slow = b
        elif v >= e[b] * (1.0 - 1e-9):
            slow = b  # at its cap: a turning point or a cruise, zero acceleration
    nodes = [b for b in sorted(u) if gate(b) or u[b] >= e[b] * (1.0 - 1e-9)]
    piece = Piece()
    total = 0.0
    refused = 0
    for i in range(len(nodes) - 1):
        b0, b1 = nodes[i], nodes[i + 1]
        a, j = limits(b0)
        length = tb.s[b1] - tb.s[b0]
        top = max(ceil[b0:b1])  # a relaxation where the ceiling changes inside (≤ CEILING_STEP)
        v0, v1 = u[b0], u[b1]
        for attempt in range(40):
            try:
                total += piece.time(length, v0, v1, top, a, j)
                break
            except RuckigError:
                refused += 1
                # at the edge of what is feasible (rounding of the closed forms): the ends a
                # little lower (the reference only gets slower by it)
                shrink = 1.0 - 1e-9 * 4**attempt
                if change_distance(v0, v1, a, j) > length:
                    v0, v1 = (v0 * shrink, v1) if v0 > v1 else (v0, v1 * shrink)
                else:
                    v0, v1 = v0 * shrink, v1 * shrink
        u[b1] = v1
    return Reference(total, len(nodes), refused)
