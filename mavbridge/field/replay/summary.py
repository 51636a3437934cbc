"""What a replay writes (replay.csv's rows) and says at its end."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from mavbridge.companion.rover_modes import mode_name
from mavbridge.field.boat import BOAT_COLUMNS
from mavbridge.lab.runlog import STATE_COLUMNS, WAVE_COLUMNS, write_csv
from vessel.wording import counted

if TYPE_CHECKING:
    from mavbridge.field.replay.flight import Flight, ReplayRequest
    from mavbridge.field.trial import Trial

COMMAND_COLUMNS = ("tau_x_n", "tau_n_nm", "cmd_throttle", "cmd_steering", "steering_pwm_us", "throttle_pwm_us",
                   "yaw_target_rad", "thrust_frac", "yaw_rate_target_rad_s")
LOGGED_COLUMNS = ("logged_steering_pwm_us", "logged_throttle_pwm_us")  # the companion's own override, if logged
COLUMNS = ("t_s", "mode", "armed", "would_command", *STATE_COLUMNS, *COMMAND_COLUMNS, *LOGGED_COLUMNS, *BOAT_COLUMNS,
           *WAVE_COLUMNS, "roll_term", "solve_ms", "status", "fallback")

def write_rows(path: Path, rows: list[dict[str, Any]]) -> None:
    """replay.csv: COLUMNS, a column a row lacks left empty (the run log's own writer)."""
    write_csv(path, rows, COLUMNS, extras="ignore")


def summary_lines(flight: Flight, trial: Trial, req: ReplayRequest, solver: str) -> list[str]:
    """What the replay says at its end."""
    rows = flight.rows
    if not rows:
        return ["replay: no control step in the window (no attitude with a position there)"]
    would = sum(r["would_command"] for r in rows)
    lines = [f"replay: {counted(len(rows), 'control step')} from t = {rows[0]['t_s']:.1f} to "
             f"{rows[-1]['t_s']:.1f} s of the log "
             f"at {flight.period_ms / 1000:g} s, solver {solver}, output {flight.output.name}; nothing was sent",
             f"replay: the boat was armed in {mode_name(flight.output.required_mode)} (where the companion commands) "
             f"for {would} of them"]
    if flight.arrived_s is not None:
        lines.append(f"replay: the last waypoint reached at t = {flight.arrived_s:.3f} s of the log")
    for what in ("throttle", "steering"):
        cmd = np.array([r.get(f"cmd_{what}", math.nan) for r in rows], float)
        boat = np.array([r.get(f"boat_{what}", math.nan) for r in rows], float)
        both = np.isfinite(cmd) & np.isfinite(boat)
        if both.any():
            lines.append(f"replay: {what}: commanded against the boat's motors, mean |difference| "
                         f"{np.mean(np.abs(cmd[both] - boat[both])):.3f} over {counted(int(both.sum()), 'step')}")
    lines.extend(logged_lines(rows))
    lines.append(waves_line(flight.gate.summary(flight.engaged_solve_ms)))
    solve = np.asarray(flight.solve_ms, float)
    lines.append(f"replay: solve median {np.median(solve):.2f} ms, p99 {np.percentile(solve, 99):.2f} ms")
    return lines


def logged_lines(rows: list[dict[str, Any]]) -> list[str]:
    """The replay's PWM against what the companion logged sending at the same steps (its own tlog only)."""
    lines = []
    for what in ("steering", "throttle"):
        pairs = np.array([(r.get(f"{what}_pwm_us", math.nan), r[f"logged_{what}_pwm_us"]) for r in rows
                          if r.get(f"logged_{what}_pwm_us") is not None], float).reshape(-1, 2)
        both = pairs[np.isfinite(pairs).all(axis=1)]
        if len(both):
            diff = np.abs(both[:, 0] - both[:, 1])
            lines.append(f"replay: {what}: against the companion's logged override, {int(np.sum(diff <= 1))} of "
                         f"{counted(len(both), 'step')} within 1 µs, max |difference| {diff.max():.0f} µs")
    return lines


def waves_line(waves: dict[str, Any]) -> str:
    """The estimator as the live run's metrics.json says it: first confident (autopilot s), roll-term share."""
    first, share = waves.get("first_confident_at_s"), waves.get("roll_term_fraction")
    return (f"replay: waves ({waves['source']}): first confident at "
            + ("never" if first is None else f"t = {first:.2f} s") + ", roll term on "
            + ("no step" if share is None else f"{100 * share:.1f} % of the steps the companion would have commanded"))


