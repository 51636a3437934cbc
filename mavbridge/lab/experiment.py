"""In-process closed-loop experiments: scenario -> NMPC + vessel plant -> CSV, metrics, plots, Table III.

Deterministic: simulated time does not advance while the solver runs (solve times are measured and
reported, not simulated), and no MAVLink is involved. Two plants:

* ``tau`` (default): the paper's set-up, the rigid-body model driven by the NMPC's τ directly (RK4 at
  ``plant_dt_s``, τ held over the control period). The NMPC's model then matches the plant except for the
  integrator (the NMPC uses its own discretisation), as in the paper and the notes.
* ``propellers``: ``vessel.Plant`` with shaft dynamics; τ goes through ``tau_to_shaft_speeds``, held for the
  period. The propellers saturate below the NMPC's τ bounds when surge and yaw are both large; reverse is weaker.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import signal
import sys
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from multiprocessing import get_context
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from mavbridge.lab.runlog import RunRecorder, column, run_metrics, write_csv
from mavbridge.lab.scenario import Scenario
from mavbridge.lab.watch import observe, realistic_parts
from mavbridge.nmpc import RollAwareNmpc
from mavbridge.nmpc.disturbance import DisturbanceObserver
from mavbridge.nmpc.model_state import resolve_heave_feedback
from mavbridge.waves.inloop import WaveFeed
from mavbridge.waves.source import SCENARIO_TRUTH, ScenarioTruth
from vessel import (
    CalmWater,
    OceanCurrent,
    RegularWaves,
    WaveField,
    shaft_speeds_to_tau,
    tau_to_shaft_speeds,
)
from vessel.closed_loop import PropellerPlant, TauPlant


@dataclass
class RunResult:
    """Where a run's files went and its metrics."""

    name: str
    out_dir: Path
    metrics: dict
    solve_ms: list[float] = field(default_factory=list)
    estimator_ms: list[float] = field(default_factory=list)  # the wave source's work per step (realistic loop)


def _sea_columns(scenario: Scenario, waves: WaveField, truth: ScenarioTruth | None, x: np.ndarray, t: float,
                 shafts: tuple[float, float] | None) -> dict[str, float | None]:
    """Per-row columns the in-process loop knows besides the state: shaft speeds, the true sea at the boat
    (slope α along the travel direction, rad, and the wave force along it, N) and, with ``truth`` (the paper's
    set-up, which plans with it), the wave it plans with. A run with a wave feed leaves those to the feed, so
    that the columns hold only what its source gave: empty before the estimator's first fit."""
    columns: dict[str, float | None] = dict(zip(("n1_rad_s", "n2_rad_s"), shafts or (None, None), strict=True))
    alpha = force = 0.0
    if hasattr(waves, "slope_along_travel"):
        alpha = float(waves.slope_along_travel(x[0], x[1], t))
        params = scenario.plant_params()
        weight = params.matrices().m_total * params.g
        force = -0.5 * weight * math.sin(2 * alpha)
    columns.update(wave_slope_rad=alpha, wave_force_n=force)
    estimate = truth.estimate(t) if truth is not None else None
    if estimate is not None:
        columns.update(estimate.row())
    return columns


