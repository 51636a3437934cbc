"""How steady the solved wave is in the earth frame: the confidence's lock term where the hull heaves.

With heave, each solve gives the wave's true frequency ω and travel direction χ (NED) — properties of
the sea, not of the boat — so they stay put while the boat accelerates or turns, which
moves the encounter frequency ω_e. Whether ω_e is steady (the Doppler case's lock term) is then the wrong
question: the boat's own surge in the waves and the Direct controller's turns keep ω_e wandering by a few
per cent for tens of seconds while the solution is already right. This term asks instead whether ω and χ
have stayed put over the last few seconds: low-passed (``tau_s``) mean and mean squared deviation of ω,
and the low-passed phasor e^{iχ}, whose shortfall from unit length gives χ's spread (σ² ≈ 2(1 − |mean|)).
The phasor starts at half length, so steadiness is earned over about four time constants (12 s), never
given by a first answer: measured on the acceptance runs, earning it faster made the confident start
earlier but the runs no better (the first estimates are the worst ones). Not the phase origin ε: it is referred to the
autopilot's boot, so a 0.1 % wobble of ω moves it by a radian after an hour; its quality shows in the
phasors' signal-to-noise and consistency, which the confidence has anyway.
"""

from __future__ import annotations

import cmath
import math

from mavbridge.waves.filters import lpf_gain

OMEGA_REL_STD = 0.08  # relative spread of ω that takes the term to e^-1: 8 % moves the phase 20° over a 4 s horizon
DIRECTION_STD_RAD = math.radians(10.0)


class SolutionSteadiness:
    """Running steadiness (0..1) of the earth-frame wave solution; updated at most once per time stamp."""

    def __init__(self, tau_s: float = 3.0) -> None:
        self.tau_s = tau_s
        self.reset()

    def reset(self) -> None:
        """Forget everything (a restart, a gap, a mode change)."""
        self._t: float | None = None
        self._omega = 0.0
        self._omega_var = 1.0
        self._chi = 0j  # low-passed e^{iχ}
        self.value = 0.0

    def update(self, t_s: float, omega: float, travel_dir_rad: float) -> float:
        """Take the solution at ``t_s`` (a repeated or older stamp changes nothing); the steadiness."""
        if self._t is not None and t_s <= self._t:
            return self.value
        if not all(math.isfinite(v) for v in (t_s, omega, travel_dir_rad)):
            self.reset()  # nothing to trust: start earning again
            return self.value
        if self._t is not None and t_s - self._t > self.tau_s:
            self.reset()  # a gap (the heave solve dropped out): one answer after it is a first answer
        if self._t is None:
            self._omega, self._omega_var = omega, (2.0 * OMEGA_REL_STD * omega) ** 2
            self._chi = cmath.rect(0.5, travel_dir_rad)
        else:
            g = lpf_gain(t_s - self._t, self.tau_s)
            self._omega_var += g * ((omega - self._omega) ** 2 - self._omega_var)
            self._omega += g * (omega - self._omega)
            self._chi += g * (cmath.rect(1.0, travel_dir_rad) - self._chi)
        self._t = t_s
        self.value = self._score()
        return self.value

    def _score(self) -> float:
        rel = math.sqrt(max(self._omega_var, 0.0)) / max(abs(self._omega), 1e-6)
        sigma_chi = math.sqrt(2.0 * max(0.0, 1.0 - abs(self._chi)))
        return math.exp(-((rel / OMEGA_REL_STD) ** 2)) * math.exp(-((sigma_chi / DIRECTION_STD_RAD) ** 2))
