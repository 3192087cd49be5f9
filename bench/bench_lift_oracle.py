"""Advanced Lifting height against an independent upper bound (issue 4).

Oracle: a linear program over a piecewise-constant jerk sequence on a grid h (exact
integration), with |j| ≤ J, |a| ≤ A, |v| ≤ V and p ≤ POS_LIMIT at the nodes, start at rest at
z0, end at rest at POS after T (docs/reference/lift-algorithm.md §4). Maximising p_k for the best k
gives the highest possible peak; maximising the integral gives the highest mean clearance.
The generator runs against a path of constant feed (T_rem = T − t). Ratios as in the
reference: peak (peak − max(z0, POS)) / (oracle − max(z0, POS)), mean (mean − min) /
(oracle − min). Figure to reach: ≥ 0.995 on every case.

Run: .venv/bin/python bench/bench_lift_oracle.py
"""

from __future__ import annotations

import json
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.optimize import linprog

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench.cli import parser
from liftd.cnc.lift.advanced import AdvancedLift
from liftd.cnc.lift.profile import LiftProfiles

DT = 1e-3


@dataclass(frozen=True)
class Case:
    name: str
    T: float
    z0: float
    pos: float
    limit: float
    v: float = 0.8
    a: float = 10.0
    j: float = 500.0


CASES = [
    Case("c1 short, limit unreachable", 0.10, 0.0, 0.0, 0.05),
    Case("c2", 0.20, 0.0, 0.0, 0.05),
    Case("c3 just unreachable", 0.30, 0.0, 0.0, 0.05),
    Case("c4 limit reached", 0.50, 0.0, 0.0, 0.05),
    Case("c5 long, v-limited", 1.00, 0.0, 0.0, 0.20),
    Case("c6 POS above", 0.25, 0.0, 0.02, 0.05),
    Case("c7 POS below", 0.25, 0.0, -0.02, 0.03),
    Case("c8 POS above, short", 0.15, 0.0, 0.03, 0.06),
    Case("c9 start above POS", 0.40, 0.01, 0.0, 0.025),
    Case("c10 soft Z 0.3/3/50", 0.40, 0.0, 0.0, 0.04, 0.3, 3.0, 50.0),
    Case("c11 stiff Z 1.5/20/2000", 0.20, 0.0, 0.0, 0.08, 1.5, 20.0, 2000.0),
    Case("c12 demo Z, 0.35 s hop", 0.35, 0.001, 0.001, 0.06, 1.0, 10.0, 500.0),
]


def policy(c: Case) -> tuple[float, float]:
    gen = AdvancedLift(LiftProfiles(c.v, c.a, c.j), DT)
    gen.start(0.0, c.z0, 0.0, 0.0, c.pos, c.limit, False, direct=False)
    zs = [c.z0]
    n = round(c.T / DT)
    for k in range(1, n + 1):
        gen.step(k * DT, c.T - (k - 1) * DT)
        zs.append(gen.z)
    z = np.array(zs)
    assert abs(z[-1] - c.pos) < 1e-9, "must land at T"
    return float(z.max()), float(np.trapezoid(z, dx=DT) / c.T)


class Oracle:
    def __init__(self, c: Case, h: float) -> None:
        self.c = c
        n = round(c.T / h)
        self.n = n
        # state after k steps as linear maps of the jerk vector (exact integration)
        a = np.zeros((n + 1, n))
        v = np.zeros((n + 1, n))
        p = np.zeros((n + 1, n))
        for k in range(n):
            a[k + 1] = a[k]
            a[k + 1, k] += h
            v[k + 1] = v[k] + h * a[k]
            v[k + 1, k] += h * h / 2
            p[k + 1] = p[k] + h * v[k] + h * h / 2 * a[k]
            p[k + 1, k] += h**3 / 6
        self.p = p + 0.0  # p_k = z0 + p[k] @ j
        self.a_ub = np.vstack([a[1:], -a[1:], v[1:], -v[1:], p[1:]])
        self.b_ub = np.concatenate(
            [
                np.full(n, c.a),
                np.full(n, c.a),
                np.full(n, c.v),
                np.full(n, c.v),
                np.full(n, max(c.limit, c.pos, c.z0) - c.z0),
            ]
        )
        self.a_eq = np.vstack([p[n], v[n], a[n]])
        self.b_eq = np.array([c.pos - c.z0, 0.0, 0.0])
        self.bounds = [(-c.j, c.j)] * n

    def maximise(self, weights: np.ndarray) -> float:
        res = linprog(
            -weights,
            A_ub=self.a_ub,
            b_ub=self.b_ub,
            A_eq=self.a_eq,
            b_eq=self.b_eq,
            bounds=self.bounds,
            method="highs",
        )
        if not res.success:
            raise RuntimeError(res.message)
        return float(weights @ res.x)

    def peak(self) -> float:
        """max_k max p_k: the envelope is unimodal in k, ternary search over the nodes."""
        cache: dict[int, float] = {}

        def at(k: int) -> float:
            if k not in cache:
                cache[k] = self.maximise(self.p[k])
            return cache[k]

        lo, hi = 1, self.n - 1
        while hi - lo > 3:
            m1, m2 = lo + (hi - lo) // 3, hi - (hi - lo) // 3
            if at(m1) < at(m2):
                lo = m1
            else:
                hi = m2
        return self.c.z0 + max(at(k) for k in range(lo, hi + 1))

    def mean(self) -> float:
        w = self.p[1:].sum(axis=0) - 0.5 * self.p[self.n]  # trapezoid over the nodes
        return self.c.z0 + self.maximise(w) / self.n


def main() -> None:
    parser(__doc__).parse_args()
    worst_peak = worst_mean = 1.0
    for c in CASES:
        t0 = time.perf_counter()
        peak, mean = policy(c)
        oracle = Oracle(c, DT)
        o_peak, o_mean = oracle.peak(), oracle.mean()
        top, bottom = max(c.z0, c.pos), min(c.z0, c.pos)
        peak_ratio = (peak - top) / (o_peak - top) if o_peak - top > 1e-9 else 1.0
        mean_ratio = (mean - bottom) / (o_mean - bottom)
        worst_peak, worst_mean = min(worst_peak, peak_ratio), min(worst_mean, mean_ratio)
        print(
            json.dumps(
                {
                    "bench": "lift_oracle",
                    "case": c.name,
                    "T_s": c.T,
                    "peak_mm": round(peak * 1e3, 4),
                    "oracle_peak_mm": round(o_peak * 1e3, 4),
                    "peak_ratio": round(peak_ratio, 5),
                    "mean_mm": round(mean * 1e3, 4),
                    "oracle_mean_mm": round(o_mean * 1e3, 4),
                    "mean_ratio": round(mean_ratio, 5),
                    "seconds": round(time.perf_counter() - t0, 1),
                }
            )
        )
    print(
        json.dumps(
            {
                "bench": "lift_oracle",
                "cases": len(CASES),
                "min_peak_ratio": round(worst_peak, 5),
                "min_mean_ratio": round(worst_mean, 5),
                "target": 0.995,
                "pass": worst_peak >= 0.995 and worst_mean >= 0.995,
            }
        )
    )


if __name__ == "__main__":
    main()
