"""Standard open-water maneuvers on the bare plant, and the figures a naval architect reads off them.

Commands are shaft speeds in percent of n_max per propeller (negative = reverse, saturated at n_min).
Figures: steady speed, yaw rate and turning radius; damped period and logarithmic decrement of a free
roll or pitch decay; overshoots of a zig-zag.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vessel.config import ConfigError
from vessel.dynamics import NX_PLANT, STATE_COLUMNS, STATE_NAMES
from vessel.params import OtterParameters, otter_parameters
from vessel.plant import Plant
from vessel.sea.waves import CalmWater, WaveField

MAX_INITIAL_ANGLE_DEG = 60.0
MAX_DT_S = 0.1
MAX_DURATION_S = 3600.0


@dataclass(frozen=True)
class Maneuver:
    """A maneuver: constant shaft commands (or a zig-zag), initial roll/pitch, duration and step."""

    left_pct: float = 0.0
    right_pct: float = 0.0
    duration_s: float = 60.0
    dt_s: float = 0.01
    roll_deg: float = 0.0
    pitch_deg: float = 0.0
    integrator: str = "rk4"
    zigzag_deg: float = 0.0  # > 0: swap left/right each time the heading passes ±zigzag_deg
    params: OtterParameters = field(default_factory=otter_parameters)
    waves: WaveField = field(default_factory=CalmWater)

    def __post_init__(self) -> None:
        for flag, value in (("--left", self.left_pct), ("--right", self.right_pct)):
            if not (math.isfinite(value) and -100.0 <= value <= 100.0):
                raise ConfigError(f"{flag}: {value!r} is outside the allowed range [-100, 100] % of n_max")
        if not (math.isfinite(self.duration_s) and 0 < self.duration_s <= MAX_DURATION_S):
            raise ConfigError(f"--duration: {self.duration_s!r} is outside the allowed range "
                              f"(0, {MAX_DURATION_S:g}] s")
        if not (math.isfinite(self.dt_s) and 0 < self.dt_s <= MAX_DT_S):
            raise ConfigError(f"--dt: {self.dt_s!r} is outside the allowed range (0, {MAX_DT_S:g}] s")
        for flag, value in (("--roll-deg", self.roll_deg), ("--pitch-deg", self.pitch_deg)):
            if not (math.isfinite(value) and abs(value) <= MAX_INITIAL_ANGLE_DEG):
                raise ConfigError(f"{flag}: {value!r} is outside the allowed range "
                                  f"[-{MAX_INITIAL_ANGLE_DEG:g}, {MAX_INITIAL_ANGLE_DEG:g}] deg")
        if not (math.isfinite(self.zigzag_deg) and 0 <= self.zigzag_deg <= 90):
            raise ConfigError(f"--zigzag-deg: {self.zigzag_deg!r} is outside the allowed range [0, 90] deg")


PRESETS: dict[str, dict[str, float]] = {
    "straight": {"left_pct": 70, "right_pct": 70, "duration_s": 60},
    "turning-circle": {"left_pct": 70, "right_pct": 30, "duration_s": 60},
    "zig-zag": {"left_pct": 70, "right_pct": 30, "duration_s": 60, "zigzag_deg": 20},
    "roll-decay": {"left_pct": 0, "right_pct": 0, "duration_s": 10, "roll_deg": 10},
    "pitch-decay": {"left_pct": 0, "right_pct": 0, "duration_s": 10, "pitch_deg": 5},
}


@dataclass(frozen=True)
class ManeuverResult:
    """Time (s, one row per step from t = 0) and plant states (rows of x, see STATE_NAMES)."""

    maneuver: Maneuver
    t: np.ndarray
    x: np.ndarray
    n_cmd: np.ndarray

    def column(self, name: str) -> np.ndarray:
        """One state column by name."""
        return self.x[:, STATE_NAMES.index(name)]


def _command_schedule(m: Maneuver, n_max: float) -> Callable[[np.ndarray], tuple[float, float]]:
    """Shaft commands (rad/s) as a function of the state; a zig-zag swaps sides at ±zigzag_deg."""
    left, right = m.left_pct / 100 * n_max, m.right_pct / 100 * n_max
    if m.zigzag_deg <= 0:
        return lambda x: (left, right)
    limit = math.radians(m.zigzag_deg)
    state = {"swapped": False, "psi0": None}

    def schedule(x: np.ndarray) -> tuple[float, float]:
        if state["psi0"] is None:
            state["psi0"] = float(x[5])
        deviation = float(x[5]) - state["psi0"]
        # Unswapped (more thrust on the left) turns to starboard: swap once past +limit, back past −limit.
        if not state["swapped"] and deviation > limit:
            state["swapped"] = True
        elif state["swapped"] and deviation < -limit:
            state["swapped"] = False
        return (right, left) if state["swapped"] else (left, right)

    return schedule


def run_maneuver(m: Maneuver) -> ManeuverResult:
    """Simulate the maneuver from rest (with the initial roll/pitch) and record every step."""
    x0 = np.zeros(NX_PLANT)
    x0[3], x0[4] = math.radians(m.roll_deg), math.radians(m.pitch_deg)
    plant = Plant(m.params, m.waves, dt=m.dt_s, integrator=m.integrator, x0=x0)  # type: ignore[arg-type]
    steps = round(m.duration_s / m.dt_s)
    schedule = _command_schedule(m, m.params.matrices().n_max)
    t = np.arange(steps + 1) * m.dt_s
    x = np.empty((steps + 1, NX_PLANT))
    n_cmd = np.empty((steps + 1, 2))
    x[0] = plant.state
    for k in range(steps):
        n_cmd[k] = schedule(x[k])
        x[k + 1] = plant.step(n_cmd[k])
    n_cmd[steps] = schedule(x[steps])
    return ManeuverResult(m, t, x, n_cmd)


def _extrema(t: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Times and values of local extrema of y, refined by a parabola through each sampled extremum."""
    dy = np.diff(y)
    idx = np.where(np.sign(dy[1:]) * np.sign(dy[:-1]) < 0)[0] + 1
    times, values = [], []
    h = t[1] - t[0]
    for i in idx:
        y0, y1, y2 = y[i - 1], y[i], y[i + 1]
        denom = y0 - 2 * y1 + y2
        shift = 0.5 * (y0 - y2) / denom if denom != 0 else 0.0
        times.append(t[i] + shift * h)
        values.append(y1 - 0.25 * (y0 - y2) * shift)
    return np.array(times), np.array(values)


