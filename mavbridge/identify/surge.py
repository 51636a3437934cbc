"""Steady surge speed against the propulsion command, forward and reverse.

The command is turned into a thrust fraction s in [−1, 1] — the mean over the motors of (n/n_full)·|n/n_full|
for shaft speeds or motor outputs (a propeller's thrust goes with n|n|), τ_X/τ_full for a commanded force — so
that the model's steady speed is linear in it: u = U·s, U the speed at full command (the hull's surge damping
is linear, X_u = bollard pull / U_max). Steady windows are WINDOW_S long after SETTLE_S of a command that moved
less than STEADY_FRACTION of full scale, while not turning harder than MAX_TURN_RAD_S on average (of |r|: a
zig-zag at a steady command turns both ways and is not a straight run). U is the least-squares
slope through the origin of the windows' mean speeds on their thrust fractions, its interval a seeded bootstrap
over the windows.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mavbridge.identify.estimate import Estimate, r_squared
from mavbridge.identify.series import Stretch
from vessel.wording import counted

SETTLE_S = 5.0
WINDOW_S = 5.0
STEADY_FRACTION = 0.05
MAX_TURN_RAD_S = math.radians(10.0)
MIN_FRACTION = 0.03  # thrust fractions closer to zero say nothing about the slope
MIN_WINDOWS = 3
BOOTSTRAP = 300


@dataclass(frozen=True)
class SurgePoint:
    """One steady window: its mean command (the log's unit), thrust fraction, mean speed (m/s) and mean pitch
    (rad, nan when the stretch has none: the trim the payload fit checks)."""

    t_s: float
    command: float
    fraction: float
    speed_m_s: float
    pitch_rad: float = math.nan


def steady_points(items: list[Stretch]) -> list[SurgePoint]:
    """Steady windows of stretches whose columns are (command in the log's unit, thrust fraction, speed m/s, yaw
    rate rad/s[, pitch rad])."""
    points = []
    for s in items:
        if s.dt <= 0:
            continue
        n_win, n_set = max(2, round(WINDOW_S / s.dt)), round(SETTLE_S / s.dt)
        for start in range(n_set, s.t.size - n_win + 1, n_win):
            held = s.y[start - n_set:start + n_win, 1]
            window = s.y[start:start + n_win]
            if np.ptp(held) > STEADY_FRACTION or float(np.mean(np.abs(window[:, 3]))) > MAX_TURN_RAD_S:
                continue
            pitch = float(np.mean(window[:, 4])) if window.shape[1] > 4 else math.nan
            points.append(SurgePoint(float(s.t[start]), float(np.mean(window[:, 0])), float(np.mean(window[:, 1])),
                                     float(np.mean(window[:, 2])), pitch))
    return points


def fit_surge(points: list[SurgePoint], reverse: bool, kind: str) -> Estimate | str:
    """The speed at full forward (or reverse, negative) command, U in u = U·s, or why it cannot be had."""
    direction = "reverse" if reverse else "forward"
    used = [p for p in points if (p.fraction < -MIN_FRACTION if reverse else p.fraction > MIN_FRACTION)]
    if len(used) < MIN_WINDOWS:
        return (f"surge {direction}: {len(used)} steady {direction} window{'s' if len(used) != 1 else ''} of "
                f"{kind} ({MIN_WINDOWS} needed): {direction} speed not identifiable")
    s = np.array([p.fraction for p in used])
    u = np.array([p.speed_m_s for p in used])
    if reverse:
        u = -np.abs(u)  # speed over ground has no sign: going astern is negative surge
    slope = float(s @ u / (s @ s))
    rng = np.random.default_rng(0)
    draws = []
    for _ in range(BOOTSTRAP):
        k = rng.integers(0, s.size, s.size)
        if float(s[k] @ s[k]) > 0:
            draws.append(float(s[k] @ u[k] / (s[k] @ s[k])))
    low, high = (float(np.percentile(draws, q)) for q in (2.5, 97.5))
    fit = r_squared(u, slope * s)
    if reverse:  # the speed at full reverse command (s = −1): negative
        slope, low, high = -slope, -high, -low
    source = f"{counted(len(used), f'steady {direction} window')} of {WINDOW_S:g} s, {kind}; u = U·(thrust fraction)"
    return Estimate(slope, low, high, "m/s", source, fit)
