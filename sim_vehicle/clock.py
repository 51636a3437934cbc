"""Pacing simulated time against the wall clock: real time, N times faster, or as fast as possible."""

from __future__ import annotations

import time

MAX_LAG_S = 0.25  # wall seconds of lag after which pacing restarts instead of racing to catch up


class Pacer:
    """Keeps simulated time at ``speedup`` times wall-clock time (0 = unpaced)."""

    def __init__(self, speedup: float) -> None:
        self.speedup = speedup
        self._wall0 = time.monotonic()
        self._sim0 = 0.0

    def restart(self, sim_t: float) -> None:
        """Pace on from ``sim_t`` now (after simulated time was held): no racing to catch up."""
        self._wall0, self._sim0 = time.monotonic(), sim_t

    def wait_until(self, sim_t: float) -> None:
        """Sleep until the wall clock catches up with simulated time ``sim_t``."""
        if self.speedup <= 0:
            return
        target = self._wall0 + (sim_t - self._sim0) / self.speedup
        delay = target - time.monotonic()
        if delay < -MAX_LAG_S:
            self._wall0, self._sim0 = time.monotonic(), sim_t
        elif delay > 0:
            time.sleep(delay)
