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
* **Except in the brake after an input changed the ceiling** (the override drops, a feed hold
  or a PLC STOP starts; or the override rises while the path brakes, which can leave a run
  boundary's cap in the jerk gap): the CNC brakes from the velocity it has, it does not cut
  it. The path may be above the new ceiling while it brakes; there it does not accelerate (a positive
  acceleration at the drop is ramped out at full jerk, lifting it to v + a²/2J at most) and
  comes down without a pause: its acceleration is negative or falling in every cycle (or
  zero in a cycle where it passed a run boundary, where it must be zero), until it is at the
  ceiling. Within that brake it may pass a block boundary above the feed caps
  (F × override) that it could no longer get down to with zero acceleration there from its
  state at the change, or at the last run boundary it passed in the brake (zero acceleration
  there; its velocity there read from the samples either side, `crossing_velocity`) (the
  tracker's `Plan.soft_from`, and `Targets.gap_over`, the jerk gap:
  docs/geo-core.md deviation 6), but never above a hard cap: the transition cap and the axes' and the
  lift's caps, which no override scales. The brake ends where the acceleration stops
  falling at or below the ceiling.

Tolerances: rounding only. A velocity within `OVER_REL` (1e-6, relative) plus `OVER_ABS`
(1e-9 m/s) above its cap is at it (the core reads a crossing within 1e-6 of its cap as at the
cap: path/constraints.py CAP_TOL). The velocity at a boundary is taken from the sample
nearer to it, v + a·Δt (Δt the time between them, from the distance), which the jerk can
move by J·Δt²/2, and through the crossing's time by (|a| + J·Δt)·J·Δt³/6 / v, at most (J
the higher of the two runs' jerk limits; Δt ≤ half a cycle): a boundary is over its cap
only where that lower bound is (`boundary_velocity`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

from tests.support.motion_rules import INF, PathRules, Sample, brake_distance, crossing_velocity

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


def _reachable(path: PathRules, drop: Sample, b: int, cap: float) -> bool:
    """From its state at the drop the path can be at `cap` with zero acceleration at boundary
    b (the lowest limits of the segments between)."""
    a, j = path.limits(drop.seg, b)
    return brake_distance(drop.v, drop.a, cap, a, j) <= path.bounds[b].s - drop.s + OVER_ABS


def _passed_gate(path: PathRules, last: Sample, smp: Sample) -> bool:
    return any(path.gate[b] for b in range(last.seg + 1, min(smp.seg, path.n - 1) + 1))


def boundary_velocity(path: PathRules, last: Sample, smp: Sample, b: int) -> tuple[float, float]:
    """The velocity where the path passed boundary b between two samples, from the nearer
    one (v + a·Δt, Δt by one Newton step on s + vΔt + aΔt²/2), and how far the jerk can have
    moved it: J·Δt²/2, and through the crossing's time, which the jerk moves the position
    by J·Δt³/6 at most, (|a| + J·Δt)·J·Δt³/6 / v (a brake that passes a feed drop at its
    cap still braking, −2.8 m/s² at 100 mm/s 0.7 ms from the sample: 0.1006 mm/s from the
    first, 0.0007 more from the second, feeds seed 956)."""
    s_b = path.bounds[b].s
    near = last if s_b - last.s <= smp.s - s_b else smp
    ds = s_b - near.s
    if near.v <= 0.0:
        return near.v, 0.0
    tau = ds / near.v
    tau -= (near.v * tau + near.a * tau * tau / 2.0 - ds) / max(near.v + near.a * tau, 1e-12)
    j = max(path.run_jerk(b - 1), path.run_jerk(b))
    if j == INF:
        return near.v + near.a * tau, INF
    moved = j * tau * tau / 2.0
    v_b = near.v + near.a * tau
    late = j * abs(tau) ** 3 / 6.0 / max(v_b - moved, 1e-12)  # the crossing's time, at most
    return v_b, moved + (abs(near.a) + j * abs(tau)) * late


def _boundaries(
    path: PathRules, last: Sample, smp: Sample, brake: Sample | None
) -> tuple[list[str], Sample | None]:
    """The boundaries passed between two samples above their caps (feed caps left out that
    the path could no longer get down to in a brake from `brake`), and the brake's state
    after them: at a run boundary (zero acceleration) what lies beyond is reachable from it."""
    out: list[str] = []
    for b in range(last.seg + 1, min(smp.seg, path.n - 1) + 1):
        cap = path.boundary_hard(b)
        feed = min(input_ceiling(path, b - 1, smp), input_ceiling(path, b, smp))
        if brake is None or _reachable(path, brake, b, feed):
            cap = min(cap, feed)
        v_b, moved = boundary_velocity(path, last, smp, b)
        if _over(v_b - moved, cap):
            out.append(
                f"overrun: boundary {b} (line {path.bounds[b].line}) at {v_b * 1e3:.4f} "
                f"mm/s above its cap {cap * 1e3:.4f} (t={smp.t:.4f} s)"
            )
        if brake is not None and path.gate[b]:
            # from there, its velocity read from the quintic through the samples either side
            # (`crossing_velocity`, as motion_check reads it): from v_b, v + a·Δt 0.79 ms
            # after a sample at −0.32 m/s², 40.606 mm/s where the jerk that ramps that
            # deceleration out at b gives 40.731, a feed cap of 40 mm/s 0.1 mm on read as
            # reachable, and x2 above it, 40.12, as an overrun (drops seed 277); v_b + moved,
            # an upper bound, is up to J·Δt² too high, and near rest far more
            v_g = crossing_velocity(last, smp, path.bounds[b].s)
            brake = replace(smp, s=path.bounds[b].s, v=v_g, a=0.0, seg=b)
    return out, brake


def overruns(path: PathRules, samples: Sequence[Sample]) -> list[str]:
    """Every cycle and boundary in `samples` where the path is faster than the rules let it
    be, as text starting with "overrun" (empty: none)."""
    out: list[str] = []
    drop: Sample | None = None  # in the brake after an input changed the ceiling: the state then
    top = INF  # the highest velocity the path may have in that brake
    reported = False  # that brake broke a rule (reported once a brake)
    over_in = -1  # the segment the path runs through above its ceiling (reported)
    last: Sample | None = None
    for smp in samples:
        if last is None:
            last = smp
            continue
        k = min(smp.seg, path.n - 1)
        ceiling = input_ceiling(path, k, smp)
        if input_ceiling(path, last.seg, smp) != input_ceiling(path, last.seg, last):
            # an input changed the ceilings for this cycle, which starts at `last`: a new plan
            # from that state, which may have to brake for caps it can no longer get down to
            drop, top, reported = last, max(projected(path, last), last.v), False
        brake = drop  # the brake this cycle's boundaries are read in
        if drop is not None:
            # negative or falling; or at zero where it passed a run boundary in this cycle
            # (zero acceleration there: the sample can fall on it)
            braking = smp.a < 0.0 or smp.a < last.a or _passed_gate(path, last, smp)
            if not _over(smp.v, ceiling):
                if not braking:
                    drop = None  # the brake ended at or below the ceiling
            elif reported:
                pass
            elif _over(smp.v, min(top, path.hard(k))):
                reported = True
                out.append(
                    f"overrun: {smp.v * 1e3:.4f} mm/s in segment {k} (line "
                    f"{path.segs[k].line}) while braking from above its ceiling, at most "
                    f"{min(top, path.hard(k)) * 1e3:.4f} (t={smp.t:.4f} s)"
                )
            elif not braking:
                reported = True
                out.append(
                    f"overrun: the brake from above the ceiling paused at {smp.v * 1e3:.4f} "
                    f"mm/s in segment {k} (line {path.segs[k].line}), ceiling "
                    f"{ceiling * 1e3:.4f} (t={smp.t:.4f} s)"
                )
            top = min(top, projected(path, smp))
        elif not _over(smp.v, ceiling):
            over_in = -1
        elif over_in != k:  # once a segment the path runs through above its ceiling
            over_in = k
            out.append(
                f"overrun: {smp.v * 1e3:.4f} mm/s in segment {k} (line {path.segs[k].line}) "
                f"above its ceiling {ceiling * 1e3:.4f} (t={smp.t:.4f} s)"
            )
        found, brake = _boundaries(path, last, smp, brake)
        out += found
        if drop is not None and brake is not None:
            drop = brake
        last = smp
    return out
