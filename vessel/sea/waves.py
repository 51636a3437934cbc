"""Wave fields behind one small interface: calm water and the paper's regular (sinusoidal) wave.

A wave field answers, at a NED horizontal position (north, east) in m and a time t in s:
elevation ζ (m, up positive), the surface slope as an angle vector (α_N, α_E) in rad (uphill direction,
magnitude = slope angle), and the horizontal wave force per unit weight (f_N, f_E) in the NED frame.
Every method works on floats, numpy arrays and CasADi symbols alike, so the same field drives the
simulator's plant and the controller's prediction model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Protocol

from vessel.config import ConfigError, bounded
from vessel.mathops import arctan, ops

BREAKING_STEEPNESS = 1 / 7  # H/λ above which a regular wave breaks


class WaveField(Protocol):
    """What the vessel model needs to know about the sea surface (NED, SI units)."""

    roll_sign: float  # +1: the paper's φ − α·cos ψ convention; −1: geometric surface-relative roll

    def elevation(self, north: Any, east: Any, t: Any) -> Any:
        """Surface elevation ζ in m, up positive."""
        ...

    def slope_angles(self, north: Any, east: Any, t: Any) -> tuple[Any, Any]:
        """Slope-angle vector (α_N, α_E) in rad: uphill direction, magnitude = slope angle."""
        ...

    def force_per_weight(self, north: Any, east: Any, t: Any) -> tuple[Any, Any]:
        """Horizontal wave force divided by the vessel's weight m·g, NED (north, east), dimensionless."""
        ...


@dataclass(frozen=True)
class CalmWater:
    """Flat, still water: no elevation, no slope, no force."""

    roll_sign: float = 1.0

    def elevation(self, north: Any, east: Any, t: Any) -> Any:
        """Zero elevation everywhere."""
        return 0 * north

    def slope_angles(self, north: Any, east: Any, t: Any) -> tuple[Any, Any]:
        """Zero slope everywhere."""
        return 0 * north, 0 * north

    def force_per_weight(self, north: Any, east: Any, t: Any) -> tuple[Any, Any]:
        """Zero force everywhere."""
        return 0 * north, 0 * north


@dataclass(frozen=True)
class RegularWaves:
    """The paper's long-crested sinusoid, travelling towards NED direction ``travel_dir_rad``.

    ζ = (H/2)·sin(ω t − k s + ε), s = north·cos χ + east·sin χ, k = 2π/λ, ω = 2π/T. The paper's
    f(y, t) = (H/2)·sin(2πy/λ + 2πt/T) (its printed formula lacks the sin) is χ = −π/2: travelling West,
    coming from the East. α = atan(∂ζ/∂s) is the slope angle rising along the travel direction.
    The lateral force is the paper's (m·g/2)·sin 2α, pointing downhill.
    """

    height_m: float = bounded(1.75, 0.0, 30.0, "m", "crest-to-trough height H")
    length_m: float = bounded(35.0, 1.0, 2000.0, "m", "wavelength λ")
    period_s: float = bounded(6.0, 0.5, 60.0, "s", "wave period T")
    travel_dir_rad: float = bounded(-math.pi / 2, -2 * math.pi, 2 * math.pi, "rad",
                                    "NED direction the waves travel towards (0 = North)")
    paper_roll_sign: bool = True
    phase_rad: float = bounded(0.0, -1e6, 1e6, "rad", "phase offset ε of ζ = (H/2)·sin(ωt − k s + ε)")

    def __post_init__(self) -> None:
        if self.height_m / self.length_m > BREAKING_STEEPNESS:
            raise ConfigError(f"height_m: {self.height_m:g} m breaks on a {self.length_m:g} m wave; "
                              f"allowed [0, {self.length_m * BREAKING_STEEPNESS:.3g}] m (H/λ <= 1/7)")

    @property
    def roll_sign(self) -> float:
        """+1 for the paper's literal sign, −1 for the geometric surface-relative roll."""
        return 1.0 if self.paper_roll_sign else -1.0

    @property
    def wavenumber(self) -> float:
        """k = 2π/λ in rad/m."""
        return 2 * math.pi / self.length_m

    @property
    def frequency(self) -> float:
        """ω = 2π/T in rad/s."""
        return 2 * math.pi / self.period_s

    def _phase(self, north: Any, east: Any, t: Any) -> Any:
        s = north * math.cos(self.travel_dir_rad) + east * math.sin(self.travel_dir_rad)
        phase = self.frequency * t - self.wavenumber * s
        return phase + self.phase_rad if self.phase_rad else phase  # no extra term: paper runs bit-identical

    def elevation(self, north: Any, east: Any, t: Any) -> Any:
        """ζ = (H/2)·sin(ωt − k s), m."""
        return 0.5 * self.height_m * ops(north, east, t).sin(self._phase(north, east, t))

    def slope_along_travel(self, north: Any, east: Any, t: Any) -> Any:
        """α = atan(∂ζ/∂s), rad, rising along the direction of travel."""
        gradient = -0.5 * self.height_m * self.wavenumber * ops(north, east, t).cos(
            self._phase(north, east, t))
        return arctan(gradient)

    def slope_angles(self, north: Any, east: Any, t: Any) -> tuple[Any, Any]:
        """(α cos χ, α sin χ), rad."""
        alpha = self.slope_along_travel(north, east, t)
        return alpha * math.cos(self.travel_dir_rad), alpha * math.sin(self.travel_dir_rad)

    def force_per_weight(self, north: Any, east: Any, t: Any) -> tuple[Any, Any]:
        """−½·sin 2α along the travel direction (downhill), NED."""
        alpha = self.slope_along_travel(north, east, t)
        f = -0.5 * ops(north, east, t).sin(2 * alpha)
        return f * math.cos(self.travel_dir_rad), f * math.sin(self.travel_dir_rad)


def surface_relative_attitude(waves: WaveField, phi: Any, theta: Any, psi: Any,
                              alpha_n: Any, alpha_e: Any) -> tuple[Any, Any]:
    """The paper's β roll and pitch: attitude relative to the local surface, generalised to any direction.

    β_θ = θ − (α_N cos ψ + α_E sin ψ); β_φ = φ − s·(α_E cos ψ − α_N sin ψ), s = waves.roll_sign.
    For the paper's waves (χ = −π/2, s = +1) this is exactly (φ − α cos ψ, θ − α sin ψ).
    """
    xp = ops(phi, theta, psi, alpha_n, alpha_e)
    c, s = xp.cos(psi), xp.sin(psi)
    beta_theta = theta - (alpha_n * c + alpha_e * s)
    beta_phi = phi - waves.roll_sign * (alpha_e * c - alpha_n * s)
    return beta_phi, beta_theta
