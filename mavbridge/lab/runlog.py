"""One run record for every closed loop: the CSV schema, the recorder, and the metrics function.

The companion (`mavbridge run`, rows in ``companion.csv``) and the in-process experiment
(``timeseries.csv``) write the same columns, built from the state names of ``vessel`` with the unit in
each name (``north_m``, ``roll_rad``, ``u_m_s``; NED position relative to home, Euler angles, body
velocities and rates). A loop fills the columns it knows and leaves the others empty, so one reader
serves both files. The figures of merit (average and maximum roll, time to the waypoint, solve-time
statistics, counters) come from one function, ``run_metrics``, fed by a ``RunRecorder``.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from mavbridge.lab.path_metrics import path_figures
from vessel import NX_RIGID, STATE_NAMES
from vessel import STATE_COLUMNS as VESSEL_COLUMNS
from vessel.config import ConfigError
from vessel.folders import fresh_folder

STATE_COLUMNS = VESSEL_COLUMNS[:NX_RIGID]  # the rigid-body states, the unit in each name (vessel's names)
# The per-step wave knowledge (mavbridge.waves.source.WaveEstimate.row()).
WAVE_COLUMNS = ("wave_height_m", "wave_period_s", "wave_length_m", "wave_dir_deg", "wave_phase_rad",
                "wave_confidence")
# The disturbance estimate (mavbridge.nmpc.disturbance.DisturbanceObserver.row()): current NED (m/s), steady surge
# force (N) and yaw moment (N·m), and the current's standard deviation (m/s).
DISTURBANCE_COLUMNS = ("dist_current_north_m_s", "dist_current_east_m_s", "dist_surge_force_n", "dist_yaw_moment_nm",
                       "dist_current_std_m_s")
LOG_COLUMNS = (
    "t_s", "phase", *STATE_COLUMNS,
    "n1_rad_s", "n2_rad_s",  # actual shaft speeds (propeller plant only)
    "tau_x_n", "tau_n_nm",  # the NMPC's surge force and yaw moment
    "n1_cmd_rad_s", "n2_cmd_rad_s",  # shaft-speed commands (experiment)
    "steering_pwm_us", "throttle_pwm_us",  # rc_override: what went out on the steering/throttle channels
    "yaw_target_rad", "thrust_frac",  # attitude_target: heading (NED) and thrust as a fraction of WP_SPEED
    "yaw_rate_target_rad_s",  # attitude_target, rate and tau forms: the body yaw rate sent (heading form: empty)
    "wave_slope_rad", "wave_force_n",  # the true sea at the boat (experiment: it knows the truth)
    *WAVE_COLUMNS,
    "wave_bank_on",  # estimation.waves predicted: 1 while the NMPC plans on the phase predictor's bank, else 0
    *DISTURBANCE_COLUMNS,  # the disturbance the NMPC predicts with, as estimated from the boat's motion
    "solve_ms", "iterations", "status", "fallback", "fallback_reason", "sent",
    "state_age_s",  # companion: autopilot time now (estimated) minus the state's time_boot_ms
)
ROLL = STATE_COLUMNS[STATE_NAMES.index("phi")]
_KNOWN_COLUMNS = frozenset(LOG_COLUMNS)  # (checked for every row)


@dataclass
class RunRecorder:
    """The rows of one run and the counters its metrics need (appended to as the loop runs)."""

    period_s: float
    rows: list[dict[str, Any]] = field(default_factory=list)
    solve_ms: list[float] = field(default_factory=list)
    iterations: list[int] = field(default_factory=list)
    background_ms: list[float] = field(default_factory=list)  # asrti: wall time of each background solve
    failures: int = 0  # the solver gave no usable plan: the fallback input was applied
    late: int = 0  # solved but past the deadline: the fallback input was applied

    def state(self, t_s: float, x: Iterable[float], **columns: Any) -> dict[str, Any]:
        """Append a row for state ``x`` (12 rigid-body states) at ``t_s`` with more columns; returns it."""
        # a float array gives its numbers in one call (float(v) of each entry makes a numpy scalar first)
        values = x.tolist() if isinstance(x, np.ndarray) and x.dtype == np.float64 else [float(v) for v in x]
        row = {"t_s": t_s, **dict(zip(STATE_COLUMNS, values[:NX_RIGID], strict=True)), **columns}
        unknown = row.keys() - _KNOWN_COLUMNS
        if unknown:
            raise KeyError(f"run log: no column {sorted(unknown)[0]!r}")
        self.rows.append(row)
        return row

    def step(self, t_s: float, x: Iterable[float], result: Any, **columns: Any) -> dict[str, Any]:
        """Append a control step: the state, the NMPC's answer (``NmpcResult``) and more columns."""
        self.solve_ms.append(result.wall_time_s * 1e3)
        self.iterations.append(result.iterations)
        if "background_solve_s" in result.stats:
            self.background_ms.append(result.stats["background_solve_s"] * 1e3)
        if not result.success:
            self.failures += 1
        elif result.fallback is not None:
            self.late += 1
        tau = result.tau
        return self.state(t_s, x, tau_x_n=float(tau[0]), tau_n_nm=float(tau[1]), solve_ms=result.wall_time_s * 1e3,
                          iterations=result.iterations, status=result.status,
                          fallback=result.fallback_source or "", fallback_reason=result.fallback or "", **columns)