def decay_figures(t: np.ndarray, y: np.ndarray, floor: float = 1e-4) -> dict[str, float]:
    """Damped period (s) and logarithmic decrement per cycle of a free decay about its final value.

    Uses the extrema whose deviation from the final value exceeds ``floor`` (rad): successive
    extrema half a period apart give the period; the decrement is ln of the ratio of extrema one
    period apart, averaged.
    """
    settled = float(np.mean(y[-max(len(y) // 10, 2):]))
    times, values = _extrema(t, y - settled)
    keep = np.abs(values) > floor
    times, values = times[keep], values[keep]
    if len(times) < 3:
        return {"damped_period_s": math.nan, "log_decrement": math.nan, "equilibrium": settled}
    period = 2 * float(np.mean(np.diff(times)))
    ratios = np.abs(values[:-2] / values[2:])
    return {"damped_period_s": period, "log_decrement": float(np.mean(np.log(ratios))),
            "equilibrium": settled}


def steady_figures(result: ManeuverResult, window_s: float = 5.0) -> dict[str, float]:
    """Speed over ground (m/s), yaw rate (rad/s) and turning radius (m) averaged over the last window."""
    m = result.maneuver
    last = result.t >= result.t[-1] - window_s
    u, v, r = (result.column(n)[last] for n in ("u", "v", "r"))
    speed = float(np.mean(np.hypot(u, v)))
    yaw_rate = float(np.mean(r))
    figures = {"surge_speed_mps": float(np.mean(u)), "speed_mps": speed}
    if m.zigzag_deg <= 0:
        figures["yaw_rate_rad_s"] = yaw_rate
        if abs(yaw_rate) > 1e-3:
            figures["turning_radius_m"] = speed / abs(yaw_rate)
    else:
        psi = np.degrees(result.column("psi") - result.column("psi")[0])
        _, peaks = _extrema(result.t, psi)
        over = [abs(p) - m.zigzag_deg for p in peaks[:2]]
        for i, o in enumerate(over, 1):
            figures[f"overshoot_{i}_deg"] = float(o)
    return figures


def maneuver_figures(result: ManeuverResult) -> dict[str, float]:
    """The standard figures that apply to this maneuver."""
    m = result.maneuver
    figures: dict[str, float] = {}
    if m.left_pct != 0 or m.right_pct != 0:
        figures.update(steady_figures(result))
    if m.roll_deg != 0:
        figures.update({f"roll_{k}": v for k, v in decay_figures(result.t, result.column("phi")).items()})
    if m.pitch_deg != 0:
        figures.update({f"pitch_{k}": v for k, v in decay_figures(result.t, result.column("theta")).items()})
    return figures


def write_csv(result: ManeuverResult, path: str | Path) -> None:
    """CSV with t_s and every state, the unit in each column's name (``STATE_COLUMNS``: NED position, Euler
    angles, body velocities and rates, shaft speeds; SI units, radians)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as stream:
        writer = csv.writer(stream)
        writer.writerow(["t_s", *STATE_COLUMNS])
        for t, x in zip(result.t, result.x, strict=True):
            writer.writerow([f"{t:.6g}", *(f"{value:.9g}" for value in x)])


def plot(result: ManeuverResult, path: str | Path) -> None:
    """Track (east right, north up) beside time series of speed, yaw rate, roll, pitch and shaft speeds."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig = plt.figure(figsize=(12, 7), constrained_layout=True)
    grid = fig.add_gridspec(4, 2)
    track = fig.add_subplot(grid[:, 0])
    track.plot(result.column("east"), result.column("north"))
    track.plot(result.column("east")[0], result.column("north")[0], "o", label="start")
    track.set_xlabel("east [m]")
    track.set_ylabel("north [m]")
    track.set_aspect("equal", adjustable="datalim")
    track.legend()
    track.set_title("track")
    series = [
        ("speed [m/s]", [("u", result.column("u")), ("v", result.column("v"))]),
        ("yaw rate [deg/s]", [("r", np.degrees(result.column("r")))]),
        ("attitude [deg]", [("roll", np.degrees(result.column("phi"))),
                            ("pitch", np.degrees(result.column("theta")))]),
        ("shaft speed [rad/s]", [("n1 left", result.column("n1")), ("n2 right", result.column("n2"))]),
    ]
    for row, (label, lines) in enumerate(series):
        ax = fig.add_subplot(grid[row, 1])
        for name, values in lines:
            ax.plot(result.t, values, label=name)
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
        ax.legend(loc="upper right", fontsize="small")
    ax.set_xlabel("t [s]")
    fig.savefig(path, dpi=100)
    plt.close(fig)
