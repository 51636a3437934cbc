"""The last seconds of the boat's motion, reduced to what the window fit needs (``window_model.Window``).

Each valid sample becomes one row: autopilot time; the boat's NED track (the GPS velocity integrated, pulled
slowly to the GPS position: smooth between fixes and free of their metres of noise, which would be a tenth of a
wave's phase; re-anchored at the GPS position after a gap in the samples); its NED velocity and heading; pitch
and roll × ``roll_sign`` (the slope along and across the hull); the hull's down acceleration from the IMU
(a_D = (R·f)_D + g, NaN without one); and, at each new GPS fix only, its down position. ``window`` hands out
the last ``window_s`` seconds thinned to ``FIT_RATE_HZ`` (every GPS height kept) and referred to the last
sample: t and north/east measured from the boat's time and place now. Plain lists grow by one value a field
per sample; the fit's arrays are built only when a fit asks.
"""

from __future__ import annotations

import math

import numpy as np

from mavbridge.waves.filters import finite
from mavbridge.waves.window_model import Window

GRAVITY = 9.81
FIELDS = ("t", "north", "east", "v_north", "v_east", "psi", "along", "across", "accel", "down")
FIT_RATE_HZ = 10.0  # the fit uses samples at most this often
TRACK_PULL_S = 30.0  # the dead-reckoned track is pulled to the GPS position with this time constant
MIN_ROWS = 40  # fewer samples than this make no window
GAP_S = 0.5  # a longer silence between samples re-anchors the dead-reckoned track at the GPS position


def down_acceleration(att: tuple[float, ...], accel_body: object) -> float:
    """a_D (m/s², NED down) of the hull from the IMU's body specific force: (R·f)_D + g; NaN without a finite one."""
    f = finite(accel_body, 3)
    if f is None:
        return math.nan
    phi, theta = att[0], att[1]
    return (-math.sin(theta) * f[0] + math.cos(theta) * math.sin(phi) * f[1]
            + math.cos(theta) * math.cos(phi) * f[2] + GRAVITY)


def _last_in_blocks(values: np.ndarray, first: int, step: int) -> np.ndarray:
    """Per kept sample (``first``, ``first`` + ``step``, …) the last finite value since the kept sample before it:
    a sparse channel (a height per GPS fix) keeps every fix when the window is thinned, on the next kept sample."""
    out = np.full(len(range(first, values.size, step)), np.nan)
    where = np.flatnonzero(np.isfinite(values))
    blocks = np.maximum(0, -((first - where) // step))  # ceil((i − first) / step): the kept sample at or after i
    inside = blocks < out.size
    where, blocks = where[inside][::-1], blocks[inside][::-1]
    unique, last = np.unique(blocks, return_index=True)  # reversed: the first seen is the last in time
    out[unique] = values[where[last]]
    return out


class MotionWindow:
    """The rows of the last ``window_s`` seconds (see the module docstring)."""

    def __init__(self, window_s: float, roll_sign: float, position_lag_s: float) -> None:
        self.window_s, self.roll_sign, self.position_lag_s = window_s, roll_sign, position_lag_s
        self._rows: dict[str, list[float]] = {key: [] for key in FIELDS}
        self._last_fix: tuple[float, float, float] | None = None
        self._track: tuple[float, ...] | None = None  # dead-reckoned NED position, m

    def clear(self) -> None:
        """Forget every row (a clock reset, a long silence)."""
        for key in FIELDS:
            self._rows[key].clear()
        self._last_fix = self._track = None

    def store(self, t: float, att: tuple[float, ...], pos: tuple[float, ...], vel: tuple[float, ...],
              accel_body: object, dt: float) -> None:
        """One valid sample (attitude, NED position and velocity, the IMU's body specific force or None)."""
        fix = (pos[0], pos[1], pos[2])
        down = pos[2] if fix != self._last_fix else math.nan  # only a new fix is a new height sample
        self._last_fix = fix
        north, east = self._dead_reckon(pos, vel, dt)
        row = (t, north, east, vel[0], vel[1], att[2], att[1], att[0] * self.roll_sign,
               down_acceleration(att, accel_body), down)
        for key, value in zip(FIELDS, row, strict=True):
            self._rows[key].append(value)
        if len(self._rows["t"]) > 4 * 40 * self.window_s:  # keep memory bounded (far above any sample rate)
            self._trim(t)

    def _dead_reckon(self, pos: tuple[float, ...], vel: tuple[float, ...], dt: float) -> tuple[float, ...]:
        """The boat's NED track (m from home) for the wave's phase (see the module docstring)."""
        gps = (pos[0] + vel[0] * self.position_lag_s, pos[1] + vel[1] * self.position_lag_s)
        if self._track is None or dt > GAP_S:  # across a gap the velocity is unknown: start again at the fix
            self._track = gps
        else:
            g = min(1.0, dt / TRACK_PULL_S)
            self._track = tuple(x + v * dt + g * (p - x - v * dt)
                                for x, v, p in zip(self._track, vel, gps, strict=False))
        return self._track

    def _trim(self, t: float) -> None:
        times = self._rows["t"]
        first = next((i for i, v in enumerate(times) if v >= t - self.window_s), len(times))
        for key in FIELDS:
            del self._rows[key][:first]

    def window(self, t: float) -> tuple[Window, tuple[float, float, float]] | None:
        """The window ending at ``t`` and its origin (autopilot time, north, east of its last sample); None with
        too few samples. Thinned to at most ``FIT_RATE_HZ``: the fit's cost grows with its samples, and a wave of
        3 s or more needs no more."""
        self._trim(t)
        times = self._rows["t"]
        if len(times) < MIN_ROWS:
            return None
        rate = (len(times) - 1) / max(times[-1] - times[0], 1e-9)
        step = max(1, round(rate / FIT_RATE_HZ))
        first = (len(times) - 1) % step  # the last sample always in
        arrays = {key: np.asarray(self._rows[key][first::step], float) for key in FIELDS}
        arrays["down"] = _last_in_blocks(np.asarray(self._rows["down"], float), first, step)
        origin = (t, float(arrays["north"][-1]), float(arrays["east"][-1]))
        for key in ("t", "north", "east"):  # referred to the window's end: the boat's time and place now
            arrays[key] = arrays[key] - arrays[key][-1]
        return Window(**arrays), origin
