"""The propellers' asymmetry: the starboard propeller's thrust over the port one's at the same command.

A boat that goes straight has the yaw moments on it in balance. Where one propeller is weaker, the helm that
holds a heading gives the weaker motor the larger command; over windows going straight ahead (the mean yaw rate
within ``STRAIGHT_RAD_S``, not turning either way on average, the gyro's yaw rate where the log has one: the
attitude's differentiated yaw weaves with its noise) the port commanded thrust P (o·|o| of the motor's output)
and the starboard one S then satisfy P = ρ·S + m: ρ the starboard to port thrust ratio, m a steady moment
that is no propeller's (a wind or current the helm held off, a hull that pulls one way), the same at any
throttle, where the propellers' part grows with the thrust.

One heading hold cannot tell them apart: a current's moment held off by the helm reads there as a weaker
propeller. So the windows are grouped into holds (a hold ends where the straight windows stop, or the thrust
moves by more than ``HOLD_LEVEL_TOL``); they must come from ``MIN_HOLDS`` holds or more, at thrusts
``THRUST_SPAN`` or more apart (the identification sequence's throttle 0.3 and 0.6 steps), and ρ is the slope of
the straight line through them, m its intercept. Otherwise one line says the asymmetry is not identifiable. Only
the motors' outputs are used: their sides are the log's own (SERVOn_FUNCTION), where shaft-speed columns do not
say which is port. The interval is a seeded bootstrap over the windows, each hold's drawn from its own; the fit
figure is how well the line carries every window's starboard thrust to its port one.
"""

from __future__ import annotations

import math

import numpy as np

from mavbridge.identify.estimate import Estimate, r_squared
from mavbridge.identify.series import Stretch
from vessel.wording import counted

WINDOW_S = 5.0
STRAIGHT_RAD_S = math.radians(1.0)  # a window's mean yaw rate within this: going straight
STEADY_TURN_RAD_S = math.radians(3.0)  # ... and its mean |yaw rate| under this: not weaving
MIN_FRACTION = 0.04  # both motors ahead by at least this thrust fraction (output 0.2)
MIN_WINDOWS = 3
MIN_HOLDS = 2  # the windows from this many separate holds at least ...
THRUST_SPAN = 1.5  # ... whose mean thrusts differ by this factor at least (a steady moment is told from a ratio)
HOLD_LEVEL_TOL = 0.2  # a straight window next to the last whose thrust differs by more than this share: a new hold
BOOTSTRAP = 300
SCALE_RANGE = (0.1, 2.0)  # OtterParameters.propeller_scale's allowed range
MIN_ASYMMETRY = 0.02  # a ratio closer to 1 than this is left out of the model, whatever its interval

Window = tuple[float, float, float, int]  # (t s, port, starboard mean thrust fraction, hold)


def straight_windows(items: list[Stretch]) -> list[Window]:
    """The windows going straight ahead, in stretches whose columns are (port output, starboard output, yaw rate
    rad/s), each with the hold it belongs to (see the module docstring)."""
    points: list[Window] = []
    hold, last = -1, None  # last: (stretch, window start, thrust) of the previous straight window
    for k, s in enumerate(items):
        if s.dt <= 0:
            continue
        n = max(2, round(WINDOW_S / s.dt))
        for start in range(0, s.t.size - n + 1, n):
            w = s.y[start:start + n]
            port, starboard = w[:, 0] * np.abs(w[:, 0]), w[:, 1] * np.abs(w[:, 1])
            if min(float(port.min()), float(starboard.min())) < MIN_FRACTION:
                continue
            if abs(float(w[:, 2].mean())) > STRAIGHT_RAD_S or float(np.abs(w[:, 2]).mean()) > STEADY_TURN_RAD_S:
                continue
            thrust = float(port.mean() + starboard.mean()) / 2.0
            if last is None or (k, start - n) != last[:2] or abs(thrust - last[2]) > HOLD_LEVEL_TOL * last[2]:
                hold += 1
            last = (k, start, thrust)
            points.append((float(s.t[start]), float(port.mean()), float(starboard.mean()), hold))
    return points


def _too_little(points: list[Window]) -> str | None:
    """Why the windows cannot tell a propeller from a steady moment, or None when they can."""
    windows = f"{counted(len(points), 'window')} of {WINDOW_S:g} s going straight ahead"
    if len(points) < MIN_WINDOWS:
        return f"propellers: {windows} ({MIN_WINDOWS} needed): their asymmetry not identifiable"
    levels = _hold_thrusts(points)
    if len(levels) < MIN_HOLDS:
        return (f"propellers: {windows}, all in one heading hold (a steady wind or current moment held off by the "
                f"helm would read as a weaker propeller): their asymmetry not identifiable")
    if max(levels) < THRUST_SPAN * min(levels):
        return (f"propellers: {windows} in {counted(len(levels), 'hold')}, all at about one thrust "
                f"({min(levels):.2g}–{max(levels):.2g}; {THRUST_SPAN:g}× apart needed to tell a steady wind or "
                f"current moment from a weaker propeller): their asymmetry not identifiable")
    return None


def _hold_thrusts(points: list[Window]) -> list[float]:
    """Each hold's mean thrust fraction (the two motors' mean)."""
    holds = sorted({p[3] for p in points})
    return [float(np.mean([(p[1] + p[2]) / 2.0 for p in points if p[3] == h])) for h in holds]


def _line(port: np.ndarray, starboard: np.ndarray) -> tuple[float, float]:
    """(slope ρ, intercept m) of port = ρ · starboard + m, least squares."""
    slope, intercept = np.polyfit(starboard, port, 1)
    return float(slope), float(intercept)


def thrust_ratio(points: list[Window]) -> Estimate | str:
    """The starboard to port thrust ratio at the same command, or why it cannot be had (one line)."""
    why = _too_little(points)
    if why is not None:
        return why
    port = np.array([p[1] for p in points])
    starboard = np.array([p[2] for p in points])
    holds = np.array([p[3] for p in points])
    ratio, offset = _line(port, starboard)
    rng = np.random.default_rng(0)
    members = [np.flatnonzero(holds == h) for h in np.unique(holds)]
    draws = []
    for _ in range(BOOTSTRAP):
        k = np.concatenate([rng.choice(m, m.size) for m in members])
        draws.append(_line(port[k], starboard[k])[0])
    low, high = (float(np.percentile(draws, q)) for q in (2.5, 97.5))
    source = (f"{counted(len(points), 'window')} of {WINDOW_S:g} s going straight ahead in "
              f"{counted(len(members), 'hold')}, motor outputs; a steady moment's part of "
              f"the port thrust {round(offset, 3) + 0.0:+.3f}")
    return Estimate(ratio, low, high, "", source, r_squared(port, ratio * starboard + offset))


def propeller_scale(ratio: Estimate | None) -> tuple[float, float] | None:
    """OtterParameters.propeller_scale (port, starboard) for a ratio whose interval excludes 1 by MIN_ASYMMETRY or
    more: the weaker propeller scaled, the stronger kept as modelled; None for a symmetric pair, and for a ratio
    beyond the field's range (the ratio itself stays in identify.json)."""
    if ratio is None or ratio.low <= 1.0 <= ratio.high or abs(ratio.value - 1.0) < MIN_ASYMMETRY:
        return None
    if not SCALE_RANGE[0] <= min(ratio.value, 1.0 / ratio.value):
        return None  # a propeller at a tenth of the other's thrust is a fault to look at, not a model to fly
    if ratio.value < 1.0:
        return 1.0, round(ratio.value, 4)
    return round(1.0 / ratio.value, 4), 1.0
