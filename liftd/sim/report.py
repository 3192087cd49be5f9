"""The report of `liftd study`: report.csv, report.json and one self-contained report.html.

Rows are streamed as results arrive (CSV and JSON directly, the HTML table to a part file
that is copied into report.html at the end), so memory holds only the aggregates: sums and
extremes, a histogram of the per-lift clearance ratios on fixed edges, the first MAX_LISTED
programs that did not run to the end, and two reservoir samples of at most RESERVOIR points
for the scatter figures (seeded: the same library gives the same figures).
"""

from __future__ import annotations

import base64
import bisect
import csv
import html
import json
import random
import shutil
from collections import Counter, defaultdict
from pathlib import Path
from types import TracebackType

from liftd.sim.study import COLUMNS, ProgramResult, ProgramRow, Status
from liftd.sim.summary import JsonObject

# clearance ratio advanced / path-based per lift; below the first edge and above the last
# are bins of their own
RATIO_EDGES = (1.0, 1.1, 1.25, 1.5, 2.0, 3.0, 5.0, 10.0, 30.0, 100.0, 1000.0)
OVERLOAD_CLASSES = ((0, "0"), (1, "1–9"), (10, "10–99"), (100, "100–999"), (1000, "≥ 1000"))
RESERVOIR = 4000
MAX_LISTED = 100
LIFT_MEANS = (
    "clearance_advanced_mm",
    "clearance_lifting_mm",
    "peak_height_advanced_mm",
    "peak_height_lifting_mm",
)
LEFT = frozenset({"program", "status", "why"})  # text columns of the HTML tables
NAMES = ("report.csv", "report.json", "report.html")


class Reservoir:
    """A uniform sample of at most `size` items of a stream (Vitter's algorithm R)."""

    def __init__(self, size: int, seed: int = 0) -> None:
        self.size = size
        self.items: list[tuple[float, float]] = []
        self.seen = 0
        self._rng = random.Random(seed)

    def add(self, item: tuple[float, float]) -> None:
        self.seen += 1
        if len(self.items) < self.size:
            self.items.append(item)
            return
        k = self._rng.randrange(self.seen)
        if k < self.size:
            self.items[k] = item