def _percentile(values: np.ndarray, q: float) -> float | None:
    return float(np.percentile(values, q)) if len(values) else None


def run_metrics(record: RunRecorder, time_to_waypoint_s: float | None,
                waypoint_ne: tuple[float, float] | None = None) -> dict[str, Any]:
    """The figures of merit: |roll| over the recorded rows (deg), solve times (ms), counters; with the waypoint
    (NED m), how far the path went past it and how often it looped around it (``path_metrics``), the start being
    the first row."""
    roll = column(record.rows, ROLL)
    solve_ms = np.asarray(record.solve_ms, float)
    metrics: dict[str, Any] = {
        "avg_roll_deg": float(np.degrees(np.mean(np.abs(roll)))) if roll.size else None,
        "max_roll_deg": float(np.degrees(np.max(np.abs(roll)))) if roll.size else None,
        "time_to_waypoint_s": time_to_waypoint_s,
        "steps": len(solve_ms),
        "solve_ms_median": _percentile(solve_ms, 50),
        "solve_ms_p95": _percentile(solve_ms, 95),
        "solve_ms_p99": _percentile(solve_ms, 99),
        "solve_ms_max": float(np.max(solve_ms)) if solve_ms.size else None,
        "iterations_median": _percentile(np.asarray(record.iterations, float), 50),
        "overruns": int(np.sum(solve_ms > record.period_s * 1e3)),
        "failures": int(record.failures),
        "late": int(record.late),
    }
    if waypoint_ne is not None and record.rows:
        north, east = column(record.rows, "north_m"), column(record.rows, "east_m")
        metrics.update(path_figures(north, east, (float(north[0]), float(east[0])), waypoint_ne))
    if record.background_ms:
        background = np.asarray(record.background_ms, float)
        metrics["background_solve_ms_median"] = _percentile(background, 50)
        metrics["background_solve_ms_p95"] = _percentile(background, 95)
        metrics["background_solve_ms_max"] = float(np.max(background))
    return metrics


def _cell(value: Any) -> str:
    """One CSV cell: empty for None, 9 significant digits for floats, text otherwise."""
    if value is None:
        return ""
    if isinstance(value, float | np.floating):
        value = float(value)
        return "nan" if not math.isfinite(value) else f"{value:.9g}"
    return str(value)


def write_csv(path: Path, rows: Iterable[Mapping[str, Any]], columns: Sequence[str] = LOG_COLUMNS,
              extras: str = "raise") -> None:
    """The rows under the ``columns`` header (default LOG_COLUMNS); a column a row lacks is left empty, one the
    header lacks refused (``extras`` "ignore": left out)."""
    with path.open("w", newline="", encoding="utf-8") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(columns), restval="", extrasaction=extras)
        writer.writeheader()
        for row in rows:
            writer.writerow({key: _cell(value) for key, value in row.items()})


def column(rows: Iterable[Mapping[str, Any]], name: str) -> np.ndarray:
    """One column of in-memory rows as floats (NaN where a row left it empty)."""
    if name not in LOG_COLUMNS:
        raise KeyError(f"run log: no column {name!r}")
    return np.array([math.nan if row.get(name) in (None, "") else float(row[name]) for row in rows], float)


def fresh_run_folder(path: Path, flag: str = "--out", say: Callable[[str], None] = print) -> Path:
    """A run folder that holds no earlier run (``vessel.folders.fresh_folder``); ConfigError (one line naming
    ``flag``) when it cannot be made."""
    try:
        return fresh_folder(path, flag, say)
    except FileExistsError:
        raise ConfigError(f"{flag}: {path} is a file, not a folder") from None
    except OSError as exc:
        raise ConfigError(f"{flag}: {path}: cannot create the folder ({exc.strerror or exc})") from None
