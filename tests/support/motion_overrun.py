"""The path is never faster than the rules let it be (issue 36, item 1; sixth round, part O):
tests/support/motion_check.py explains every slowdown, this checks the other side. A PLC
reads v_path for laser power: a path above F × override is as wrong as a stop (a cache bug of
the fifth round ran a 1 mm/s block at 19.3 mm/s, and no check saw it).

The rules:

* **In every cycle** the path velocity is at most the ceiling of the block it is in (F ×
  override within the axes' and the lift's caps, `PathRules.ceiling`; 0 under a feed hold,
  at override 0 and while the channel does not run).
* **At a block boundary** it is at most the transition cap (hard) and the lower of the two
  blocks' ceilings.
* **Except after an input lowered the ceiling** (the override drops, a feed hold or a PLC STOP
  starts) while the path was above the new one: the CNC brakes from the velocity it has, it
  does not cut it. While it is above, the path does not accelerate (a positive acceleration
  at the drop is ramped out at full jerk, lifting it to v + a²/2J at most) and comes down
  without a pause: its acceleration is negative or falling in every cycle. Meanwhile it may
  pass feed caps above them (the tracker's `Plan.soft_from`) but never a hard cap: the
  transition cap and the axes' and the lift's caps, which no override scales.

Tolerances: rounding only. A velocity within `OVER_REL` (1e-6, relative) plus `OVER_ABS`
(1e-9 m/s) above its cap is at it (the core reads a crossing within 1e-6 of its cap as at the
cap: path/constraints.py CAP_TOL). The velocity at a boundary is interpolated between two
samples with a constant jerk; the profile can change its jerk inside the cycle, which moves
the velocity there by at most J·dt²/4 (J the path's jerk limit there), added at boundaries.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from tests.support.motion_rules import INF, PathRules, Sample

OVER_REL = 1e-6
OVER_ABS = 1e-9  # m/s


def _over(v: float, cap: float, extra: float = 0.0) -> bool:
    return v > cap * (1.0 + OVER_REL) + OVER_ABS + extra


def input_ceiling(path: PathRules, k: int, smp: Sample) -> float:
    """The ceiling of segment k under the inputs in effect in `smp`'s cycle."""
    if smp.hold or smp.override <= 0.0 or not smp.running:
        return 0.0
    return path.ceiling(min(k, path.n - 1), smp.override)


def projected(path: PathRules, smp: Sample) -> float:
    """The velocity the path reaches with its acceleration ramped out at the jerk limit of its
    run (the one the tracker plans with): v + a²/2J where a > 0."""
    j = path.run_jerk(smp.seg)
    if smp.a <= 0.0 or j == INF:
        return smp.v
    return smp.v + smp.a * smp.a / (2.0 * j)


def overruns(
    path: PathRules,
    dt: float,
    samples: Sequence[Sample],
    at: Callable[[Sample, Sample, float], float],
) -> list[str]:
    """Every cycle and boundary in `samples` where the path is faster than the rules let it
    be, as text starting with "overrun" (empty: none). `at` gives the velocity where the path
    passed a position between two samples."""
    out: list[str] = []
    above = -1.0  # coming down from above the ceiling: the highest velocity it may still have
    reported = False  # that brake broke a rule (reported once a brake)
    over_in = -1  # the segment the path runs through above its ceiling (reported)
    last: Sample | None = None
    for smp in samples:
        if last is None:
            last = smp
            continue
        k = min(smp.seg, path.n - 1)
        ceiling = input_ceiling(path, k, smp)
        hard = path.hard(k)
        if input_ceiling(path, last.seg, smp) < input_ceiling(path, last.seg, last):
            # an input lowered the ceiling in this cycle: braking from above it is the rule
            top = max(projected(path, last), last.v)
            if _over(top, input_ceiling(path, last.seg, smp)):
                above = max(above, top)
        soft = above >= 0.0  # feed caps may be passed above while braking (this cycle too)
        if above >= 0.0:
            if not _over(smp.v, ceiling):
                above, reported = -1.0, False  # down at the ceiling: held to it from here
            elif reported:
                pass
            elif _over(smp.v, min(above, hard)):
                reported = True
                out.append(
                    f"overrun: {smp.v * 1e3:.4f} mm/s in segment {k} (line "
                    f"{path.segs[k].line}) while braking from above its ceiling, at most "
                    f"{min(above, hard) * 1e3:.4f} (t={smp.t:.4f} s)"
                )
            elif smp.a >= 0.0 and smp.a >= last.a:
                reported = True
                out.append(
                    f"overrun: the brake from above the ceiling paused at {smp.v * 1e3:.4f} "
                    f"mm/s in segment {k} (line {path.segs[k].line}), ceiling "
                    f"{ceiling * 1e3:.4f} (t={smp.t:.4f} s)"
                )
            above = min(above, projected(path, smp))
        elif not _over(smp.v, ceiling):
            over_in = -1
        elif over_in != k:  # once a segment the path runs through above its ceiling
            over_in = k
            out.append(
                f"overrun: {smp.v * 1e3:.4f} mm/s in segment {k} (line {path.segs[k].line}) "
                f"above its ceiling {ceiling * 1e3:.4f} (t={smp.t:.4f} s)"
            )
        for b in range(last.seg + 1, min(smp.seg, path.n - 1) + 1):
            cap = min(path.bounds[b].v_cap, path.hard(b - 1), path.hard(b))
            if not soft:
                cap = min(cap, input_ceiling(path, b - 1, smp), input_ceiling(path, b, smp))
            _, j = path.limits(b - 1, b + 1)
            v_b = at(last, smp, path.bounds[b].s)
            if _over(v_b, cap, j * dt * dt / 4.0 if j != INF else 0.0):
                out.append(
                    f"overrun: boundary {b} (line {path.bounds[b].line}) at {v_b * 1e3:.4f} "
                    f"mm/s above its cap {cap * 1e3:.4f} (t={smp.t:.4f} s)"
                )
        last = smp
    return out
