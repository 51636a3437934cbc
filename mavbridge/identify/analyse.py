"""Every estimator over a set of logs of one boat: what they identify, and one line for what they cannot.

Each log is put on a uniform grid (``frames``: its attitude's own step, stretches split at gaps), with its speed
over ground and commands held onto it and the yaw rate from the unwrapped yaw. Roll and pitch come from the
free decays when any log holds one (``decay``), else from the motion itself (``ambient``). Surge and yaw use
the one command the logs hold, in this order: shaft speeds, τ_X/τ_N, the motors' outputs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mavbridge.identify.ambient import ArFit, ambient_estimates
from mavbridge.identify.decay import MIN_EXTREMA, DecayFit, decay_estimates, find_decays, fit_decay
from mavbridge.identify.estimate import Estimate
from mavbridge.identify.logdata import LogData
from mavbridge.identify.series import Stretch, held, median_step, moving_average, stretches
from mavbridge.identify.yaw import Nomoto

QUIET_TURN_RAD_S = math.radians(3.0)  # a decay is free only while the boat turns slower than this ...
QUIET_AVERAGE_S = 0.5  # ... the gyro's, else on average over this long (the yaw's change carries the attitude's noise)
MIN_DECAY_RAD = math.radians(1.5)
MAX_GAP_S = 0.4  # a third of the shortest roll period seen: bridged by interpolation, a longer gap ends a stretch
COLUMNS = ("roll", "pitch", "r", "speed", "n1", "n2", "tau_X", "tau_N", "left", "right", "p", "q", "r_gyro")
RATE_OF = {"roll": "p", "pitch": "q"}  # the body rate beside each angle: its free decay is the angle's, less noisy
RATE_SNR = 10.0  # a decay in a body rate must start at this many times the rate's own sample-to-sample noise ...
RATE_FLOOR_SIGMAS = 2.0  # ... and goes on while its half-heights stay above this many (white gyro noise: a run that
# starts at ten times it is not noise, and a fit below MIN_R2 is refused anyway) ...
RATE_MIN_EXTREMA = 3  # ... for one whole cycle at least (the angle's decays need one and a half: MIN_EXTREMA)
DIFFERENCED_TOL = 0.05  # rates within this share of their RMS of the angles' differences are those differences


@dataclass
class Frames:
    """One log's gap-free stretches on a uniform grid, columns COLUMNS (nan where the log has none)."""

    log: LogData
    items: list[Stretch]

    def column(self, s: Stretch, name: str) -> np.ndarray:
        """A column of one stretch by name."""
        return s.y[:, COLUMNS.index(name)]

    def has(self, name: str) -> bool:
        """Some stretch holds ``name``."""
        return any(np.isfinite(self.column(s, name)).any() for s in self.items)


def _rates(log: LogData) -> np.ndarray | None:
    """Rows (t, p, q, r) of the log's body rates (rad/s), None when it holds none (or only zeros), or when they are
    the angles' own rate of change (a DataFlash log without IMU samples: its reader fills the rates so), which is
    no gyro: its noise is the differenced angle's, and decays are then looked for in the angle."""
    if log.attitude.shape[1] < 7:
        return None
    rows = log.attitude[np.all(np.isfinite(log.attitude[:, 0:7]), axis=1)]
    rows = rows[np.argsort(rows[:, 0], kind="stable")]
    if rows.shape[0] < 2 or not np.any(rows[:, 4:7] != 0) or _differenced(rows):
        return None
    return rows[:, [0, 4, 5, 6]]


def _differenced(rows: np.ndarray) -> bool:
    """The roll and pitch rates are the angles' backward differences (within DIFFERENCED_TOL of their RMS): a gyro's
    rate leads its angle's difference by half a sample, far more than that on any motion."""
    dt = np.diff(rows[:, 0])
    ok = dt > 0
    if np.count_nonzero(ok) < 2:
        return False
    for angle, rate in ((1, 4), (2, 5)):
        diff = np.remainder(np.diff(rows[:, angle]) + math.pi, 2 * math.pi) - math.pi
        measured = rows[1:, rate][ok]
        scale = float(np.sqrt(np.mean(measured**2)))
        if scale == 0 or np.sqrt(np.mean((measured - diff[ok] / dt[ok]) ** 2)) > DIFFERENCED_TOL * scale:
            return False
    return True


def frames(log: LogData) -> Frames:
    """The log on its attitude's grid (see the module docstring)."""
    dt = median_step(log.attitude[:, 0])
    if not math.isfinite(dt):
        return Frames(log, [])
    items = []
    rates = _rates(log)
    for s in stretches(log.attitude[:, 0], log.attitude[:, 1:4], dt, max_gap_s=max(2.5 * dt, MAX_GAP_S)):
        cols = np.full((s.t.size, len(COLUMNS)), np.nan)
        cols[:, 0:2] = s.y[:, 0:2]
        if rates is not None:
            for k, name in enumerate(("p", "q", "r_gyro")):
                cols[:, COLUMNS.index(name)] = np.interp(s.t, rates[:, 0], rates[:, k + 1], left=np.nan, right=np.nan)
        cols[:, 2] = np.gradient(s.y[:, 2], s.dt) if s.t.size > 1 else 0.0
        if log.speed.size:
            cols[:, 3] = held(log.speed[:, 0], log.speed[:, 1], s.t)
        for key, names in (("shafts", ("n1", "n2")), ("tau", ("tau_X", "tau_N")), ("motors", ("left", "right"))):
            if key in log.commands:
                rows = log.commands[key]
                for k, name in enumerate(names):
                    cols[:, COLUMNS.index(name)] = held(rows[:, 0], rows[:, k + 1], s.t)
        items.append(Stretch(s.t, cols))
    return Frames(log, items)


