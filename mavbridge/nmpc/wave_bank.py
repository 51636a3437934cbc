"""A phase-resolved irregular sea for the NMPC's model: K long-crested components as run-time numbers.

The ``bank`` parameter block (``layout``, present only when ``NmpcConfig.wave_components`` K > 0) holds a
weight w₀ (0..1), the time t_f (s, autopilot clock) it fades from and the fade time τ_f (s), then, per
component i, the amplitude aᵢ (m), angular frequency ωᵢ (rad/s), wavenumber kᵢ (rad/m), cos μᵢ, sin μᵢ (μ the
NED travel direction) and phase εᵢ (rad, absolute on the autopilot clock):

    ζ_b(N, E, t) = w(t) Σᵢ aᵢ cos(ωᵢ t − kᵢ (N cos μᵢ + E sin μᵢ) + εᵢ),   w(t) = w₀ / (1 + ((t − t_f)/τ_f)²)

— the convention of ``vessel.sea.irregular.IrregularWaves`` and of ``PhasePredictor.bank_arrays``. The model
predicts in the sum of this sea and the regular wave of the ``wave`` block (whose ``roll_sign`` it uses):
their surface gradients add, and the slope angles and the force per weight follow from the total gradient
∇ζ by IrregularWaves' formulas (α = ∇ζ·atan ρ/ρ, F/mg = −½ sin 2 atan ρ · ∇ζ/ρ, ρ = √(|∇ζ|² + ε²)), so given
the plant's own components (and a calm regular wave) the model's slope and force are the simulator's.
Evaluated at each stage's time and predicted position, the encounter frequency comes for free. The fade is
there because a fitted bank predicts well only a second or two past its fit (``PhasePredictor.skill``): beyond
that its waves would be planned against as if certain; w(t) takes them out smoothly (half weight τ_f after t_f),
and the statistics term (``roll_spread``) speaks for the sea there. A very long τ_f is no fade.
Built with CasADi operations only: it works on SX/MX symbols and on DM numbers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from mavbridge.nmpc.layout import BANK_HEADER, WAVE_NAMES, bank_size
from mavbridge.nmpc.wave_model import ParametricRegularWaves
from vessel.sea.irregular import SLOPE_EPSILON

BANK_ARRAYS = ("amplitude_m", "frequency_rad_s", "wavenumber_rad_m", "direction_rad", "phase_rad")
H = len(BANK_HEADER)
NO_FADE_S = 1e12  # a fade time that is no fade (below rounding for clocks under 10⁴ s)


def no_bank(components: int) -> np.ndarray:
    """The bank block with no sea in it (weight 0, amplitudes 0, finite numbers elsewhere)."""
    block = np.zeros(bank_size(components))
    if components > 0:
        block[2] = NO_FADE_S
        block[H + 3 * components:H + 4 * components] = 1.0  # cos μ = 1: a valid direction
    return block


def bank_parameters(arrays: dict[str, np.ndarray] | None, components: int, weight: float = 1.0,
                    fade_from_s: float = 0.0, fade_s: float = NO_FADE_S) -> np.ndarray:
    """The bank block from ``PhasePredictor.bank_arrays``-style arrays (amplitude m, ω rad/s, k rad/m, direction
    rad NED, phase rad; padded or cut to K entries, the first K kept), its weight and fade (see the module
    docstring; by default none), or ``no_bank`` for None or weight 0."""
    if arrays is None or weight <= 0 or components <= 0:
        return no_bank(components)
    if not (math.isfinite(fade_from_s) and math.isfinite(fade_s) and fade_s > 0):
        raise ValueError(f"wave bank: fade from {fade_from_s!r} s over {fade_s!r} s; allowed finite, fade > 0")
    values = {}
    for name in BANK_ARRAYS:
        given = np.asarray(arrays[name], float).ravel()[:components]
        if not np.all(np.isfinite(given)):
            raise ValueError(f"wave bank: {name} has non-finite values")
        values[name] = np.pad(given, (0, components - given.size))
    if np.any(values["amplitude_m"] < 0) or not np.isfinite(weight) or weight > 1:
        raise ValueError(f"wave bank: amplitudes must be >= 0 and the weight in [0, 1], got {weight!r}")
    direction = values["direction_rad"]
    return np.concatenate([[weight, fade_from_s, fade_s], values["amplitude_m"], values["frequency_rad_s"],
                           values["wavenumber_rad_m"], np.cos(direction), np.sin(direction), values["phase_rad"]])


@dataclass(frozen=True)
class ParametricSea:
    """The regular wave of the ``wave`` block plus the K-component bank (see the module docstring)."""

    regular: ParametricRegularWaves
    weight: Any
    fade_from_s: Any
    fade_s: Any
    amplitude: Any  # K-vectors (CasADi) from here on
    frequency: Any
    wavenumber: Any
    cos_dir: Any
    sin_dir: Any
    phase: Any

    @classmethod
    def from_vector(cls, wave: Any, components: int) -> ParametricSea:
        """The field from the model's ``wave`` input: the 7 regular numbers, then the bank block of K components."""
        n = len(WAVE_NAMES)
        regular = ParametricRegularWaves.from_vector(wave[0:n])
        arrays = [wave[n + H + j * components:n + H + (j + 1) * components] for j in range(6)]
        return cls(regular, *(wave[n + i] for i in range(H)), *arrays)

    def weight_at(self, t: Any) -> Any:
        """w(t) = w₀ / (1 + ((t − t_f)/τ_f)²)."""
        lead = (t - self.fade_from_s) / self.fade_s
        return self.weight / (1 + lead * lead)

    @property
    def roll_sign(self) -> Any:
        """The regular wave block's roll sign (see ``vessel.sea.waves.WaveField``)."""
        return self.regular.roll_sign

    def _phases(self, north: Any, east: Any, t: Any) -> Any:
        return self.frequency * t - (self.wavenumber * self.cos_dir) * north - (self.wavenumber * self.sin_dir) * east \
            + self.phase

    def elevation(self, north: Any, east: Any, t: Any) -> Any:
        """ζ, m: the regular wave's plus the bank's."""
        bank = ca.dot(self.amplitude, ca.cos(self._phases(north, east, t)))
        return self.regular.elevation(north, east, t) + self.weight_at(t) * bank

    def gradient(self, north: Any, east: Any, t: Any) -> tuple[Any, Any]:
        """(∂ζ/∂N, ∂ζ/∂E) of the sum, NED."""
        s = ca.sin(self._phases(north, east, t))
        b_n = ca.dot(self.amplitude * self.wavenumber * self.cos_dir, s)
        b_e = ca.dot(self.amplitude * self.wavenumber * self.sin_dir, s)
        r = self.regular
        g_s = -0.5 * r.height_m * r.wavenumber_rad_per_m * ca.cos(r._phase(north, east, t))
        w = self.weight_at(t)
        return g_s * r.cos_travel_dir + w * b_n, g_s * r.sin_travel_dir + w * b_e

    def slope_angles(self, north: Any, east: Any, t: Any) -> tuple[Any, Any]:
        """(α_N, α_E), rad: uphill direction of ∇ζ, magnitude atan|∇ζ|."""
        g_n, g_e = self.gradient(north, east, t)
        rho = ca.sqrt(g_n * g_n + g_e * g_e + SLOPE_EPSILON**2)
        angle = ca.atan(rho)
        return g_n * angle / rho, g_e * angle / rho

    def force_per_weight(self, north: Any, east: Any, t: Any) -> tuple[Any, Any]:
        """−½·sin 2|α| pointing downhill, NED, per unit weight."""
        g_n, g_e = self.gradient(north, east, t)
        rho = ca.sqrt(g_n * g_n + g_e * g_e + SLOPE_EPSILON**2)
        scale = -0.5 * ca.sin(2 * ca.atan(rho)) / rho
        return g_n * scale, g_e * scale


def model_field(wave: Any, components: int) -> Any:
    """The NMPC's wave field from its ``wave`` input: the regular wave alone (K = 0, today's model exactly) or
    the regular wave plus the K-component bank."""
    if components <= 0:
        return ParametricRegularWaves.from_vector(wave)
    return ParametricSea.from_vector(wave, components)