class Aggregate:
    """The summary over all programs, in bounded memory."""

    def __init__(self) -> None:
        self.programs = 0
        self.status: Counter[str] = Counter()
        self.errors_by_id: Counter[int] = Counter()
        self.not_run: list[ProgramRow] = []  # the first MAX_LISTED that did not end normally
        self.counts: Counter[str] = Counter()  # lifts, cycles, programs
        self.sums: defaultdict[str, float] = defaultdict(float)  # lift-weighted, durations
        self.ratio_min: tuple[float, str] | None = None
        self.z_a_max = (0.0, "")
        self.ratio_counts = [0] * (len(RATIO_EDGES) + 1)
        self.lift_points = Reservoir(RESERVOIR)  # (clearance path-based, advanced) [mm]
        self.program_points = Reservoir(RESERVOIR, seed=1)  # (duration adv [s], diff [%])
        self.overload_counts = [0] * len(OVERLOAD_CLASSES)
        self.max_rss_kib = 0

    def add(self, result: ProgramResult) -> None:
        row = result.row
        self.programs += 1
        self.status[row.status.value] += 1
        self.max_rss_kib = max(self.max_rss_kib, result.max_rss_kib)
        for e in row.errors:
            self.errors_by_id[e.error_id] += 1
        if row.status is not Status.OK and len(self.not_run) < MAX_LISTED:
            self.not_run.append(row)
        c, s = self.counts, self.sums
        c.update(lifts=row.lifts, compared=row.compared, suppressed=row.suppressed, open=row.open)
        for key in LIFT_MEANS:  # the row's means over its compared lifts, back to sums
            value = row.value(key)
            if isinstance(value, float):
                s[key] += value * row.compared
        for ratio in result.ratios:
            s["clearance_ratio"] += ratio
            self.ratio_counts[bisect.bisect_right(RATIO_EDGES, ratio)] += 1
        if row.clearance_ratio_min is not None and (
            self.ratio_min is None or row.clearance_ratio_min < self.ratio_min[0]
        ):
            self.ratio_min = (row.clearance_ratio_min, row.program)
        if row.lifting_z_a_max_ratio > self.z_a_max[0]:
            self.z_a_max = (row.lifting_z_a_max_ratio, row.program)
        for point in result.points:
            self.lift_points.add((point[1], point[0]))
        if row.status is Status.OK:
            self._add_finished(row)

    def _add_finished(self, row: ProgramRow) -> None:
        adv, lift = row.duration_advanced_s or 0.0, row.duration_lifting_s or 0.0
        self.sums["duration_advanced_s"] += adv
        self.sums["duration_lifting_s"] += lift
        self.counts.update(
            finished=1,
            lifting_z_overload_cycles=row.lifting_z_overload_cycles,
            lifting_z_error_cycles=row.lifting_z_error_cycles,
            programs_with_lifting_overload=row.lifting_z_overload_cycles > 0,
        )
        k = bisect.bisect_right([c for c, _ in OVERLOAD_CLASSES], row.lifting_z_overload_cycles)
        self.overload_counts[k - 1] += 1
        if adv > 0.0:
            self.program_points.add((adv, 100.0 * (lift - adv) / adv))

    def summary(self) -> JsonObject:
        c, s = self.counts, self.sums
        n = c["compared"]

        def per_lift(key: str) -> float | None:
            return round(s[key] / n, 6) if n else None

        adv, lift = s["duration_advanced_s"], s["duration_lifting_s"]
        return {
            "programs": self.programs,
            "status": {st.value: self.status[st.value] for st in Status},
            "lifts": c["lifts"],
            "compared": n,
            "suppressed": c["suppressed"],
            "open": c["open"],
            "clearance_advanced_mm": per_lift("clearance_advanced_mm"),
            "clearance_lifting_mm": per_lift("clearance_lifting_mm"),
            "clearance_ratio_of_means": (
                round(s["clearance_advanced_mm"] / s["clearance_lifting_mm"], 6)
                if s["clearance_lifting_mm"] > 0.0
                else None
            ),
            "clearance_ratio_mean": per_lift("clearance_ratio"),
            "clearance_ratio_min": self.ratio_min[0] if self.ratio_min else None,
            "clearance_ratio_min_program": self.ratio_min[1] if self.ratio_min else None,
            "peak_height_advanced_mm": per_lift("peak_height_advanced_mm"),
            "peak_height_lifting_mm": per_lift("peak_height_lifting_mm"),
            "finished": c["finished"],
            "duration_advanced_s": round(adv, 6),
            "duration_lifting_s": round(lift, 6),
            "time_difference_s": round(lift - adv, 6),
            "time_difference_pct": round(100.0 * (lift - adv) / adv, 3) if adv > 0 else None,
            "lifting_z_overload_cycles": c["lifting_z_overload_cycles"],
            "lifting_z_error_cycles": c["lifting_z_error_cycles"],
            "programs_with_lifting_overload": c["programs_with_lifting_overload"],
            "lifting_z_a_max_ratio": self.z_a_max[0],
            "lifting_z_a_max_ratio_program": self.z_a_max[1],
            "errors_by_id": {str(k): v for k, v in sorted(self.errors_by_id.items())},
            "clearance_ratio_histogram": {
                "edges": list(RATIO_EDGES),
                "counts": list(self.ratio_counts),
            },
        }


