"""A lower bound of the time the path needs to reach a boundary: the relaxation of
docs/reference/path-planning.md fact 5.

Drop the jerk limit, drop every constraint beyond the target (the look-ahead window's end
included) and solve the rest exactly: acceleration-limited (each run's limit), with the
ceilings at the given override and the caps of the constraint boundaries on the way (stops
count as caps of 0; the waits there as 0). The true motion is one feasible solution of that
relaxed problem, so it takes at least as long; appending blocks to the window only relaxes it.
At most MAX_POINTS constraints are solved exactly; beyond them the remaining segments are
bounded by their length over their ceiling (prefix sums of the table), so the cost is bounded
whatever the program.
"""

from __future__ import annotations

import math

from liftd.cnc.path.table import PathTable
from liftd.cnc.path.velocity import change_distance, projected_velocity

INF = float("inf")
MAX_POINTS = 12
MAX_GATES = 64  # run boundaries walked for the stopping distance (`_stop_distance`)


def _interval_time(d: float, u0: float, u1: float, ceiling: float, acc: float) -> float:
    """Least time over distance d from u0 to u1 (u1 reachable) with |acceleration| ≤ acc and
    velocity ≤ max(ceiling, u0, u1)."""
    if d <= 0.0:
        return 0.0
    top = max(ceiling, u0, u1)
    peak = math.sqrt(max(0.5 * (2.0 * acc * d + u0 * u0 + u1 * u1), 0.0))
    if peak < max(u0, u1):  # not reachable in the relaxation either: faster than it can be
        return d / top if top > 0.0 else INF
    peak = min(peak, top)
    if peak <= 0.0:
        return INF
    t_ramp = (peak - u0) / acc + (peak - u1) / acc
    cruise = d - (2.0 * peak * peak - u0 * u0 - u1 * u1) / (2.0 * acc)
    return t_ramp + max(cruise, 0.0) / peak


def _stop_distance(tb: PathTable, s: float, seg: int, top: float) -> float:
    """An upper bound of the distance in which the path comes to rest from velocity `top`
    (zero acceleration) at s in segment `seg`, with zero acceleration at every run boundary
    on the way (`PathTable.gate`: a kink, a change of the limits); inf beyond MAX_GATES of
    them. Between two run boundaries L apart the velocity falls at least by the drop whose
    time-optimal change takes L / u at the velocity u it starts from (it covers at most L):
    a feasible drop, so the velocity it leaves is at least the lowest one there.
    (A stop in one brake of the run's limits, as this bound used to take it, is ten times
    shorter on 2 mm blocks with a kink each: wide seed 181 landed late, issue 36.)"""
    n = tb.n
    u, pos, b = top, s, seg + 1
    for _ in range(MAX_GATES):
        if u <= 0.0:
            return pos - s
        while b < n and not tb.gate[b]:
            b = tb.next_constraint[b + 1]
        r = tb.run[min(max(b - 1, 0), n - 1)]
        acc, jerk = tb.run_a[r], tb.run_j[r]
        length = tb.s[min(b, n)] - pos
        full = change_distance(u, 0.0, acc, jerk)
        if full <= length or b >= n:
            return pos - s + full
        span = length / u  # the drop's time, covering at most `length`
        if jerk == INF or 0.5 * jerk * span >= acc:
            drop = acc * span if jerk == INF else acc * (span - acc / jerk)
        else:
            drop = 0.25 * jerk * span * span
        u, pos, b = max(u - drop, 0.0), tb.s[b], b + 1
    return INF


def lower_bound_time(
    tb: PathTable, s: float, v: float, seg: int, target: int, ov: float, a: float = 0.0
) -> float:
    """Seconds the path needs at least from (s, v, a) in segment `seg` to boundary `target` at
    override `ov` (held constant); 0 if the target is behind, inf if the path cannot move.

    The feed caps (F × ov) are soft: after a sudden override decrease the path is above them
    until it has braked, and the tracker passes those it cannot get down to as slowly as it
    can (wide seed 1747: a bound that took them as hard said 1.61 s where the path arrived at
    1.49 s, and Z, planning against it, landed late). Meanwhile the velocity never rises above
    its projected value `top`, so a point's cap here is at least min(top, its hard cap); and
    beyond the distance in which the path can stop (twice it, to spare) every feed cap is
    reachable, so the tracker keeps it."""
    n = tb.n
    target = min(target, n)
    if target <= seg or s >= tb.s[target]:
        return 0.0
    if ov <= 0.0:
        return INF
    r0 = tb.run[min(seg, n - 1)]
    top = projected_velocity(v, max(a, 0.0), tb.run_j[r0])
    stop = _stop_distance(tb, s, seg, top) if top > 0.0 else 0.0
    settled = s + 2.0 * stop
    # the constraint points between here and the target (exclusive), then the target
    pos = [s]
    caps = [v]
    ceil = [0.0]  # ceiling of the interval ending at point i
    acc = [0.0]
    b = tb.next_constraint[seg + 1] if seg + 1 <= n else n
    cut = -1
    while b < target:
        if len(pos) > MAX_POINTS:
            cut = b
            break
        pos.append(tb.s[b])
        if tb.stop[b]:
            caps.append(tb.point_cap[b])
        else:
            hard = min(tb.cap[b], tb.point_cap[b]) if b < n else 0.0
            caps.append(max(tb.entry_cap(b, ov), min(top, hard)))
        ceil.append(tb.ceiling(b - 1, ov))
        acc.append(tb.run_a[tb.run[b - 1]])
        b = tb.next_constraint[b + 1] if b + 1 <= n else n
    end = target if cut < 0 else cut
    pos.append(tb.s[end])
    last_ceiling = tb.ceiling(end - 1, ov)
    # free at the end of the solved part (its ceiling at most, or what is left of a brake)
    caps.append(max(last_ceiling, min(top, tb.cap[end - 1])))
    ceil.append(last_ceiling)
    acc.append(tb.run_a[tb.run[end - 1]])
    m = len(pos)
    # backward: every cap reachable from the one before
    e = caps[:]
    for i in range(m - 2, 0, -1):
        lim = math.sqrt(e[i + 1] * e[i + 1] + 2.0 * acc[i + 1] * (pos[i + 1] - pos[i]))
        e[i] = min(e[i], lim)
    total = 0.0
    u = v
    for i in range(1, m):
        d = pos[i] - pos[i - 1]
        nxt = min(e[i], math.sqrt(u * u + 2.0 * acc[i] * d))
        total += _interval_time(d, u, nxt, ceil[i], acc[i])
        u = nxt
    if cut >= 0:  # the rest at its ceilings at the most (its feed caps once the path can keep them)
        hard_rest = tb.sum_l_c[target] - tb.sum_l_c[cut]
        if tb.s[cut] >= settled:
            total += max((tb.sum_l_f[target] - tb.sum_l_f[cut]) / ov, hard_rest)
        else:
            total += hard_rest
    return total
