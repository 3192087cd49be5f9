"""Figures of a simulated run (optional extra: pip install 'liftd[plot]', i.e. matplotlib)."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from typing import Any

import numpy as np

from liftd.cnc.lift.controller import LiftRecord

MM = 1e3
HINT = "plotting needs matplotlib: pip install 'liftd[plot]' (or: .venv/bin/pip install matplotlib)"


def available() -> bool:
    return importlib.util.find_spec("matplotlib") is not None


def plot_run(
    path: Path,
    rows: np.ndarray,
    axis_names: tuple[str, ...],
    z_index: int,
    records: list[LiftRecord],
    title: str,
) -> None:
    """rows: t, positions…, v_path, override, lift_active, lift_suppressed, line."""
    import matplotlib  # noqa: PLC0415

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # noqa: PLC0415

    n = len(axis_names)
    t = rows[:, 0]
    pos = rows[:, 1 : 1 + n] * MM
    v_path = rows[:, 1 + n] * MM
    override = rows[:, 2 + n] * 100.0
    active = rows[:, 3 + n] > 0.5
    suppressed = rows[:, 4 + n] > 0.5
    z = pos[:, z_index]

    fig = plt.figure(figsize=(13, 9), constrained_layout=True)
    grid = fig.add_gridspec(3, 2, width_ratios=[1.0, 1.3])
    ax_xy = fig.add_subplot(grid[:, 0])
    ax_z = fig.add_subplot(grid[0, 1])
    ax_v = fig.add_subplot(grid[1, 1], sharex=ax_z)
    ax_f = fig.add_subplot(grid[2, 1], sharex=ax_z)

    colours = np.where(suppressed, "tab:orange", np.where(active, "tab:red", "tab:blue"))
    ax_xy.scatter(pos[:, 0], pos[:, 1], c=colours, s=1.5, linewidths=0)
    ax_xy.set_aspect("equal", adjustable="box")
    margin = max(np.ptp(pos[:, 0]), np.ptp(pos[:, 1]), 1.0) * 0.05
    ax_xy.set_xlim(pos[:, 0].min() - margin, pos[:, 0].max() + margin)
    ax_xy.set_ylim(pos[:, 1].min() - margin, pos[:, 1].max() + margin)
    ax_xy.set_xlabel(f"{axis_names[0]} [mm]")
    ax_xy.set_ylabel(f"{axis_names[1]} [mm]")
    ax_xy.set_title("path: blue = cutting/travel, red = lift active, orange = suppressed")
    for rec in records:
        k = int(np.searchsorted(t, rec.t_start))
        if k < len(t):
            ax_xy.annotate(f"N{rec.range.start.line}", (pos[k, 0], pos[k, 1]), fontsize=7)

    ax_z.plot(t, z, color="tab:red", lw=1.2, label=f"{axis_names[z_index]} command")
    for i, rec in enumerate(records):
        spec = rec.range.start
        span = [rec.t_start, rec.t_end]
        ax_z.plot(
            span, [spec.pos_limit * MM] * 2, "k--", lw=0.8, label="POS_LIMIT" if i == 0 else None
        )
        ax_z.plot(
            span,
            [spec.target * MM] * 2,
            color="tab:green",
            lw=0.8,
            label="POS (target)" if i == 0 else None,
        )
    ax_z.set_ylabel(f"{axis_names[z_index]} [mm]")
    ax_z.legend(loc="upper right", fontsize=8)
    ax_z.grid(alpha=0.3)

    ax_v.plot(t, v_path, color="tab:blue", lw=1.0, label="path velocity")
    ax_v.set_ylabel("v_path [mm/s]")
    ax_o = ax_v.twinx()
    ax_o.plot(t, override, color="tab:gray", lw=0.8, ls=":", label="override")
    ax_o.set_ylabel("override [%]")
    ax_o.set_ylim(0, max(210.0, float(override.max()) + 10.0))
    ax_v.grid(alpha=0.3)

    ax_f.step(t, active.astype(float) + 1.1, where="post", color="tab:red", label="lift_active")
    ax_f.step(
        t, suppressed.astype(float), where="post", color="tab:orange", label="lift_suppressed"
    )
    ax_f.set_yticks([0, 1, 1.1, 2.1], ["0", "1", "0", "1"])
    ax_f.set_xlabel("t [s]")
    ax_f.legend(loc="upper right", fontsize=8)
    ax_f.grid(alpha=0.3)
    fig.suptitle(title)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def describe(summary: dict[str, Any]) -> str:
    lifts = summary["lifts"]
    clear = [f"{x['mean_clearance']:.1f}" for x in lifts if not x["suppressed"]]
    return (
        f"method {summary['method']}, {len(lifts)} lifts, mean clearance [mm]: "
        f"{', '.join(clear) or '-'}, duration {summary['duration_s']:.2f} s"
    )
