"""The propellers' asymmetry: the starboard propeller's thrust over the port one's at the same command.

A boat that goes straight has its two propellers' yaw moments equal. Where one propeller is weaker, the helm that
holds a heading gives the weaker motor the larger command, so over windows going straight ahead (the mean yaw
rate within ``STRAIGHT_RAD_S``, not turning either way on average) the ratio of the port to the starboard
commanded thrust (o·|o| of each motor's output) is the starboard to port thrust ratio. Only the motors' outputs
are used: their sides are the log's own (SERVOn_FUNCTION), where shaft-speed columns do not say which is port.
The interval is a seeded bootstrap over the windows; the fit figure is how well one ratio carries every window's
port thrust to its starboard one (the windows span the throttle steps).
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
BOOTSTRAP = 300
SCALE_RANGE = (0.1, 2.0)  # OtterParameters.propeller_scale's allowed range
MIN_ASYMMETRY = 0.02  # a ratio closer to 1 than this is left out of the model, whatever its interval


def straight_windows(items: list[Stretch]) -> list[tuple[float, float, float]]:
    """(t s, port, starboard mean thrust fraction) of the windows going straight ahead, in stretches whose columns
    are (port output, starboard output, yaw rate rad/s)."""
    points = []
    for s in items:
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
            points.append((float(s.t[start]), float(port.mean()), float(starboard.mean())))
    return points


def thrust_ratio(points: list[tuple[float, float, float]]) -> Estimate | str:
    """The starboard to port thrust ratio at the same command, or why it cannot be had."""
    if len(points) < MIN_WINDOWS:
        return (f"propellers: {counted(len(points), 'window')} of {WINDOW_S:g} s going straight ahead "
                f"({MIN_WINDOWS} needed): their asymmetry not identifiable")
    port = np.array([p[1] for p in points])
    starboard = np.array([p[2] for p in points])
    ratio = float(port.sum() / starboard.sum())
    rng = np.random.default_rng(0)
    draws = [float(port[k].sum() / starboard[k].sum())
             for k in (rng.integers(0, port.size, port.size) for _ in range(BOOTSTRAP))]
    low, high = (float(np.percentile(draws, q)) for q in (2.5, 97.5))
    source = f"{counted(len(points), 'window')} of {WINDOW_S:g} s going straight ahead, motor outputs"
    return Estimate(ratio, low, high, "", source, r_squared(starboard, port / ratio))


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
