"""Which motion samples the estimator may trust, and whether the boat is manoeuvring.

An attitude counts when it is finite and not frozen (the same reading for more than 0.3 s is a stale
stream, not a calm sea). A turn or a heading jump changes the encounter frequency, so the estimator's
settling clock restarts: the heading's rate is watched over ``turn_filter_s`` (longer than a wave
period, so the hull's wave-induced yaw averages out) against ``turn_rate_rad_s``, and over 1 s against
``sharp_turn_rate_rad_s``. The NED velocity is low-passed (3 s) for the phase reference and averaged by
the same two 2 s stages as ω_e for the Doppler line (the mean speed, not the surge within each wave).
"""

from __future__ import annotations

import math

from mavbridge.waves.filters import finite, lpf_gain
from mavbridge.waves.settings import EstimatorSettings
from mavbridge.waves.source import MotionSample

FROZEN_S = 0.3  # an unchanged attitude for longer than this is a stale stream
JUMP_RAD = 0.35  # a heading step between two samples larger than this is a jump


class MotionWatch:
    """Attitude validity, turn detection and the navigation filters of the wave estimator."""

    def __init__(self, s: EstimatorSettings) -> None:
        self.s = s
        self.vel, self.pos = (0.0, 0.0), (0.0, 0.0)  # low-passed NED velocity (m/s), latest NED position (m)
        self.vel_two = ((0.0, 0.0), (0.0, 0.0))  # the two 2 s averaging stages of the NED velocity
        self._last_att: tuple[float, ...] | None = None
        self._frozen_s = 0.0
        self._psi_prev: float | None = None
        self._turn_rate = 0.0  # low-passed over turn_filter_s: slow course changes
        self._turn_fast = 0.0  # low-passed over 1 s: sharp turns

    def restart(self) -> None:
        """After a silence: forget the last attitude and heading (no frozen or turn verdict across it)."""
        self._last_att = None
        self._psi_prev = None

    def navigate(self, sample: MotionSample, dt: float) -> None:
        """Low-passed NED velocity (for the Doppler term) and the latest position."""
        vel = finite(sample.velocity_ned, 2)
        if vel is not None:
            g = lpf_gain(dt, 3.0)
            self.vel = (self.vel[0] + g * (vel[0] - self.vel[0]), self.vel[1] + g * (vel[1] - self.vel[1]))
            g = lpf_gain(dt, 2.0)
            v1 = self.vel_two[0]
            v1 = (v1[0] + g * (vel[0] - v1[0]), v1[1] + g * (vel[1] - v1[1]))
            v2 = self.vel_two[1]
            self.vel_two = (v1, (v2[0] + g * (v1[0] - v2[0]), v2[1] + g * (v1[1] - v2[1])))
        pos = finite(sample.position_ned, 2)
        if pos is not None:
            self.pos = pos

    def attitude(self, sample: MotionSample, dt: float) -> tuple[float, ...] | None:
        """(φ, θ, ψ) if finite and not frozen, else None (the caller restarts its settling clock)."""
        att = finite(sample.attitude, 3)
        if att is None:
            return None
        self._frozen_s = self._frozen_s + dt if att == self._last_att else 0.0
        self._last_att = att
        return None if self._frozen_s > FROZEN_S else att

    def manoeuvring(self, psi: float, dt: float) -> bool:
        """True when this heading sample shows a turn or a jump (the settling clock restarts)."""
        turned = False
        if self._psi_prev is not None:
            step = math.remainder(psi - self._psi_prev, 2 * math.pi)
            self._turn_rate += lpf_gain(dt, self.s.turn_filter_s) * (step / dt - self._turn_rate)
            self._turn_fast += lpf_gain(dt, 1.0) * (step / dt - self._turn_fast)
            turned = (abs(step) > JUMP_RAD or abs(self._turn_rate) > self.s.turn_rate_rad_s
                      or abs(self._turn_fast) > self.s.sharp_turn_rate_rad_s)
        self._psi_prev = psi
        return turned
