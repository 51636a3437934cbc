"""The sea's slope statistics from the hull's motion: the NED covariance that sets the expected roll.

An irregular sea cannot be predicted wave by wave from the boat alone, but its statistics can be
measured: the hull's roll and pitch (each divided by the hull's gain to the slope, ``calibration``), less
their running means in the hull's frame (its trim and list: a hull under way or loaded unevenly sits at an
angle no wave makes; ``TRIM_TAU_S``), rotated by the heading into NED, give the surface slope the hull follows;
its running covariance C (2×2, rad², NED) over ``tau_s`` says how much a hull at heading ψ will roll,
E[φ²] ≈ yᵀ C y with y = (−sin ψ, cos ψ) the body y axis — beam seas roll it, head and following seas barely
(``mavbridge.nmpc.sea_spread`` turns C into the NMPC's expected-roll term).

C is offered only after ``min_s`` of valid attitude samples (NaN and frozen attitudes do not count; a
silence longer than the estimator's ``max_gap_s`` starts the count again) and when the slope is large
enough to be a sea (above the attitude noise: ``NOISE_FLOOR_RAD``). Turns do not reset it: the
statistics of the surface in NED do not depend on the boat's heading (only through the encounter
frequency, which moves the hull's response a little); the trim means are in the hull's frame, so a turn
leaves them alone.
"""

from __future__ import annotations

import math

import numpy as np

from mavbridge.waves.filters import lpf_gain

SPREAD_TAU_S = 60.0  # time constant of the running covariance: several wave groups
SPREAD_MIN_S = 30.0  # valid observation needed before the covariance is offered (5 periods of a 6 s sea)
TRIM_TAU_S = 30.0  # time constant of the hull-frame means taken off first: many wave periods (a change of speed
# leaves a transient of about a sixth of the trim step squared, fading over a minute or two)
# an RMS slope below this is no sea: the default 0.2° attitude noise on roll and pitch alone gives 0.005 rad
NOISE_FLOOR_RAD = 0.01


def _young_gain(dt: float, tau_s: float, age_s: float) -> float:
    """A running mean's blend factor over ``tau_s`` that is about a plain mean while it is younger than that."""
    return lpf_gain(dt, min(tau_s, max(age_s, dt)))


class SlopeSpread:
    """Running NED covariance of the slope the hull follows; ``covariance`` answers None until known."""

    def __init__(self, tau_s: float = SPREAD_TAU_S, min_s: float = SPREAD_MIN_S) -> None:
        self.tau_s, self.min_s = tau_s, min_s
        self._c = [0.0, 0.0, 0.0]  # (nn, en, ee), rad²
        self._trim = [0.0, 0.0]  # running means of (across, along), rad, hull frame
        self._trim_s = 0.0  # how long the means have run (a plain mean while young)
        self.observed_s = 0.0

    def restart(self) -> None:
        """After a long silence: the count of valid observation starts again, and the trim means' age with it
        (their values are where they start from: a silence often comes with a change of speed, and so of trim)."""
        self.observed_s = 0.0
        self._trim_s = 0.0

    def update(self, across: float, along: float, psi: float, dt: float) -> None:
        """One valid sample: the hull's attitude (rad) across and along it with the hull gains undone, as measured
        (its trim and list are taken off here, nowhere before), the heading ψ (rad); ``dt`` s after the previous
        sample."""
        self._trim_s += dt
        g_trim = _young_gain(dt, TRIM_TAU_S, self._trim_s)
        trim = self._trim
        trim[0] += g_trim * (across - trim[0])
        trim[1] += g_trim * (along - trim[1])
        across, along = across - trim[0], along - trim[1]
        c_psi, s_psi = math.cos(psi), math.sin(psi)
        slope_n, slope_e = along * c_psi - across * s_psi, along * s_psi + across * c_psi
        self.observed_s += dt
        g = _young_gain(dt, self.tau_s, self.observed_s)
        c = self._c
        c[0] += g * (slope_n * slope_n - c[0])
        c[1] += g * (slope_e * slope_n - c[1])
        c[2] += g * (slope_e * slope_e - c[2])

    def covariance(self, min_slope_rad: float) -> np.ndarray | None:
        """C (2×2, rad², NED) once ``min_s`` of valid samples are in and the RMS slope ≥ ``min_slope_rad``."""
        floor = max(min_slope_rad, NOISE_FLOOR_RAD)
        if self.observed_s < self.min_s or math.sqrt(max(self._c[0] + self._c[2], 0.0)) < floor:
            return None
        c_nn, c_en, c_ee = self._c
        return np.array([[c_nn, c_en], [c_en, c_ee]])
