"""The heave the wave estimator sees: the vertical acceleration (IMU) and the GPS height, demodulated.

A hull that heaves with the sea carries the elevation in its vertical motion: a_D = (R·f)_D + g from the
IMU's specific force f (body FRD, the attitude's roll and pitch rotating it into NED), else the GPS down
position. Each is high-passed and fitted by a sinusoid at the estimator's oscillator phase; the
elevation phasor is −a_D/ω_e² (IMU) or −z (GPS, its lag undone), from whichever streamed in the last
second. Ratio and quadrature of slope against heave then give k and the travel direction (``solve``).
"""

from __future__ import annotations

import math

from mavbridge.waves.filters import MeanRemover, SinusoidFit, finite, lag_correction
from mavbridge.waves.settings import EstimatorSettings
from mavbridge.waves.source import MotionSample

GRAVITY = 9.81
HEAVE_NONE, HEAVE_IMU, HEAVE_GPS = 0.0, 1.0, 2.0  # extras['heave_source']
FRESH_S = 1.0  # a heave source counts while it streamed within this long


class HeaveFits:
    """Sinusoid fits of the high-passed vertical acceleration (IMU) and GPS down position."""

    def __init__(self, s: EstimatorSettings) -> None:
        self.s = s
        self._hp = {key: MeanRemover(s.mean_tau_s) for key in ("acc", "z")}
        self.fit = {key: SinusoidFit(s.fit_tau_s) for key in ("acc", "z")}
        self._last_acc_t = self._last_z_t = -math.inf

    def update(self, sample: MotionSample, att: tuple[float, ...], rotor: complex, t: float, dt: float) -> None:
        """Fit the vertical acceleration (IMU) and the GPS down position when they are there."""
        f = finite(sample.accel_body, 3)
        if f is not None:
            phi, th = att[0], att[1]
            a_down = (-math.sin(th) * f[0] + math.cos(th) * math.sin(phi) * f[1]
                      + math.cos(th) * math.cos(phi) * f[2] + GRAVITY)
            self.fit["acc"].update(self._hp["acc"].update(a_down, dt), rotor, dt)
            self._last_acc_t = t
        pos = finite(sample.position_ned, 3)
        if pos is not None:
            self.fit["z"].update(self._hp["z"].update(pos[2], dt), rotor, dt)
            self._last_z_t = t

    def elevation(self, t: float, omega_e: float, comp: complex) -> tuple[complex, float] | None:
        """Elevation phasor (from the IMU if streaming, else from the GPS height) and its source."""
        if t - self._last_acc_t < FRESH_S and self.fit["acc"].samples > 0:
            return self.fit["acc"].X * comp / (omega_e * omega_e), HEAVE_IMU
        if t - self._last_z_t < FRESH_S and self.fit["z"].samples > 0:
            return -self.fit["z"].X * comp * lag_correction(omega_e, self.s.position_lag_s), HEAVE_GPS
        return None
