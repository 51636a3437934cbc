"""In-process closed-loop experiments: scenario -> NMPC + vessel plant -> CSV, metrics, plots, Table III.

Deterministic: simulated time does not advance while the solver runs (solve times are measured and
reported, not simulated), and no MAVLink is involved. Two plants:

* ``tau`` (default): the paper's set-up, the rigid-body model driven by the NMPC's τ directly (RK4 at
  ``plant_dt_s``, τ held over the control period). The NMPC's model then matches the plant except for the
  integrator (the NMPC uses its own discretisation), as in the paper and the notes.
* ``propellers``: ``vessel.Plant`` with shaft dynamics; τ goes through ``tau_to_shaft_speeds`` and the
  shaft-speed commands are held for the control period. The propellers saturate below the NMPC's τ bounds
  when surge and yaw are both large, and reverse thrust is weaker.
"""

from __future__ import annotations

import csv
import json
import math
import os
import sys
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from multiprocessing import get_context
from pathlib import Path

import numpy as np
import yaml

from vessel import tau_to_shaft_speeds
from vessel.closed_loop import PropellerPlant, TauPlant

from .nmpc import RollAwareNmpc
from .scenario import Scenario

STATE_COLUMNS = ("north", "east", "down", "phi", "theta", "psi", "u", "v", "w", "p", "q", "r")
CSV_COLUMNS = ("t", *STATE_COLUMNS, "n1", "n2", "tau_x", "tau_n", "n1_cmd", "n2_cmd", "alpha",
               "wave_force", "solve_ms", "iterations", "status", "fallback")


@dataclass
class RunResult:
    """Where a run's files went and its metrics."""

    name: str
    out_dir: Path
    metrics: dict
    solve_ms: list[float] = field(default_factory=list)


def _wave_slope_and_force(scenario: Scenario, waves, north: float, east: float, t: float) -> tuple[float, float]:
    """Slope α along the travel direction (rad) and wave force along it (N) at the vessel."""
    if not hasattr(waves, "slope_along_travel"):
        return 0.0, 0.0
    alpha = float(waves.slope_along_travel(north, east, t))
    weight = scenario.params().matrices().m_total * scenario.params().g
    return alpha, -0.5 * weight * math.sin(2 * alpha)


def _percentile(values: Sequence[float], q: float) -> float | None:
    return float(np.percentile(values, q)) if len(values) else None


def compute_metrics(scenario: Scenario, t: np.ndarray, roll: np.ndarray, arrival: float | None,
                    final_distance: float, solve_s: np.ndarray, failures: int, late: int, iterations: np.ndarray,
                    wall_s: float) -> dict:
    """The run's figures of merit (roll in degrees, times in s, solve times in ms)."""
    solve_ms = np.asarray(solve_s) * 1e3
    period_ms = scenario.controller.period_s * 1e3
    ref = scenario.reference
    return {
        "name": scenario.name,
        "weights_qrs": [scenario.controller.q, scenario.controller.r, scenario.controller.s],
        "avg_roll_deg": float(np.degrees(np.mean(np.abs(roll)))),
        "max_roll_deg": float(np.degrees(np.max(np.abs(roll)))),
        "time_to_waypoint_s": arrival,
        "final_distance_m": final_distance,
        "simulated_s": float(t[-1]),
        "steps": len(solve_ms),
        "solve_ms_median": _percentile(solve_ms, 50),
        "solve_ms_p95": _percentile(solve_ms, 95),
        "solve_ms_p99": _percentile(solve_ms, 99),
        "solve_ms_max": float(np.max(solve_ms)) if len(solve_ms) else None,
        "iterations_median": _percentile(iterations, 50),
        "overruns": int(np.sum(solve_ms > period_ms)),
        "failures": int(failures),  # solver gave no usable plan: the fallback input was applied
        "late": int(late),  # solved but past the scenario's deadline_s: the fallback input was applied
        "solver": scenario.controller.solver,
        "plant": scenario.plant,
        "wall_time_s": wall_s,
        "reference": {"avg_roll_deg": ref.avg_roll_deg, "max_roll_deg": ref.max_roll_deg,
                      "time_to_waypoint_s": ref.time_to_waypoint_s},
    }