def _closed_loop(scenario: Scenario, nmpc: RollAwareNmpc, plant: Any, record: RunRecorder,
                 progress: Callable[[str], None] | None, progress_every_s: float,
                 feed: WaveFeed | None = None, observer: DisturbanceObserver | None = None) -> float | None:
    """Step plant and NMPC until the waypoint or t_max; rows go to ``record``; returns the arrival time.

    With a ``feed`` (the realistic loop) the wave the NMPC plans with comes from it at every step; with an
    ``observer`` the disturbance it predicts with is the one estimated from the boat's motion.
    """
    cfg, params = scenario.controller, scenario.model_params()  # the controller turns τ into commands
    waves = feed.truth if feed is not None else scenario.sea.waves(scenario.plant_params())
    truth = ScenarioTruth(waves) if feed is None else None  # with a feed, its source fills the wave columns
    wp = np.array([scenario.waypoint.north_m, scenario.waypoint.east_m])
    n_steps_max = math.floor(scenario.t_max_s / cfg.period_s + 1e-9)
    step, next_report = 0, progress_every_s
    while True:
        t = round(step * cfg.period_s, 9)
        x = plant.rigid_state
        dist = float(np.hypot(*(wp - x[0:2])))
        sea = _sea_columns(scenario, waves, truth, x, t, plant.shaft_speeds)
        if feed is not None:
            sea.update(feed.step(t, plant, nmpc))
        if observer is not None:
            sea.update(observer.row())
        arrival = t if dist < scenario.waypoint.acceptance_radius_m else None
        if arrival is not None or step >= n_steps_max:
            record.state(t, x, status="end", **sea)
            return arrival
        result = nmpc.solve(x, t, wp, deadline_s=scenario.deadline_s)
        n_cmd = tau_to_shaft_speeds(params, float(result.tau[0]), float(result.tau[1]))
        if observer is not None:  # the command as the boat receives it: τ itself, or what the propellers give
            given = result.tau if plant.shaft_speeds is None else np.array(shaft_speeds_to_tau(params, *n_cmd), float)
            observe(observer, nmpc, t, x, given, progress)
        record.step(t, x, result, n1_cmd_rad_s=n_cmd[0], n2_cmd_rad_s=n_cmd[1], **sea)
        plant.advance(t, result.tau, n_cmd)
        step += 1
        if progress is not None and t + cfg.period_s >= next_report - 1e-9:
            next_report += progress_every_s
            progress(f"[{scenario.name}] t = {t + cfg.period_s:5.1f} s, distance {dist:6.1f} m, "
                     f"median solve {np.median(record.solve_ms):.1f} ms")


def experiment_metrics(scenario: Scenario, record: RunRecorder, arrival: float | None,
                       final_distance_m: float) -> dict[str, Any]:
    """The shared figures of merit (``run_metrics``) with what identifies an in-process run."""
    ref = scenario.reference
    return {
        "name": scenario.name,
        "weights_qrs": [scenario.controller.q, scenario.controller.r, scenario.controller.s],
        **run_metrics(record, arrival, (scenario.waypoint.north_m, scenario.waypoint.east_m)),
        "final_distance_m": final_distance_m,
        "simulated_s": float(record.rows[-1]["t_s"]),
        "solver": scenario.controller.solver,
        "plant": scenario.plant,
        "wave_source": SCENARIO_TRUTH,
        "reference": {"avg_roll_deg": ref.avg_roll_deg, "max_roll_deg": ref.max_roll_deg,
                      "time_to_waypoint_s": ref.time_to_waypoint_s},
    }


def true_disturbance(scenario: Scenario) -> dict[str, float]:
    """The plant's current as NED components (simulation truth, for the metrics' comparison only)."""
    sea = scenario.sea
    direction = math.radians(sea.current_dir_deg)
    return {"true_current_north_m_s": round(sea.current_speed_mps * math.cos(direction), 4),
            "true_current_east_m_s": round(sea.current_speed_mps * math.sin(direction), 4)}


def _told_current(scenario: Scenario) -> OceanCurrent:
    """The current the NMPC is built with: the truth in the paper's set-up (everything known), none in a
    realistic run (the companion is never told; it estimates what it meets, ``estimation.disturbance``); so for
    the wind, which the NMPC is built with only where it is told (``estimation.disturbance: truth``: a bound)."""
    if scenario.estimation.realistic and scenario.estimation.disturbance != "truth":
        return OceanCurrent()
    return scenario.sea.current()


def _model_waves(scenario: Scenario) -> WaveField:
    """The wave the NMPC is built with: the scenario's, except that a run on the estimate plans with one
    regular component set at run time (an irregular field is fixed at build: on the truth it is the full
    field, known to the NMPC)."""
    waves = scenario.sea.waves(scenario.model_params())
    if scenario.estimation.waves != "truth" and not isinstance(waves, RegularWaves | CalmWater):
        return CalmWater()
    return waves