class ReportWriter:
    """Writes the three files into `out` as results arrive; `finish` adds the summary, the
    figures and closes them. A context manager: on an exception the files are closed as far
    as they got (report.html is then missing)."""

    def __init__(self, out: Path, meta: JsonObject) -> None:
        out.mkdir(parents=True, exist_ok=True)
        self.out = out
        self.meta = meta
        self.aggregate = Aggregate()
        self._csv_file = open(out / "report.csv", "w", encoding="utf-8", newline="")  # noqa: SIM115
        self._csv = csv.writer(self._csv_file)
        self._csv.writerow(COLUMNS)
        self._json = open(out / "report.json", "w", encoding="utf-8")  # noqa: SIM115
        self._json.write('{"study": ' + json.dumps(meta) + ',\n "programs": [')
        self._rows_path = out / ".report.rows.html"
        self._rows = open(self._rows_path, "w", encoding="utf-8")  # noqa: SIM115
        self._first = True

    def __enter__(self) -> ReportWriter:
        return self

    def __exit__(
        self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()

    def add(self, result: ProgramResult) -> None:
        row = result.row
        self._csv.writerow(row.csv_row())
        self._json.write(("\n  " if self._first else ",\n  ") + json.dumps(row.to_json()))
        self._first = False
        self._rows.write(_html_row(row))
        self.aggregate.add(result)

    def finish(self, run: JsonObject, figures: list[tuple[str, bytes]] | None) -> JsonObject:
        """Write the summary (and `run`: wall time, jobs, memory) to report.json and the whole
        report.html; `figures`: (caption, PNG) pairs, None without matplotlib."""
        summary = self.aggregate.summary()
        self._json.write("\n ],\n")
        self._json.write(' "summary": ' + json.dumps(summary) + ",\n")
        self._json.write(' "run": ' + json.dumps(run) + "}\n")
        self._rows.close()
        with open(self.out / "report.html", "w", encoding="utf-8") as page:
            page.write(_html_head(self.meta, summary, run))
            page.write(_html_figures(figures))
            page.write(_html_not_run(self.aggregate))
            page.write(_TABLE_HEAD)
            with open(self._rows_path, encoding="utf-8") as rows:
                shutil.copyfileobj(rows, page)
            page.write("</tbody></table>\n</body></html>\n")
        self._rows_path.unlink()
        return summary

    def close(self) -> None:
        for f in (self._csv_file, self._json, self._rows):
            f.close()
        self._rows_path.unlink(missing_ok=True)


# -- report.html ------------------------------------------------------------------------------
_STYLE = """body{font-family:system-ui,sans-serif;margin:2em;color:#222;max-width:110em}
table{border-collapse:collapse;margin:1em 0;font-size:90%}
th,td{border:1px solid #ccc;padding:.25em .5em;text-align:right}
th{background:#f0f0f0}td.l,th.l{text-align:left}tr.bad td{background:#fff0f0}
figure{display:inline-block;margin:0 1em 1em 0}figcaption{max-width:40em;font-size:90%}
.note{background:#fffbe6;border:1px solid #e6d280;padding:.5em 1em}"""

_SUMMARY_ROWS = (  # (summary key, label)
    ("programs", "programs"),
    ("finished", "ran to the end (times and overload are over these)"),
    ("lifts", "lift ranges"),
    ("compared", "compared lifts (both runs completed them, path-based Lifting lifted)"),
    ("suppressed", "suppressed (path shorter than lift_min_dist)"),
    ("open", "open when an error stopped the program"),
    ("clearance_advanced_mm", "mean clearance, Advanced Lifting [mm]"),
    ("clearance_lifting_mm", "mean clearance, path-based Lifting [mm]"),
    ("clearance_ratio_of_means", "ratio of the two mean clearances"),
    ("clearance_ratio_mean", "clearance ratio Advanced / path-based per lift: mean"),
    ("clearance_ratio_min", "… smallest"),
    ("clearance_ratio_min_program", "… in program"),
    ("peak_height_advanced_mm", "mean peak height above the start, Advanced [mm]"),
    ("peak_height_lifting_mm", "mean peak height above the start, path-based [mm]"),
    ("duration_advanced_s", "program time, Advanced Lifting [s]"),
    ("duration_lifting_s", "program time, path-based Lifting [s]"),
    ("time_difference_s", "path-based − Advanced [s]"),
    ("time_difference_pct", "path-based − Advanced [% of Advanced]"),
    ("lifting_z_overload_cycles", "Z overload cycles of path-based Lifting (P-AXIS-00441)"),
    ("lifting_z_error_cycles", "… above the error level (P-AXIS-00442)"),
    ("programs_with_lifting_overload", "programs with Z overload, path-based Lifting"),
    ("lifting_z_a_max_ratio", "largest Z acceleration / a_max, path-based Lifting"),
)
_TABLE_COLUMNS = (  # (row column, heading)
    ("program", "program"),
    ("status", "status"),
    ("lifts", "lifts"),
    ("compared", "compared"),
    ("clearance_advanced_mm", "clearance adv [mm]"),
    ("clearance_lifting_mm", "clearance path [mm]"),
    ("clearance_ratio_mean", "ratio mean"),
    ("clearance_ratio_min", "ratio min"),
    ("peak_height_advanced_mm", "peak adv [mm]"),
    ("peak_height_lifting_mm", "peak path [mm]"),
    ("duration_advanced_s", "time adv [s]"),
    ("duration_lifting_s", "time path [s]"),
    ("time_difference_s", "path − adv [s]"),
    ("lifting_z_overload_cycles", "Z overload cycles path"),
    ("why", "errors"),
)


def _cell(tag: str, column: str, text: str) -> str:
    left = ' class="l"' if column in LEFT else ""
    return f"<{tag}{left}>{html.escape(text)}</{tag}>"


_TABLE_HEAD = (
    "<h2>Programs</h2>\n<table><thead><tr>"
    + "".join(_cell("th", c, h) for c, h in _TABLE_COLUMNS)
    + "</tr></thead><tbody>\n"
)


def _fmt(value: object) -> str:
    if value is None:
        return "–"
    if isinstance(value, float):
        return f"{value:.3f}" if abs(value) < 1e6 else f"{value:.4g}"
    return str(value)


def _html_row(row: ProgramRow) -> str:
    cells = "".join(_cell("td", c, _fmt(row.value(c))) for c, _ in _TABLE_COLUMNS)
    bad = ' class="bad"' if row.status is not Status.OK else ""
    return f"<tr{bad}>{cells}</tr>\n"


def _html_head(meta: JsonObject, summary: JsonObject, run: JsonObject) -> str:
    rows = "".join(
        f'<tr><td class="l">{html.escape(label)}</td><td>{html.escape(_fmt(summary[key]))}</td>'
        "</tr>\n"
        for key, label in _SUMMARY_ROWS
    )
    status = ", ".join(f"{n} {k}" for k, n in summary["status"].items() if n)
    errors = ", ".join(f"{k} × {n}" for k, n in summary["errors_by_id"].items()) or "none"
    return (
        f"<!DOCTYPE html>\n<html lang='en'><head><meta charset='utf-8'>"
        f"<title>liftd study: {summary['programs']} programs</title><style>{_STYLE}</style>"
        f"</head><body>\n<h1>Advanced Lifting vs path-based Lifting: {summary['programs']} "
        f"programs</h1>\n<p>liftd {html.escape(str(meta.get('liftd', '')))}, configuration "
        f"<code>{html.escape(str(meta.get('config', '')))}</code>, method of the lists: "
        f"{html.escape(str(meta.get('method', '')))}; each program run as "
        "<code>liftd simulate PROGRAM --compare</code> (100 % override, no feed hold). "
        f"{run.get('jobs', '')} jobs, {_fmt(run.get('wall_s'))} s.</p>\n"
        f"<p>Programs: {html.escape(status)}. Errors by ISG id: {html.escape(errors)}.</p>\n"
        f"<h2>Summary over all programs</h2>\n<table><tbody>\n{rows}</tbody></table>\n"
    )


def _html_figures(figures: list[tuple[str, bytes]] | None) -> str:
    if figures is None:
        return (
            "<p class='note'>Figures need matplotlib: <code>pip install liftd[plot]</code>, "
            "then run <code>liftd study</code> again.</p>\n"
        )
    parts = ["<h2>Figures</h2>\n"]
    for caption, png in figures:
        data = base64.b64encode(png).decode("ascii")
        parts.append(
            f"<figure><img alt='{html.escape(caption)}' src='data:image/png;base64,{data}'>"
            f"<figcaption>{html.escape(caption)}</figcaption></figure>\n"
        )
    return "".join(parts)


def _html_not_run(agg: Aggregate) -> str:
    failed = agg.programs - agg.status[Status.OK.value]
    if not failed:
        return ""
    shown = f" (the first {len(agg.not_run)})" if len(agg.not_run) < failed else ""
    rows = "".join(
        f'<tr class="bad"><td class="l">{html.escape(r.program)}</td><td class="l">'
        f'{r.status.value}</td><td class="l">{html.escape(r.why)}</td></tr>\n'
        for r in agg.not_run
    )
    return (
        f"<h2>{failed} programs did not run to the end{shown}</h2>\n<table><thead><tr>"
        '<th class="l">program</th><th class="l">status</th><th class="l">why</th></tr>'
        f"</thead><tbody>\n{rows}</tbody></table>\n"
    )


def describe(summary: JsonObject, run: JsonObject, out: Path) -> str:
    """A few lines for the terminal."""
    status = ", ".join(f"{n} {k}" for k, n in summary["status"].items() if n)
    lines = [
        f"study: {summary['programs']} programs ({status}) in {run['wall_s']:.1f} s with "
        f"{run['jobs']} jobs"
        + (
            f" on the Dask cluster at {run['scheduler']} ({run['workers']} workers at the start)"
            if "scheduler" in run
            else ""
        ),
    ]
    if summary["compared"]:
        lines.append(
            f"lifts {summary['lifts']} ({summary['compared']} compared): mean clearance Advanced "
            f"{summary['clearance_advanced_mm']:.2f} mm, path-based "
            f"{summary['clearance_lifting_mm']:.2f} mm (× {summary['clearance_ratio_of_means']:.2f}"
            f"; per lift × {summary['clearance_ratio_min']:.2f} at least, in "
            f"{summary['clearance_ratio_min_program']})"
        )
    if summary["finished"]:
        pct = summary["time_difference_pct"]
        lines.append(
            f"program time Advanced {summary['duration_advanced_s']:.3f} s, path-based "
            f"{summary['duration_lifting_s']:.3f} s"
            + (f" ({pct:+.2f} %)" if pct is not None else "")
            + f"; path-based Z overload cycles {summary['lifting_z_overload_cycles']} in "
            f"{summary['programs_with_lifting_overload']} programs"
        )
    lines.append("report: " + ", ".join(str(out / name) for name in NAMES))
    return "\n".join(lines)