def run_scenario(scenario: Scenario, out_dir: str | Path | None = None, plots: bool = True,
                 progress: Callable[[str], None] | None = None, progress_every_s: float = 20.0) -> RunResult:
    """Run one closed loop; with ``out_dir``, write timeseries.csv, metrics.json, scenario.yaml, PNGs."""
    wall_start = time.perf_counter()
    waves = scenario.sea.waves()
    params = scenario.params()
    cfg = scenario.controller
    nmpc = RollAwareNmpc(cfg, params, waves, scenario.sea.current())
    plant_class = TauPlant if scenario.plant == "tau" else PropellerPlant
    plant = plant_class(scenario.world, cfg.period_s, scenario.plant_dt_s)
    wp = np.array([scenario.waypoint.north_m, scenario.waypoint.east_m])
    n_steps_max = math.floor(scenario.t_max_s / cfg.period_s + 1e-9)
    rows: list[list] = []
    solve_s: list[float] = []
    iterations: list[int] = []
    background: list[float] = []  # asrti: wall time of each background solve, ms
    failures = late = 0
    arrival = None
    step = 0
    next_report = progress_every_s
    # Fast solvers: the cold, full solve happens before the loop, so every step inside it is a warm one. The
    # ipopt reference runs exactly as before: its first step is the cold solve, and it is counted.
    prepared = nmpc.prepare(plant.rigid_state, 0.0, wp) if cfg.solver != "ipopt" else None
    while True:
        t = round(step * cfg.period_s, 9)
        x = plant.rigid_state
        dist = float(np.hypot(*(wp - x[0:2])))
        alpha, force = _wave_slope_and_force(scenario, waves, x[0], x[1], t)
        shafts = plant.shaft_speeds or (None, None)
        if dist < scenario.waypoint.acceptance_radius_m:
            arrival = t
        if arrival is not None or step >= n_steps_max:
            rows.append([t, *x, *shafts, None, None, None, None, alpha, force, None, None, "end", None])
            break
        result = nmpc.solve(x, t, wp, deadline_s=scenario.deadline_s)
        tau = result.tau
        n_cmd = tau_to_shaft_speeds(params, float(tau[0]), float(tau[1]))
        solve_s.append(result.wall_time_s)
        iterations.append(result.iterations)
        if "background_solve_s" in result.stats:
            background.append(result.stats["background_solve_s"] * 1e3)
        if not result.success:
            failures += 1
        elif result.fallback is not None:
            late += 1
        rows.append([t, *x, *shafts, tau[0], tau[1], n_cmd[0], n_cmd[1], alpha, force,
                     result.wall_time_s * 1e3, result.iterations, result.status,
                     result.fallback_source or ""])
        plant.advance(t, tau, n_cmd)
        step += 1
        if progress is not None and t + cfg.period_s >= next_report - 1e-9:
            next_report += progress_every_s
            progress(f"[{scenario.name}] t = {t + cfg.period_s:5.1f} s, distance {dist:6.1f} m, "
                     f"median solve {np.median(solve_s) * 1e3:.1f} ms")
    t_arr = np.array([r[0] for r in rows], float)
    roll = np.array([r[4] for r in rows], float)
    final_x = plant.rigid_state
    metrics = compute_metrics(scenario, t_arr, roll, arrival, float(np.hypot(*(wp - final_x[0:2]))),
                              np.array(solve_s), failures, late, np.array(iterations), 0.0)
    metrics["wall_time_s"] = time.perf_counter() - wall_start
    metrics["prepare_ms"] = prepared.wall_time_s * 1e3 if prepared is not None else None
    if background:
        metrics["background_solve_ms_median"] = _percentile(background, 50)
        metrics["background_solve_ms_p95"] = _percentile(background, 95)
        metrics["background_solve_ms_max"] = float(np.max(background))
    out = Path(out_dir) if out_dir is not None else None
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        _write_csv(out / "timeseries.csv", rows)
        (out / "metrics.json").write_text(json.dumps(metrics, indent=2) + "\n", encoding="utf-8")
        (out / "scenario.yaml").write_text(yaml.safe_dump(scenario.to_mapping(), sort_keys=False),
                                           encoding="utf-8")
        if plots:
            _write_plots(out, scenario, rows, waves)
    return RunResult(scenario.name, out if out is not None else Path("."), metrics,
                     [v * 1e3 for v in solve_s])


def _fmt(value) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return "nan" if not math.isfinite(value) else f"{value:.6g}"
    return str(value)


def _write_csv(path: Path, rows: list[list]) -> None:
    with path.open("w", newline="", encoding="utf-8") as handle:
        writer = csv.writer(handle)
        writer.writerow(CSV_COLUMNS)
        for row in rows:
            writer.writerow([_fmt(v if not isinstance(v, np.floating) else float(v)) for v in row])


def _write_plots(out: Path, scenario: Scenario, rows: list[list], waves) -> None:
    def col(i: int) -> np.ndarray:
        return np.array([np.nan if r[i] is None else float(r[i]) for r in rows])

    t, north, east = col(0), col(1), col(2)
    from .plots import plot_path, plot_timeseries

    title = f"{scenario.name}: Q, R, S = {scenario.controller.q:g}, {scenario.controller.r:g}, " \
            f"{scenario.controller.s:g}"
    plot_path(out / "path.png", north, east, (scenario.waypoint.north_m, scenario.waypoint.east_m),
              scenario.waypoint.acceptance_radius_m, waves, float(t[-1]), title)
    plot_timeseries(out / "timeseries.png", t, col(CSV_COLUMNS.index("wave_force")),
                    np.degrees(col(4)), np.degrees(col(5)), col(CSV_COLUMNS.index("tau_x")),
                    col(CSV_COLUMNS.index("tau_n")), title)


