"""Figures of a simulated run, a comparison and a study (optional extra: pip install
'liftd[plot]', i.e. matplotlib)."""

from __future__ import annotations

import importlib.util
import io
import itertools
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from liftd.sim.compare import MAX_PLOTTED, Comparison, as_arrays, occurrence_keys
from liftd.sim.report import OVERLOAD_CLASSES, RATIO_EDGES, Aggregate
from liftd.sim.summary import LiftSummary
from liftd.sim.trace import MM

HINT = "plotting needs matplotlib: pip install 'liftd[plot]' (or: .venv/bin/pip install matplotlib)"


def available() -> bool:
    return importlib.util.find_spec("matplotlib") is not None


def format_problem(path: str) -> str | None:
    """Why the figure cannot be written in the format its name says (matplotlib picks the
    format from the suffix; none: PNG), or None."""
    from matplotlib.backend_bases import FigureCanvasBase  # noqa: PLC0415

    suffix = Path(path).suffix.lower().lstrip(".")
    formats = FigureCanvasBase.get_supported_filetypes()
    if not suffix or suffix in formats:
        return None
    return f"format '{suffix}' not supported (use {', '.join(sorted(formats))})"


def _spans(t: np.ndarray, flag: np.ndarray) -> list[tuple[float, float]]:
    """Time intervals where flag is True."""
    edges = np.flatnonzero(np.diff(flag.astype(int)))
    starts = [t[0]] if flag[0] else []
    ends: list[float] = []
    for e in edges:
        (starts if not flag[e] else ends).append(t[e + 1] if not flag[e] else t[e])
    if flag[-1]:
        ends.append(t[-1])
    return list(zip(starts, ends, strict=False))