def run_scenario(scenario: Scenario, out_dir: str | Path | None = None, plots: bool = True,
                 progress: Callable[[str], None] | None = None, progress_every_s: float = 20.0) -> RunResult:
    """Run one closed loop; with ``out_dir``, write timeseries.csv, metrics.json, scenario.yaml, PNGs.

    ``scenario.estimation.realistic``: the sensed 20 Hz plant in the hidden sea, and the NMPC's wave from
    the estimator (``waves: estimated``) or the truth; otherwise the paper's set-up, unchanged.
    """
    wall_start = time.perf_counter()
    cfg = scenario.controller
    hull_heaves = scenario.estimation.realistic and scenario.estimation.surface_heave
    cfg = cfg.replace(heave_feedback=resolve_heave_feedback(cfg.heave_feedback, hull_heaves),
                      as_worker="inline" if cfg.as_worker == "thread" else cfg.as_worker)  # (each step waits for it)
    told = not scenario.estimation.realistic or scenario.estimation.disturbance == "truth"  # (simulation truth)
    nmpc = RollAwareNmpc(cfg, scenario.model_params(), _model_waves(scenario), _told_current(scenario),
                         scenario.sea.wind() if told else None)
    feed: WaveFeed | None = None
    observer: DisturbanceObserver | None = None
    if scenario.estimation.realistic:
        if scenario.estimation.disturbance == "estimated":
            observer = DisturbanceObserver(nmpc)
        plant, feed = realistic_parts(scenario, nmpc, observer, progress)  # after the watch (or a kept one's copy)
        if nmpc.takes_waves:
            nmpc.set_wave(feed.truth if scenario.estimation.waves == "truth" else None)
    else:
        plant_class = TauPlant if scenario.plant == "tau" else PropellerPlant
        plant = plant_class(scenario.world, cfg.period_s, scenario.plant_dt_s)
    record = RunRecorder(cfg.period_s)
    wp = np.array([scenario.waypoint.north_m, scenario.waypoint.east_m])
    # Fast solvers: the cold, full solve happens before the loop, so every step inside it is a warm one. The
    # ipopt reference runs exactly as before: its first step is the cold solve, and it is counted.
    prepared = nmpc.prepare(plant.rigid_state, 0.0, wp) if cfg.solver != "ipopt" else None
    arrival = _closed_loop(scenario, nmpc, plant, record, progress, progress_every_s, feed, observer)
    final_distance = float(np.hypot(*(wp - plant.rigid_state[0:2])))
    metrics = experiment_metrics(scenario, record, arrival, final_distance)
    if feed is not None:
        metrics.update(feed.metrics(float(record.rows[-1]["t_s"]), plant.rigid_state))
    if observer is not None:
        metrics["disturbance"] = {**observer.metrics(), **true_disturbance(scenario)}
    metrics["wall_time_s"] = time.perf_counter() - wall_start
    metrics["prepare_ms"] = prepared.wall_time_s * 1e3 if prepared is not None else None
    out = Path(out_dir) if out_dir is not None else None
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        write_csv(out / "timeseries.csv", record.rows)
        (out / "metrics.json").write_text(json.dumps(metrics, indent=2) + "\n", encoding="utf-8")
        (out / "scenario.yaml").write_text(yaml.safe_dump(scenario.to_mapping(), sort_keys=False),
                                           encoding="utf-8")
        if plots:
            _write_plots(out, scenario, record.rows, feed)
    return RunResult(scenario.name, out if out is not None else Path("."), metrics, list(record.solve_ms),
                     list(feed.estimator_ms) if feed is not None else [])