def _worker(scenario: Scenario, out_dir: str) -> RunResult:
    def say(line: str) -> None:
        print(line, flush=True)

    return run_scenario(scenario, out_dir, progress=say)


def run_many(scenarios: Sequence[Scenario], out_root: str | Path, jobs: int | None = None,
             say: Callable[[str], None] = print) -> list[RunResult]:
    """Run scenarios in parallel processes (one per job), in the given order of results."""
    out_root = Path(out_root)
    jobs = max(1, min(jobs or os.cpu_count() or 1, len(scenarios)))
    results: dict[str, RunResult] = {}
    if jobs == 1:
        for sc in scenarios:
            say(f"[{sc.name}] started")
            results[sc.name] = run_scenario(sc, out_root / sc.name, progress=say)
            say(_done_line(results[sc.name]))
    else:
        os.environ.setdefault("OMP_NUM_THREADS", "1")
        with ProcessPoolExecutor(max_workers=jobs, mp_context=get_context("spawn")) as pool:
            futures = {}
            for sc in scenarios:
                futures[pool.submit(_worker, sc, str(out_root / sc.name))] = sc.name
                say(f"[{sc.name}] queued")
            for fut in as_completed(futures):
                res = fut.result()
                results[res.name] = res
                say(_done_line(res))
    ordered = [results[sc.name] for sc in scenarios]
    return ordered


def _done_line(res: RunResult) -> str:
    m = res.metrics
    arrival = f"{m['time_to_waypoint_s']:.1f} s" if m["time_to_waypoint_s"] is not None else "not reached"
    return (f"[{res.name}] done: avg roll {m['avg_roll_deg']:.2f}°, max {m['max_roll_deg']:.2f}°, "
            f"waypoint {arrival}, solve median {m['solve_ms_median']:.1f} ms, failures {m['failures']}, "
            f"wall {m['wall_time_s']:.1f} s -> {res.out_dir}")


def _num(value: float | None, digits: int = 2) -> str:
    return "N/A" if value is None else f"{value:.{digits}f}"


def comparison_table(results: Sequence[RunResult]) -> str:
    """Markdown: each run with the reference (paper) values side by side."""
    lines = [
        "| run | Q, R, S | avg roll ° (ours / paper) | max roll ° (ours / paper) | time to wpt s (ours / paper) "
        "| avg-roll change vs direct (ours / paper) | solve ms median / p95 / max | failures |",
        "|---|---|---|---|---|---|---|---|",
    ]
    by_name = {r.name: r.metrics for r in results}
    direct = by_name.get("direct")
    for res in results:
        m = res.metrics
        ref = m["reference"]
        q, r, s = m["weights_qrs"]
        change = ""
        if direct is not None and res.name != "direct":
            ours = 100 * (m["avg_roll_deg"] / direct["avg_roll_deg"] - 1)
            paper = ""
            if ref["avg_roll_deg"] is not None and direct["reference"]["avg_roll_deg"]:
                paper = f"{100 * (ref['avg_roll_deg'] / direct['reference']['avg_roll_deg'] - 1):+.0f} %"
            change = f"{ours:+.0f} % / {paper or 'N/A'}"
        lines.append(
            f"| {res.name} | {q:g}, {r:g}, {s:g} "
            f"| {_num(m['avg_roll_deg'])} / {_num(ref['avg_roll_deg'])} "
            f"| {_num(m['max_roll_deg'])} / {_num(ref['max_roll_deg'])} "
            f"| {_num(m['time_to_waypoint_s'], 1)} / {_num(ref['time_to_waypoint_s'], 1)} "
            f"| {change} "
            f"| {_num(m['solve_ms_median'], 1)} / {_num(m['solve_ms_p95'], 1)} / {_num(m['solve_ms_max'], 1)} "
            f"| {m['failures']} |")
    return "\n".join(lines) + "\n"


def experiment(scenarios: Sequence[Scenario], out_root: str | Path, jobs: int | None = None,
               say: Callable[[str], None] = print) -> list[RunResult]:
    """Run all scenarios, then print and write the comparison table (table3.md) for a set of runs."""
    results = run_many(scenarios, out_root, jobs, say)
    table = comparison_table(results)
    if len(results) > 1:
        (Path(out_root) / "table3.md").write_text(table, encoding="utf-8")
    sys.stdout.write(table)
    sys.stdout.flush()
    return results
