"""A sweep's results people can use: one CSV row per case, a Markdown table, and two plots.

The roll reduction of a case is r = 1 − avg_roll / avg_roll_ref, against its reference case (the same
world with the spec's ``reference`` overrides, by default R = 0: the paper's Direct). In this model roll
follows the slope almost statically, so average roll is proportional to the average speed across the
crests (README, "Tuning"); the distance to make good across them is fixed, so cutting average roll by r
stretches the time at least to T ≥ T_ref / (1 − r). The trade-off plot draws that bound.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from mavbridge.sweep.spec import SweepSpec, case_id

METRIC_COLUMNS = ("avg_roll_deg", "max_roll_deg", "time_to_waypoint_s", "final_distance_m",
                  "solve_ms_median", "solve_ms_p99", "solve_ms_max", "failures")


def case_rows(spec: SweepSpec, results: dict[str, dict]) -> list[dict[str, Any]]:
    """One row per case with a result: axis values, metrics, reduction against its reference."""
    rows = []
    for case in spec.cases:
        record = results.get(case.case_id)
        if record is None:
            continue
        m = record["metrics"]
        row: dict[str, Any] = {"case_id": case.case_id, **case.values}
        row.update({k: m.get(k) for k in METRIC_COLUMNS})
        ref = results.get(case_id(case.reference)) if case.reference is not None else None
        ref_roll = ref["metrics"]["avg_roll_deg"] if ref else None
        row["reference_avg_roll_deg"] = ref_roll
        row["reference_time_s"] = ref["metrics"].get("time_to_waypoint_s") if ref else None
        row["roll_reduction"] = (1 - m["avg_roll_deg"] / ref_roll) if ref_roll else None
        rows.append(row)
    return rows


def _cell(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return f"{value:.6g}" if math.isfinite(value) else "nan"
    return str(value)


def write_csv(path: Path, rows: Sequence[dict[str, Any]]) -> None:
    """summary.csv: every row's keys as columns, in first-seen order."""
    columns: list[str] = []
    for row in rows:
        columns.extend(k for k in row if k not in columns)
    with path.open("w", newline="", encoding="utf-8") as handle:
        writer = csv.writer(handle)
        writer.writerow(columns)
        for row in rows:
            writer.writerow([_cell(row.get(c)) for c in columns])


def markdown_table(spec: SweepSpec, rows: Sequence[dict[str, Any]]) -> str:
    """The cases as a Markdown table, best reduction first."""
    axes = list(spec.axes)
    head = [*axes, "avg roll °", "max roll °", "arrival s", "reduction", "solve ms median / p99", "failures"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    ordered = sorted(rows, key=lambda r: -(r["roll_reduction"] if r["roll_reduction"] is not None else -9))
    for r in ordered:
        arrival = f"{r['time_to_waypoint_s']:.1f}" if r["time_to_waypoint_s"] is not None else "not reached"
        red = f"{100 * r['roll_reduction']:+.0f} %" if r["roll_reduction"] is not None else ""
        solve = f"{_cell(r['solve_ms_median'])} / {_cell(r['solve_ms_p99'])}"
        cells = [_cell(r[a]) for a in axes] + [f"{r['avg_roll_deg']:.2f}", f"{r['max_roll_deg']:.2f}", arrival,
                                               red, solve, str(r["failures"])]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def plot_tradeoff(path: Path, rows: Sequence[dict[str, Any]]) -> None:
    """Reduction against arrival time, with the guide T = T_ref / (1 − r) for the median reference time."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    pts = [(r["roll_reduction"], r["time_to_waypoint_s"]) for r in rows
           if r["roll_reduction"] is not None and r["time_to_waypoint_s"] is not None]
    refs = [r["reference_time_s"] for r in rows if r["reference_time_s"] is not None]
    fig, ax = plt.subplots(figsize=(6, 4))
    if pts:
        red, t = np.array(pts).T
        ax.scatter(100 * red, t, s=14, label="cases that arrived")
    if refs:
        r = np.linspace(0, 0.8, 100)
        ax.plot(100 * r, float(np.median(refs)) / (1 - r), "k--", lw=1, label="T_ref / (1 − r)")
    ax.set_xlabel("average-roll reduction vs reference, %")
    ax.set_ylabel("time to waypoint, s")
    ax.legend(loc="upper left")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_heatmap(path: Path, rows: Sequence[dict[str, Any]], x_axis: str, y_axis: str) -> None:
    """Mean reduction over two axes (other axes averaged)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    xs = sorted({r[x_axis] for r in rows})
    ys = sorted({r[y_axis] for r in rows})
    grid = np.full((len(ys), len(xs)), np.nan)
    for j, y in enumerate(ys):
        for i, x in enumerate(xs):
            vals = [r["roll_reduction"] for r in rows
                    if r[x_axis] == x and r[y_axis] == y and r["roll_reduction"] is not None]
            if vals:
                grid[j, i] = 100 * float(np.mean(vals))
    fig, ax = plt.subplots(figsize=(6, 4))
    image = ax.imshow(grid, origin="lower", aspect="auto", cmap="viridis")
    ax.set_xticks(range(len(xs)), [_cell(x) for x in xs])
    ax.set_yticks(range(len(ys)), [_cell(y) for y in ys])
    ax.set_xlabel(x_axis)
    ax.set_ylabel(y_axis)
    fig.colorbar(image, label="average-roll reduction, %")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