def select(sets: list[Frames], names: tuple[str, ...], keep: Any = None) -> list[Stretch]:
    """Stretches of the named columns, split where a column is missing or ``keep(frames, stretch)`` is False."""
    out = []
    for f in sets:
        for s in f.items:
            y = np.column_stack([f.column(s, n) for n in names])
            ok = np.all(np.isfinite(y), axis=1) & (np.ones(s.t.size, bool) if keep is None else keep(f, s))
            out += stretches(s.t[ok], y[ok], s.dt, max_gap_s=1.5 * s.dt, min_s=2 * s.dt)
    return out


@dataclass
class Identification:
    """What the logs gave: estimates by name, one line per quantity they could not give, and what each fit was
    drawn from (for the page)."""

    estimates: dict[str, Estimate] = field(default_factory=dict)
    missing: list[str] = field(default_factory=list)
    decays: dict[str, list[tuple[DecayFit, np.ndarray, np.ndarray]]] = field(default_factory=dict)
    decay_signal: dict[str, str] = field(default_factory=dict)  # the signal each axis's decays are of ("roll rate")
    ambient: dict[str, tuple[ArFit, list[Stretch]]] = field(default_factory=dict)
    surge: dict[str, Any] = field(default_factory=dict)
    yaw: tuple[Nomoto, list[Stretch], str] | None = None
    yaw_replay: Any = None  # what the yaw was identified on, for the model to fly (``yawfield.YawReplay``)


def _noise(y: np.ndarray) -> float:
    """The attitude's sample-to-sample noise (rad): robust spread of what a 3-sample average leaves."""
    resid = y - moving_average(y, 3)
    return float(1.4826 * np.median(np.abs(resid - np.median(resid))) / 0.816) if y.size > 5 else 0.0


def _signal_decays(t: np.ndarray, y: np.ndarray, quiet: np.ndarray, floor: float, floor_sigmas: float = 3.0,
                   min_extrema: int = MIN_EXTREMA) -> list[tuple[DecayFit, np.ndarray, np.ndarray]]:
    """The fitted free decays of one signal of a stretch, each starting at ``floor`` or more and well above the
    signal's own motion (four times the robust spread of what a 10 s average leaves)."""
    dt = float(t[1] - t[0])
    hp = y - moving_average(y, round(10.0 / dt))
    ambient = 1.4826 * float(np.median(np.abs(hp - np.median(hp))))
    found = []
    for a, b in find_decays(t, y, quiet, max(floor, 4 * ambient), _noise(y), floor_sigmas, min_extrema):
        fit = fit_decay(t[a:b + 1], y[a:b + 1])
        if fit is not None:
            found.append((fit, t[a:b + 1], y[a:b + 1]))
    return found


def _quiet_yaw_rate(f: Frames, s: Stretch) -> np.ndarray:
    """The yaw rate a free decay is judged quiet on: the gyro's where the log has it, else the attitude's yaw
    differentiated and averaged over QUIET_AVERAGE_S (a centred average smears the end of a turn by half of it)."""
    gyro = f.column(s, "r_gyro")
    if np.all(np.isfinite(gyro)):
        return gyro
    return moving_average(np.nan_to_num(f.column(s, "r")), max(1, round(QUIET_AVERAGE_S / s.dt)))


def _axis_decays(sets: list[Frames], axis: str) -> tuple[list[tuple[DecayFit, np.ndarray, np.ndarray]], str]:
    """The axis's free decays and the signal they were found in: its body rate where every log holds it (a free
    decay of the angle is one of its rate too, same period and damping, and a gyro's noise is a small part of a
    decay's rate where an attitude's is a large part of a small decay's angle: the threshold is then RATE_SNR
    times the rate's own noise), else the angle (from MIN_DECAY_RAD)."""
    rate = RATE_OF[axis]
    use_rate = all(f.has(rate) for f in sets)
    signal = f"{axis} rate" if use_rate else axis
    found = []
    for f in sets:
        for s in f.items:
            if s.t.size < 8:
                continue
            quiet = np.abs(_quiet_yaw_rate(f, s)) < QUIET_TURN_RAD_S
            if use_rate:
                y = np.nan_to_num(f.column(s, rate))
                found += _signal_decays(s.t, y, quiet, RATE_SNR * _noise(y), RATE_FLOOR_SIGMAS, RATE_MIN_EXTREMA)
            else:
                found += _signal_decays(s.t, f.column(s, axis), quiet, MIN_DECAY_RAD)
    return found, signal


def identify_axis(sets: list[Frames], axis: str, result: Identification) -> None:
    """Natural period and damping ratio of roll or pitch: free decays first, else the motion's AR fit."""
    decays, signal = _axis_decays(sets, axis)
    pair = decay_estimates([d[0] for d in decays], signal)
    if pair is not None:
        result.decays[axis] = decays
        result.decay_signal[axis] = signal
    else:
        items = select(sets, (axis,))
        got = ambient_estimates(items, axis)
        if isinstance(got, str):
            result.missing.append(f"{axis}: no free decay, and {got}")
            return
        pair = got[0], got[1]
        result.ambient[axis] = (got[2], items)
    result.estimates[f"{axis}_period_s"], result.estimates[f"{axis}_damping_ratio"] = pair
