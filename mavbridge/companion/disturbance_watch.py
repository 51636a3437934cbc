"""The companion's disturbance observer, period by period: what it is told of the command in effect, and when it
says that its estimate settled (``mavbridge.nmpc.disturbance`` holds the filter itself)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from mavbridge.nmpc.disturbance import DisturbanceObserver

IDLE = np.zeros(2)  # τ with the thrusters idle (disarmed, or neutral sent)


def observe_period(observer: DisturbanceObserver | None, nmpc: Any, state: Any, now_ms: int, tau: np.ndarray | None,
                   stale_s: float, log: Callable[[str], None]) -> None:
    """One control period: the observer compares the boat's state (when fresh) with the model's prediction under the
    command in effect since the last period (``tau`` is the one from now on; None: unknown, a pilot drives), and the
    NMPC's later solves predict with its estimate. One line when it settles."""
    if observer is None or not state.ready():
        return
    fresh = state.age_ms(now_ms) <= stale_s * 1000
    if observer.update(now_ms / 1000.0, state.vector(), tau if fresh else None, nmpc.model_wave()):
        log(f"disturbance settled at t = {now_ms / 1000:.1f} s: {observer.describe()} (estimated from the boat's "
            f"motion)")
    nmpc.set_disturbance(observer.estimate)