def _write_plots(out: Path, scenario: Scenario, rows: list[dict[str, Any]], feed: WaveFeed | None = None) -> None:
    from mavbridge.lab.plots import plot_path, plot_timeseries, plot_wave_estimate

    t = column(rows, "t_s")
    title = f"{scenario.name}: Q, R, S = {scenario.controller.q:g}, {scenario.controller.r:g}, " \
            f"{scenario.controller.s:g}"
    plot_path(out / "path.png", column(rows, "north_m"), column(rows, "east_m"),
              (scenario.waypoint.north_m, scenario.waypoint.east_m), scenario.waypoint.acceptance_radius_m,
              feed.truth if feed is not None else scenario.sea.waves(scenario.plant_params()), float(t[-1]), title)
    plot_timeseries(out / "timeseries.png", t, column(rows, "wave_force_n"), np.degrees(column(rows, "roll_rad")),
                    np.degrees(column(rows, "pitch_rad")), column(rows, "tau_x_n"), column(rows, "tau_n_nm"), title)
    if feed is not None and feed.mode in ("estimated", "predicted"):
        plot_wave_estimate(out / "wave_estimate.png", rows, feed.truth, title)


def _worker(scenario: Scenario, out_dir: str) -> RunResult:
    def say(line: str) -> None:
        print(line, flush=True)

    return run_scenario(scenario, out_dir, progress=say)


def run_many(scenarios: Sequence[Scenario], out_root: str | Path, jobs: int | None = None,
             say: Callable[[str], None] = print, results: dict[str, RunResult] | None = None) -> list[RunResult]:
    """Run scenarios in parallel processes (one per job), in the given order of results. ``results`` (name ->
    result) fills as runs finish, so that an interrupted call leaves what was finished. On an interrupt the
    queued runs are cancelled and the running ones stopped: nothing runs on unreported."""
    out_root = Path(out_root)
    jobs = max(1, min(jobs or os.cpu_count() or 1, len(scenarios)))
    results = {} if results is None else results
    if jobs == 1:
        for sc in scenarios:
            say(f"[{sc.name}] started")
            results[sc.name] = run_scenario(sc, out_root / sc.name, progress=say)
            say(_done_line(results[sc.name]))
    else:
        os.environ.setdefault("OMP_NUM_THREADS", "1")
        pool = ProcessPoolExecutor(max_workers=jobs, mp_context=get_context("spawn"))
        try:
            futures = {}
            for sc in scenarios:
                futures[pool.submit(_worker, sc, str(out_root / sc.name))] = sc.name
                say(f"[{sc.name}] queued")
            for fut in as_completed(futures):
                res = fut.result()
                results[res.name] = res
                say(_done_line(res))
        except BaseException:
            workers = list(getattr(pool, "_processes", None) or {})  # pids; the pool has no public handle
            pool.shutdown(wait=False, cancel_futures=True)
            for pid in workers:
                with contextlib.suppress(ProcessLookupError):
                    os.kill(pid, signal.SIGTERM)
            raise
        pool.shutdown()
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
    """Run all scenarios, then print and write the comparison table (table3.md) for a set of runs. Interrupted
    (Ctrl-C, SIGTERM), it writes the table of the runs that finished, lists those that did not, and re-raises."""
    finished: dict[str, RunResult] = {}
    try:
        results = run_many(scenarios, out_root, jobs, say, finished)
    except KeyboardInterrupt:
        done = [finished[sc.name] for sc in scenarios if sc.name in finished]
        missing = [sc.name for sc in scenarios if sc.name not in finished]
        if done:
            (Path(out_root) / "table3.md").write_text(comparison_table(done), encoding="utf-8")
            sys.stdout.write(comparison_table(done))
        say(f"experiment: interrupted; finished: {', '.join(r.name for r in done) or 'none'}"
            + (f" (table in {Path(out_root) / 'table3.md'})" if done else "")
            + f"; not finished: {', '.join(missing)}")
        raise
    table = comparison_table(results)
    if len(results) > 1:
        (Path(out_root) / "table3.md").write_text(table, encoding="utf-8")
    sys.stdout.write(table)
    sys.stdout.flush()
    return results
