"""The estimator's clock on the wave: the encounter frequency ω_e and an oscillator phase locked to it.

The slope's principal axis (a running NED covariance over 8 s) gives a scalar signal for the coarse
tracker (zero crossings by default, a normalised Belleter observer as an option); an oscillator at the
tracked ω_e runs the demodulating phase θ, and a frequency-locked loop on the common rotation of the
slope phasors pulls it onto ω_e (the rotation left, ``dw``, is added to ω_e and undone in the phasors).
ω_e is averaged in two 2 s stages (a surging hull wobbles the encounter phase); its spread, the
phasors' rotation and the agreement with the coarse tracker make the lock quality.
"""

from __future__ import annotations

import cmath
import math

from mavbridge.waves.filters import FrequencyTracker, ZeroCrossingTracker, lpf_gain
from mavbridge.waves.settings import EstimatorSettings
from mavbridge.waves.solve import principal_axis


class EncounterOscillator:
    """ω_e and the oscillator phase θ (rad) from the NED slope; ``lock_quality`` says how steady they are."""

    def __init__(self, s: EstimatorSettings) -> None:
        self.s = s
        self.tracker: FrequencyTracker | ZeroCrossingTracker
        if s.tracker == "belleter":
            self.tracker = FrequencyTracker(s.omega_init_rad_s, s.tracker_filter_rad_s, s.tracker_gain,
                                            s.omega_min_rad_s, s.omega_max_rad_s)
        else:
            self.tracker = ZeroCrossingTracker(s.omega_init_rad_s, s.omega_min_rad_s, s.omega_max_rad_s)
        self.theta, self.w_var = 0.0, 0.01
        self.omega_lo = self.w_mean = self.w_fast = s.omega_init_rad_s
        self.dw = self.dw_inst = 0.0
        self._cov = [1e-6, 0.0, 1e-6]
        self.axis = (1.0, 0.0)  # the slope's principal axis (N, E), sign kept continuous

    def advance(self, slope_n: float, slope_e: float, dt: float, fit_quality: float) -> None:
        """Principal slope axis → tracker → oscillator phase at the (low-passed) tracked ω_e.

        ``fit_quality`` (0..1, the share of the slope the sinusoid fits explain) weighs the phasors'
        pull against the coarse tracker's.
        """
        g = lpf_gain(dt, 8.0)
        cov = self._cov
        cov[0] += g * (slope_n * slope_n - cov[0])
        cov[1] += g * (slope_n * slope_e - cov[1])
        cov[2] += g * (slope_e * slope_e - cov[2])
        ang = principal_axis(*cov)
        u = (math.cos(ang), math.sin(ang))
        if u[0] * self.axis[0] + u[1] * self.axis[1] < 0:
            u = (-u[0], -u[1])
        self.axis = u
        omega = self.tracker.update(u[0] * slope_n + u[1] * slope_e, dt)
        # frequency-locked loop: the slope phasors' rotation pulls the oscillator, the tracker guides it
        if self._coarse_disagrees(omega):  # (re)acquisition: jump to the coarse tracker
            self.omega_lo = self.w_fast = self.w_mean = omega
            self.dw = self.dw_inst = 0.0
        else:
            q = fit_quality ** 2
            pull = (q * self.s.fll_gain * self.dw_inst
                    + (1.0 - 0.95 * q) * self.s.tracker_pull * (omega - self.omega_lo))
            self.omega_lo = min(self.s.omega_max_rad_s, max(self.s.omega_min_rad_s, self.omega_lo + dt * pull))
        self.theta = math.remainder(self.theta + self.omega_lo * dt, 2 * math.pi)

    def update_lock(self, prev: tuple[complex, complex], now: tuple[complex, complex], dt: float) -> None:
        """Rotation rate of the slope phasors (``prev`` → ``now``) = ω_e − ω_oscillator; ω_e averaged."""
        cross = prev[0].conjugate() * now[0] + prev[1].conjugate() * now[1]
        self.dw_inst = cmath.phase(cross) / dt if abs(cross) > 0 else 0.0
        self.dw += lpf_gain(dt, 1.5) * (self.dw_inst - self.dw)
        w = self.omega_lo + self.dw
        g = lpf_gain(dt, 2.0)  # two stages: averages out the phase wobble of a surging hull
        self.w_fast += g * (w - self.w_fast)
        self.w_mean += g * (self.w_fast - self.w_mean)
        self.w_var += lpf_gain(dt, 3.0) * ((self.w_fast - self.w_mean) ** 2 - self.w_var)

    def _coarse_disagrees(self, omega: float) -> bool:
        """True while the coarse tracker has few crossings yet, or has left the oscillator far behind."""
        crossings = getattr(self.tracker, "crossings", 99)
        if 1 <= crossings < 3:
            return True
        return crossings >= 3 and abs(omega - self.omega_lo - self.dw) > 0.15 * omega

    def lock_quality(self) -> float:
        """1 when ω_e is steady (relative std ≪ 1 %) and the phasors barely rotate, → 0 otherwise."""
        w = max(self.w_mean, 1e-3)
        rel_std = math.sqrt(max(self.w_var, 0.0)) / w
        rotation = abs(self.dw) * self.s.fit_tau_s
        agree = abs(self.tracker.omega / w - 1.0)
        return (math.exp(-((rel_std / 0.02) ** 2)) * math.exp(-((rotation / 0.5) ** 2))
                * math.exp(-((agree / 0.06) ** 2)))

    def steady(self) -> bool:
        """ω_e settled: its two averaging stages agree within 1 % (a Doppler point may be taken)."""
        return abs(self.w_fast - self.w_mean) <= 0.01 * self.w_mean
