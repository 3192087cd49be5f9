"""A proven lower bound of the path's program time over the same prepared path as the GEO core
(issue 36, item 3): no motion that keeps the core's rules can be faster, so a core time below
it means the core broke a rule (a limit, a cap, the look-ahead window's stop).

bench/reference_profile.py chains ruckig profiles with zero acceleration at every node, also at
the caps where the core's rules do not ask for it (a ceiling change or a look-ahead stop on a
straight line): a feasible motion, not the optimum, and the core beat it on 60 of 200
programs (by up to 0.53 %; seed 15: the core passes a collinear boundary 0.5 mm before a sharp
corner braking at 36 mm/s, the chain asked 23 mm/s there with zero acceleration). This bound
relaxes instead of restricting: it is the integral of ds / V(s) over the program, V(s) an upper
bound of the velocity any such motion can have at s:

* the ceiling of the segment (F × override within the axes' and the lift's caps), and at a
  block boundary its own cap (both ceilings, the transition cap; 0 at a stop);
* the look-ahead window: in segment k the path can stop at boundary k + look_ahead, through
  the run boundaries on the way (`window`: zero acceleration at each; `_gain` from each of
  the first four, the acceleration at the point itself free);
* around every run boundary (`PathTable.gate`: zero path acceleration there, stops included)
  the velocity after or before it is at most what full jerk and then full acceleration add
  to its bound within the distance (`_gain`); the run boundaries' bounds chained among
  themselves with the exact jerk-limited change (zero acceleration at both);
* every other bound carried along with the acceleration limit alone (a forward and a backward
  pass: v² ≤ u² + 2·A·Δs, the acceleration free everywhere).

Between two run boundaries (one set of limits, zero acceleration at both) the time is also at
least that of ruckig's time-optimal profile between their velocity bounds under the highest
ceiling between them, with nothing else in between; the bound takes the larger of the two.
That part rests on the profile's time not rising when an end velocity rises, which ruckig's
profiles showed on 3 523 random feasible cases (length 10 µm-100 mm, both ends, 0 exceptions)
but which is not proven here; the envelope alone is.

What it leaves out is what makes it a bound: the jerk away from the run boundaries (a switch
from accelerating to braking between two of them is instantaneous here), and zero acceleration
at the caps that are no run boundary. The grid is fine (`STEP`) and each cell is timed at the
higher of its two ends' bounds.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
from ruckig import RuckigError

from liftd.cnc.path.program import PathProgram
from liftd.cnc.path.table import PathTable
from liftd.cnc.path.velocity import reach_velocity
from tests.support.reference_profile import Piece

INF = float("inf")
STEP = 2e-5  # m: the grid (at most; at least 8 cells a segment)


def _gain(u: float, x: np.ndarray, a: float, j: float) -> np.ndarray:
    """The highest velocity at distance x from a point passed at u with zero acceleration
    (full jerk, then full acceleration; the acceleration at x free). By time reversal equally
    the highest velocity x before a point the path must pass at most at u with zero
    acceleration."""
    u = max(u, 0.0)  # a velocity: a rounding residue below 0 would make p < 0 and d NaN
    if j == INF:
        return np.sqrt(u * u + 2.0 * a * x)
    t1 = a / j
    x1 = u * t1 + j * t1**3 / 6.0
    v1 = u + 0.5 * a * t1
    # phase 1: j·t³/6 + u·t = x, a depressed cubic t³ + p·t + q = 0 (one real root)
    p = 6.0 * u / j
    q = -6.0 * np.minimum(x, x1) / j
    d = np.sqrt(q * q / 4.0 + p**3 / 27.0)
    t = np.cbrt(-q / 2.0 + d) + np.cbrt(-q / 2.0 - d)
    early = u + 0.5 * j * t * t
    late = np.sqrt(v1 * v1 + 2.0 * a * np.maximum(x - x1, 0.0))
    return np.where(x <= x1, early, late)


def lower_bound_time(prog: PathProgram, tb: PathTable, look_ahead: int, ov: float) -> float:
    """Seconds from rest at the program's start to rest at its end at the constant override
    `ov`, at least (waits count 0)."""
    n = tb.n
    la = max(1, look_ahead)
    bounds = prog.boundaries

    def stop(b: int) -> bool:
        return b == 0 or b >= n or tb.stop[b] or tb.conditional[b]

    def gate(b: int) -> bool:
        # zero acceleration where the tangent jumps (the axes' acceleration would jump with
        # it) and at rest; not where only the limits change on a tangent transition (the core
        # passes a line into a tangent arc of lower limits braking: seed 2, −0.2 m/s²)
        return stop(b) or (tb.gate[b] and bounds[b].kink and not bounds[b].smooth)

    def limits(k: int) -> tuple[float, float]:
        r = tb.run[min(max(k, 0), n - 1)]
        return tb.run_a[r], tb.run_j[r]

    def span_limits(b: int, nb: int) -> tuple[float, float]:
        """The highest limits of the runs between two run boundaries (a relaxation)."""
        lims = [limits(k) for k in range(b, max(nb, b + 1))]
        return max(x[0] for x in lims), max(x[1] for x in lims)

    ceil = [tb.ceiling(k, ov) for k in range(n)]
    own = [0.0 if stop(b) else min(ceil[b - 1], ceil[b], tb.point_cap[b]) for b in range(n + 1)]

    def window(first: int, w: int) -> list[tuple[int, float]]:
        """The look-ahead window's stop at w as the run boundaries after `first` see it: each
        one's highest velocity (zero acceleration there) from which the path still stops at w
        through the ones after it, nearest first."""
        chain = [(w, 0.0)]
        for g in range(w - 1, first, -1):
            if gate(g):
                nxt, e = chain[-1]
                a, j = span_limits(g, nxt)
                chain.append((g, min(own[g], reach_velocity(e, tb.s[nxt] - tb.s[g], a, j))))
        return chain[::-1]

    # the grid: segment k's points, its boundaries included once
    starts: list[int] = []
    pieces: list[np.ndarray] = []
    total = 0
    for k in range(n):
        length = tb.s[k + 1] - tb.s[k]
        cells = max(8, math.ceil(length / STEP))
        starts.append(total)
        pts = np.linspace(tb.s[k], tb.s[k + 1], cells + 1)
        pieces.append(pts if k == n - 1 else pts[:-1])
        total += len(pieces[-1])
    starts.append(total - 1)  # boundary n: the last point
    s = np.concatenate(pieces)
    acc = np.empty(len(s))
    vmax = np.empty(len(s))
    for k in range(n):
        # segment k's points; the last segment's include the program's end point (np.empty:
        # a point left out held whatever the memory held, and the bound varied run to run:
        # 4.2896, 4.3027, 4.4932 s or NaN for seed 2)
        lo, hi = starts[k], starts[k + 1] if k < n - 1 else total
        acc[lo:hi] = limits(k)[0]
        vmax[lo:hi] = ceil[k]
        w = k + la
        if w < n:  # the window's end as seen from segment k: a stop the path can make
            for g, e in window(k, w)[:4]:
                a, j = span_limits(k, g)
                vmax[lo:hi] = np.minimum(vmax[lo:hi], _gain(e, np.maximum(tb.s[g] - s[lo:hi], 0.0), a, j))  # fmt: skip
    idx = [starts[b] for b in range(n + 1)]
    for b in range(n + 1):
        vmax[idx[b]] = min(vmax[idx[b]], own[b])
    # the run boundaries: their bounds (zero acceleration there), chained with the exact change
    gates = [b for b in range(n + 1) if gate(b)]
    u = {b: float(vmax[idx[b]]) for b in gates}
    for b in gates:
        w = b - 1 + la
        if 0 < b < n and w < n:  # the window as seen from segment b − 1 when the path is at b
            for g, e in window(b, w):
                a, j = span_limits(b, g)
                u[b] = min(u[b], reach_velocity(e, tb.s[g] - tb.s[b], a, j))
    for _ in range(2):
        for prev, b in itertools.pairwise(gates):
            a, j = span_limits(prev, b)
            u[b] = min(u[b], reach_velocity(u[prev], tb.s[b] - tb.s[prev], a, j))
        for b, nxt in zip(reversed(gates[:-1]), reversed(gates[1:]), strict=False):
            a, j = span_limits(b, nxt)
            u[b] = min(u[b], reach_velocity(u[nxt], tb.s[nxt] - tb.s[b], a, j))
    for i, b in enumerate(gates):
        vmax[idx[b]] = min(vmax[idx[b]], u[b])
        if i + 1 < len(gates):  # after it, up to the next run boundary
            nb = gates[i + 1]
            a, j = span_limits(b, nb)
            sl = slice(idx[b], idx[nb] + 1)
            vmax[sl] = np.minimum(vmax[sl], _gain(u[b], s[sl] - tb.s[b], a, j))
        if i > 0:  # before it, back to the previous one
            pb = gates[i - 1]
            a, j = span_limits(pb, b)
            sl = slice(idx[pb], idx[b] + 1)
            vmax[sl] = np.minimum(vmax[sl], _gain(u[b], tb.s[b] - s[sl], a, j))
    # every bound carried along with the acceleration limit alone
    v = vmax.tolist()
    ds = np.diff(s).tolist()
    av = acc.tolist()
    for i in range(1, len(v)):
        v[i] = min(v[i], math.sqrt(v[i - 1] * v[i - 1] + 2.0 * av[i - 1] * ds[i - 1]))
    for i in range(len(v) - 2, -1, -1):
        v[i] = min(v[i], math.sqrt(v[i + 1] * v[i + 1] + 2.0 * av[i] * ds[i]))
    arr = np.array(v)
    top = np.maximum(arr[:-1], arr[1:])
    if np.any(top <= 0.0):
        return INF
    cell = np.diff(s) / top
    # between two run boundaries (one run: one set of limits) at least the time-optimal
    # profile between their bounds with nothing in between but the highest ceiling
    piece = Piece()
    result = 0.0
    for b, nb in itertools.pairwise(gates):
        env = float(np.sum(cell[idx[b] : idx[nb]]))
        a, j = span_limits(b, nb)
        try:
            alone = piece.time(tb.s[nb] - tb.s[b], u[b], u[nb], max(ceil[b:nb]), a, j)
        except RuckigError:
            alone = 0.0  # at the edge of what is feasible (rounding): the envelope alone
        result += max(env, alone)
    return result