def plot_run(
    path: Path,
    rows: np.ndarray,
    axis_names: tuple[str, ...],
    z_index: int,
    lifts: Sequence[LiftSummary],
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
    zn = axis_names[z_index]

    fig = plt.figure(figsize=(14, 11), constrained_layout=True)
    grid = fig.add_gridspec(4, 2, height_ratios=[1.25, 1.0, 0.28, 0.85])
    ax_xy = fig.add_subplot(grid[0, :])
    ax_z = fig.add_subplot(grid[1, :])
    ax_f = fig.add_subplot(grid[2, :], sharex=ax_z)
    ax_v = fig.add_subplot(grid[3, 0], sharex=ax_z)
    ax_zoom = fig.add_subplot(grid[3, 1])

    # 1. the path in the plane, coloured by lift state
    colours = np.where(suppressed, "tab:orange", np.where(active, "tab:red", "tab:blue"))
    ax_xy.scatter(pos[:, 0], pos[:, 1], c=colours, s=2, linewidths=0)
    ax_xy.set_aspect("equal", adjustable="datalim")
    ax_xy.set_xlabel(f"{axis_names[0]} [mm]")
    ax_xy.set_ylabel(f"{axis_names[1]} [mm]")
    ax_xy.set_title(
        "path: blue = cutting and travel, red = lift active, orange = lift suppressed", fontsize=10
    )
    for lift in lifts:
        k = min(int(np.searchsorted(t, lift.t_start)), len(t) - 1)
        ax_xy.annotate(
            f"N{lift.start_line}",
            (pos[k, 0], pos[k, 1]),
            fontsize=8,
            xytext=(4, 4),
            textcoords="offset points",
        )
    ax_xy.grid(alpha=0.25)

    # 2. Z over time with each lift's POS_LIMIT and target; lift flags shaded
    for t0, t1 in _spans(t, active):
        ax_z.axvspan(t0, t1, color="tab:red", alpha=0.08, lw=0)
    ax_z.plot(t, z, color="tab:red", lw=1.3, label=f"{zn} command")
    for i, lift in enumerate(lifts):
        span = [lift.t_start, lift.t_end]
        ax_z.plot(
            span, [lift.pos_limit_mm] * 2, "k--", lw=0.9, label="POS_LIMIT" if i == 0 else None
        )
        ax_z.plot(
            span,
            [lift.z_target_mm] * 2,
            color="tab:green",
            lw=1.2,
            label="POS (target)" if i == 0 else None,
        )
    ax_z.set_ylabel(f"{zn} [mm]")
    ax_z.legend(loc="upper left", fontsize=8, ncol=3)
    ax_z.grid(alpha=0.3)

    # 3. the two CNC objects as the PLC sees them
    ax_f.step(t, active.astype(float) + 1.2, where="post", color="tab:red")
    ax_f.step(t, suppressed.astype(float), where="post", color="tab:orange")
    ax_f.set_yticks([0.5, 1.7], ["lift_suppressed", "lift_active"], fontsize=8)
    ax_f.set_ylim(-0.2, 2.4)
    ax_f.tick_params(labelbottom=False)
    ax_f.grid(alpha=0.3, axis="x")

    # 4. path velocity and override
    ax_v.plot(t, v_path, color="tab:blue", lw=1.0)
    ax_v.set_ylabel("path velocity [mm/s]", color="tab:blue")
    ax_v.set_xlabel("t [s]")
    ax_o = ax_v.twinx()
    ax_o.plot(t, override, color="tab:gray", lw=1.0, ls=":")
    ax_o.set_ylabel("override [%]", color="tab:gray")
    ax_o.set_ylim(0, max(210.0, float(override.max()) + 10.0))
    ax_v.grid(alpha=0.3)

    # 5. zoom on the longest lift: Z against the time the path needs to LIFT_END
    best = max(
        (x for x in lifts if not x.suppressed),
        key=lambda x: x.t_end - x.t_start,
        default=None,
    )
    if best is not None:
        m = (t >= best.t_start - 0.02) & (t <= best.t_end + 0.02)
        ax_zoom.plot(t[m] - best.t_end, z[m], color="tab:red", lw=1.5, label=zn)
        ax_zoom.axhline(best.pos_limit_mm, color="k", ls="--", lw=0.9, label="POS_LIMIT")
        ax_zoom.axhline(best.z_target_mm, color="tab:green", lw=1.2, label="POS")
        ax_zoom.axvline(0.0, color="tab:gray", lw=0.8, ls=":")
        ax_zoom.annotate(
            "path reaches LIFT_END",
            (0.0, best.z_target_mm),
            fontsize=8,
            xytext=(-120, 20),
            textcoords="offset points",
            arrowprops={"arrowstyle": "->", "lw": 0.7},
        )
        ax_zoom.set_title(
            f"lift N{best.start_line}: peak {best.peak_mm:.1f} mm, mean clearance "
            f"{best.mean_clearance_mm:.1f} mm",
            fontsize=9,
        )
        ax_zoom.set_xlabel("t − t(LIFT_END) [s]")
        ax_zoom.set_ylabel(f"{zn} [mm]")
        ax_zoom.legend(fontsize=8, loc="lower center")
        ax_zoom.grid(alpha=0.3)
    fig.suptitle(title, fontsize=12)
    fig.savefig(path, dpi=100)
    plt.close(fig)


COLOURS = {"advanced": "tab:red", "lifting": "tab:blue"}


def plot_compare(
    path: Path, comparison: Comparison, a_max: float, warn_ratio: float, title: str
) -> None:
    """Per lift (the first MAX_PLOTTED): Z over time and over path distance for both methods,
    POS_LIMIT and target, and the cycles where Z's sampled acceleration exceeds a_max (dots)
    or the P-AXIS-00441 warning level (crosses)."""
    import matplotlib  # noqa: PLC0415

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # noqa: PLC0415

    pairs = comparison.summary.lifts[:MAX_PLOTTED]
    runs = {
        m: dict(zip(occurrence_keys(x.start_line for x in s.lifts), s.lifts, strict=True))
        for m, s in comparison.samples.items()
    }
    keys = occurrence_keys(p.start_line for p in pairs)
    rows = max(1, len(keys))
    fig, axes = plt.subplots(rows, 2, figsize=(13, 2.5 * rows + 0.8), squeeze=False)
    for i, (key, pair) in enumerate(zip(keys, pairs, strict=False)):
        ax_t, ax_s = axes[i]
        ref = pair.ref
        for method in ("advanced", "lifting"):
            lift = runs[method].get(key)
            if lift is None:
                continue
            data = as_arrays(lift)
            t = data[:, 0] - lift.t_start
            s = (data[:, 1] - lift.s_start) * MM
            z = data[:, 2] * MM
            ratio = np.abs(data[:, 3]) / a_max
            entry = pair.of(method)
            label = (
                f"{method}: clearance {entry.mean_clearance_mm:.1f} mm, "
                f"Z a/a_max {entry.z_a_max_ratio:.2f}"
                if entry
                else method
            )
            ax_t.plot(t, z, color=COLOURS[method], lw=1.4, label=label)
            ax_s.plot(s, z, color=COLOURS[method], lw=1.4)
            over = ratio > 1.0 + 1e-6
            warn = ratio > warn_ratio
            for ax, x in ((ax_t, t), (ax_s, s)):
                ax.scatter(x[over & ~warn], z[over & ~warn], s=7, color="black", zorder=3)
                ax.scatter(x[warn], z[warn], s=28, marker="x", color="black", zorder=3)
        for ax in (ax_t, ax_s):
            ax.axhline(ref.pos_limit_mm, color="k", ls="--", lw=0.8)
            ax.axhline(ref.z_target_mm, color="tab:green", lw=1.0)
            ax.grid(alpha=0.3)
            ax.set_ylabel("Z [mm]")
        ratio_text = f" (×{pair.clearance_ratio:.2f})" if pair.clearance_ratio else ""
        ax_t.set_title(
            f"lines {pair.start_line}–{pair.end_line}: mean clearance advanced / lifting"
            f"{ratio_text}{' (suppressed)' if ref.suppressed else ''}",
            fontsize=9,
        )
        ax_t.legend(fontsize=7, loc="best")
        ax_s.set_title("Z over the path distance (coupled: fixed shape)", fontsize=9)
    axes[-1][0].set_xlabel("t − t(LIFT_START) [s]")
    axes[-1][1].set_xlabel("path distance from LIFT_START [mm]")
    fig.suptitle(
        f"{title}\n--- POS_LIMIT, green: POS; Z acceleration above a_max: dots, above the "
        f"P-AXIS-00441 warning level ({warn_ratio:.2f} a_max): crosses",
        fontsize=10,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def study_figures(agg: Aggregate) -> list[tuple[str, bytes]]:
    """The figures of `liftd study` as (caption, PNG): per lift, Advanced against path-based
    mean clearance (a sample) and the histogram of their ratio; per program, the time
    path-based Lifting costs, and its Z overload cycles."""
    import matplotlib  # noqa: PLC0415

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # noqa: PLC0415

    out: list[tuple[str, bytes]] = []

    def save(fig: Any, caption: str) -> None:
        buf = io.BytesIO()
        fig.tight_layout()
        fig.savefig(buf, format="png", dpi=90)
        plt.close(fig)
        out.append((caption, buf.getvalue()))

    pts = np.asarray(agg.lift_points.items, dtype=float).reshape(-1, 2)
    fig, ax = plt.subplots(figsize=(5.5, 5))
    ax.scatter(pts[:, 0], pts[:, 1], s=10, alpha=0.6, color=COLOURS["advanced"], linewidths=0)
    top = float(pts.max()) * 1.05 if len(pts) else 1.0
    ax.plot([0.0, top], [0.0, top], color="k", lw=0.8, ls="--", label="equal clearance")
    ax.set_xlim(0.0, top)
    ax.set_ylim(0.0, top)
    ax.set_xlabel("mean clearance, path-based Lifting [mm]")
    ax.set_ylabel("mean clearance, Advanced Lifting [mm]")
    ax.legend(loc="upper left", fontsize=8)
    ax.grid(alpha=0.3)
    shown = f"{len(pts)} of {agg.lift_points.seen}" if agg.lift_points.seen > len(pts) else "all"
    save(
        fig,
        f"Mean clearance per lift ({shown} compared lifts): above the line Advanced "
        "Lifting keeps Z higher over the sheet.",
    )

    fig, ax = plt.subplots(figsize=(6.5, 4))
    edges = RATIO_EDGES
    labels = [f"< {edges[0]:g}"] + [f"{a:g}–{b:g}" for a, b in itertools.pairwise(edges)]
    labels.append(f"≥ {edges[-1]:g}")
    ax.bar(range(len(labels)), agg.ratio_counts, color=COLOURS["advanced"])
    ax.set_xticks(range(len(labels)), labels, rotation=45, ha="right", fontsize=8)
    ax.set_xlabel("clearance ratio Advanced / path-based")
    ax.set_ylabel("lifts")
    ax.grid(alpha=0.3, axis="y")
    save(
        fig,
        "Clearance ratio per compared lift (all of them): 1 means no gain, 2 twice "
        "the clearance with Advanced Lifting.",
    )

    prog = np.asarray(agg.program_points.items, dtype=float).reshape(-1, 2)
    fig, ax = plt.subplots(figsize=(6.5, 4))
    ax.scatter(prog[:, 0], prog[:, 1], s=10, alpha=0.6, color=COLOURS["lifting"], linewidths=0)
    ax.axhline(0.0, color="k", lw=0.8)
    ax.set_xlabel("program time, Advanced Lifting [s]")
    ax.set_ylabel("path-based − Advanced [% of the time]")
    ax.grid(alpha=0.3)
    save(
        fig,
        "Program time with path-based Lifting, per program that ran to the end: what its "
        "slower ranges cost (above 0) against Advanced Lifting.",
    )

    fig, ax = plt.subplots(figsize=(5.5, 4))
    ax.bar([name for _, name in OVERLOAD_CLASSES], agg.overload_counts, color=COLOURS["lifting"])
    ax.set_xlabel("Z overload cycles of path-based Lifting (above P-AXIS-00441)")
    ax.set_ylabel("programs")
    ax.grid(alpha=0.3, axis="y")
    save(
        fig,
        "Programs by the cycles in which path-based Lifting's Z acceleration exceeds the "
        "P-AXIS-00441 warning level (Advanced Lifting stays within a_max).",
    )
    return out
