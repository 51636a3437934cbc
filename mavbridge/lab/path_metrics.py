"""How a path went to its waypoint: overshoot beyond it and loops around it (NED metres, north/east).

Two figures a skipper would judge a run by, besides roll and time (issue 29's "no wandering"):

* ``overshoot_m`` — how far the boat went past the waypoint along the line from the start: the largest
  (p − w)·u over the path, u the unit vector from the start to the waypoint w; 0 when it never passed it.
* ``loops_around`` — how many times the path wound around the waypoint: the largest net angle the bearing
  from the waypoint to the boat turns through, in whole turns (|Δ| summed with sign, so a zig-zag does not
  count), taken while the boat is within ``radius_m`` of it. A boat that circles the waypoint before
  entering its acceptance circle scores 1 per circle; a straight approach scores 0.

Pure numpy on the logged path (the simulator's true state, or the companion's own estimate).
"""

from __future__ import annotations

import math

import numpy as np

LOOP_RADIUS_M = 25.0  # loops closer than this to the waypoint count (the 25 m)


def overshoot_m(north: np.ndarray, east: np.ndarray, start: tuple[float, float],
                waypoint: tuple[float, float]) -> float:
    """Largest distance (m) the path went beyond the waypoint along the start→waypoint line; 0 if never."""
    n, e = np.asarray(north, float), np.asarray(east, float)
    line = np.array([waypoint[0] - start[0], waypoint[1] - start[1]])
    length = float(np.hypot(*line))
    if n.size == 0 or length < 1e-9:
        return 0.0
    u = line / length
    beyond = (n - waypoint[0]) * u[0] + (e - waypoint[1]) * u[1]
    return max(0.0, float(np.max(beyond)))


def loops_around(north: np.ndarray, east: np.ndarray, waypoint: tuple[float, float],
                 radius_m: float = LOOP_RADIUS_M) -> float:
    """Whole turns (≥ 0, one decimal's worth of precision) the path made around the waypoint within
    ``radius_m``: the largest |net swept angle| / 2π over each stretch spent inside that radius."""
    dn = np.asarray(north, float) - waypoint[0]
    de = np.asarray(east, float) - waypoint[1]
    inside = np.hypot(dn, de) <= radius_m
    bearing = np.arctan2(de, dn)
    best = 0.0
    swept = 0.0
    for i in range(1, bearing.size):
        if not (inside[i] and inside[i - 1]):
            swept = 0.0
            continue
        swept += math.remainder(float(bearing[i] - bearing[i - 1]), 2 * math.pi)
        best = max(best, abs(swept))
    return best / (2 * math.pi)


def path_figures(north: np.ndarray, east: np.ndarray, start: tuple[float, float],
                 waypoint: tuple[float, float]) -> dict[str, float]:
    """The two figures for metrics.json: ``overshoot_m`` and ``loops_around_waypoint`` (rounded)."""
    return {"overshoot_m": round(overshoot_m(north, east, start, waypoint), 2),
            "loops_around_waypoint": round(loops_around(north, east, waypoint), 2)}
