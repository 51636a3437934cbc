"""The NMPC's wave as run-time numbers: a regular wave field whose parameters are CasADi symbols.

The companion plans against an *estimated* wave that changes during a run, so the prediction model is
built once with this field, its seven numbers taken from the parameter vector's ``wave`` block, and one
built solver serves any regular wave (or calm water). The formulas are those of
``vessel.sea.waves.RegularWaves`` with its derived numbers as inputs:

    ζ = (H/2)·sin(ω t − k (N cos χ + E sin χ) + ε),   α = atan(∂ζ/∂s) along the travel direction χ,

slope angles (α cos χ, α sin χ) and force per weight −½·sin 2α along χ (NED), roll sign s as in
RegularWaves. The operations happen in the same order as in RegularWaves, so for the same wave the
model's numbers are those of the baked-in field (a test checks this).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from mavbridge.nmpc.layout import WAVE_NAMES
from vessel import CalmWater, RegularWaves
from vessel.mathops import arctan, ops

# No wave: zero height makes every term zero (the direction and numbers are then irrelevant but finite).
CALM_PARAMETERS = np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0])


@dataclass(frozen=True)
class ParametricRegularWaves:
    """A RegularWaves-like WaveField whose numbers may be CasADi symbols (names as in ``WAVE_NAMES``)."""

    height_m: Any
    wavenumber_rad_per_m: Any
    frequency_rad_per_s: Any
    cos_travel_dir: Any
    sin_travel_dir: Any
    phase_rad: Any
    roll_sign: Any

    @classmethod
    def from_vector(cls, wave: Any) -> ParametricRegularWaves:
        """The field from a 7-element vector (a CasADi symbol block or numbers) ordered as WAVE_NAMES."""
        return cls(*(wave[i] for i in range(len(WAVE_NAMES))))

    def _xp(self, *values: Any) -> Any:
        return ops(*values, self.height_m, self.frequency_rad_per_s)

    def _phase(self, north: Any, east: Any, t: Any) -> Any:
        s = north * self.cos_travel_dir + east * self.sin_travel_dir
        return self.frequency_rad_per_s * t - self.wavenumber_rad_per_m * s + self.phase_rad

    def elevation(self, north: Any, east: Any, t: Any) -> Any:
        """ζ, m."""
        return 0.5 * self.height_m * self._xp(north, east, t).sin(self._phase(north, east, t))

    def slope_along_travel(self, north: Any, east: Any, t: Any) -> Any:
        """α = atan(∂ζ/∂s), rad, rising along the direction of travel."""
        gradient = -0.5 * self.height_m * self.wavenumber_rad_per_m * self._xp(north, east, t).cos(
            self._phase(north, east, t))
        return arctan(gradient)

    def slope_angles(self, north: Any, east: Any, t: Any) -> tuple[Any, Any]:
        """(α cos χ, α sin χ), rad, NED."""
        alpha = self.slope_along_travel(north, east, t)
        return alpha * self.cos_travel_dir, alpha * self.sin_travel_dir

    def force_per_weight(self, north: Any, east: Any, t: Any) -> tuple[Any, Any]:
        """−½·sin 2α along the travel direction (downhill), NED, per unit weight."""
        alpha = self.slope_along_travel(north, east, t)
        f = -0.5 * self._xp(north, east, t).sin(2 * alpha)
        return f * self.cos_travel_dir, f * self.sin_travel_dir


def _number(value: float, name: str, minimum: float = -math.inf, strict: bool = False) -> float:
    """``value`` as a finite float at or above ``minimum`` (above it when ``strict``), else ValueError."""
    number = float(value)
    if not math.isfinite(number) or number < minimum or (strict and number == minimum):
        allowed = "any finite value" if minimum == -math.inf else f"{'>' if strict else '>='} {minimum:g}"
        raise ValueError(f"waves.{name}: {value!r} is not allowed; allowed {allowed}")
    return number


def wave_parameters(waves: RegularWaves | CalmWater | None) -> np.ndarray:
    """The ``wave`` parameter block for a regular wave, calm water or None (no wave: calm)."""
    if waves is None or isinstance(waves, CalmWater):
        return CALM_PARAMETERS.copy()
    if not isinstance(waves, RegularWaves):
        raise TypeError(f"waves: expected RegularWaves, CalmWater or None, got {type(waves).__name__}")
    _number(waves.height_m, "height_m", 0.0)
    _number(waves.length_m, "length_m", 0.0, strict=True)
    _number(waves.period_s, "period_s", 0.0, strict=True)
    chi = _number(waves.travel_dir_rad, "travel_dir_rad")
    phase = _number(waves.phase_rad, "phase_rad")
    return np.array([waves.height_m, waves.wavenumber, waves.frequency, math.cos(chi), math.sin(chi), phase,
                     waves.roll_sign])


def is_parametric(waves: object) -> bool:
    """True for the wave fields the parametric model represents exactly (regular waves and calm water)."""
    return waves is None or isinstance(waves, (RegularWaves, CalmWater))
