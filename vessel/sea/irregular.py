"""Irregular seas as a sum of linear wave components, behind the ``WaveField`` interface of ``vessel.sea.waves``.

ζ(N, E, t) = Σᵢ aᵢ cos(ωᵢ t − kᵢ (N cos μᵢ + E sin μᵢ) + εᵢ)   (m, up positive; N, E in the NED frame)

with amplitude aᵢ (m), angular frequency ωᵢ (rad/s), wavenumber kᵢ (rad/m), travel direction μᵢ (NED,
rad, 0 = towards North) and phase εᵢ (rad). The surface gradient (∂ζ/∂N, ∂ζ/∂E) is the same sum with
aᵢ kᵢ (cos μᵢ, sin μᵢ) sin(·); evaluated at a moving point it already contains the encounter frequency.

The same formulas run on floats, numpy arrays (any broadcastable shapes) and CasADi symbols, so one
field drives the numeric plant and the NMPC's prediction model. :func:`synthesise` draws the components
from a spectrum and one integer seed: one random frequency inside each of N equal bins (the record
does not repeat every 2π/Δω), one random phase each, and for short-crested seas one random direction
each from the cos-2s spreading.

The hull does not feel waves much shorter than itself. :func:`hull_averaging_factor` gives each
component the mean of a plane wave over a disc with the area of the waterplane's bounding rectangle
(length L × beam B of the vessel parameters; radius R = √(L·B/π), 0.83 m for the Otter's 2.0 m × 1.08 m):
2·J₁(kR)/(kR). It is 1 for long waves (0.998 at the 56 m peak wave of Tp = 6 s) and falls to 0.5 near
λ ≈ 2.4 m. Applied to the amplitudes, it turns the point sea into the smoothed surface the hull rides
on, so elevation, slope and force stay consistent with each other.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np

from vessel.mathops import is_symbolic
from vessel.sea.spectra import sample_cos2s, spectrum, wavenumber

SLOPE_EPSILON = 1e-12  # keeps |∇ζ| away from 0 so atan(ρ)/ρ stays smooth (and differentiable) there
BIN_NODES = 17  # trapezoid nodes per bin for the bin energy ∫ S dω
CHUNK = 4096  # numeric evaluation: samples per block (bounds memory at samples × components)


@dataclass(frozen=True, eq=False)
class IrregularWaves:
    """A sum of linear wave components (see the module docstring); all arrays have one entry per component.

    ``roll_sign`` follows ``vessel.sea.waves.WaveField``: −1 (default) is the geometric surface-relative roll
    (the hull lies along the surface), +1 the paper's literal φ − α·cos ψ sign.
    """

    amplitude_m: np.ndarray
    frequency_rad_s: np.ndarray
    wavenumber_rad_m: np.ndarray
    direction_rad: np.ndarray
    phase_rad: np.ndarray
    roll_sign: float = -1.0
    _k_north: np.ndarray = field(init=False, repr=False)
    _k_east: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        arrays = [np.array(getattr(self, name), dtype=float) for name in
                  ("amplitude_m", "frequency_rad_s", "wavenumber_rad_m", "direction_rad", "phase_rad")]
        if len({a.shape for a in arrays}) != 1 or arrays[0].ndim != 1 or not all(np.all(np.isfinite(a))
                                                                                 for a in arrays):
            raise ValueError("IrregularWaves: component arrays must be finite, one-dimensional and equally long")
        for name, array in zip(("amplitude_m", "frequency_rad_s", "wavenumber_rad_m", "direction_rad",
                                "phase_rad"), arrays, strict=True):
            array.setflags(write=False)
            object.__setattr__(self, name, array)
        object.__setattr__(self, "_k_north", self.wavenumber_rad_m * np.cos(self.direction_rad))
        object.__setattr__(self, "_k_east", self.wavenumber_rad_m * np.sin(self.direction_rad))

    @property
    def n_components(self) -> int:
        """Number of wave components."""
        return int(self.amplitude_m.size)

    def attenuated(self, factor: np.ndarray) -> IrregularWaves:
        """The same sea with every amplitude multiplied by its factor (e.g. :func:`hull_averaging_factor`)."""
        return IrregularWaves(self.amplitude_m * np.asarray(factor, float), self.frequency_rad_s,
                              self.wavenumber_rad_m, self.direction_rad, self.phase_rad, self.roll_sign)

    def advanced(self, seconds: float) -> IrregularWaves:
        """The same sea ``seconds`` later: at time t it shows what this one shows at t + ``seconds``."""
        if seconds == 0.0:
            return self
        return IrregularWaves(self.amplitude_m, self.frequency_rad_s, self.wavenumber_rad_m, self.direction_rad,
                              np.mod(self.phase_rad + self.frequency_rad_s * seconds, 2 * math.pi), self.roll_sign)

    def slope_covariance(self) -> np.ndarray:
        """The surface slope's covariance at a fixed point, 2×2 NED (rad², small slopes): Σ ½ (aᵢ kᵢ)² dᵢ dᵢᵀ with
        dᵢ = (cos μᵢ, sin μᵢ), the sea's slope statistics that a boat's own motion estimates (the time average
        of the gradient's outer product over a long record, the components' frequencies being distinct)."""
        energy = 0.5 * (self.amplitude_m * self.wavenumber_rad_m) ** 2
        c, s = np.cos(self.direction_rad), np.sin(self.direction_rad)
        cross = float(np.sum(energy * c * s))
        return np.array([[float(np.sum(energy * c * c)), cross], [cross, float(np.sum(energy * s * s))]])

    # --- the WaveField interface -------------------------------------------------------------------

    def elevation(self, north: Any, east: Any, t: Any) -> Any:
        """ζ in m, up positive."""
        if is_symbolic(north, east, t):
            return ca.dot(ca.DM(self.amplitude_m), ca.cos(self._phase_symbolic(north, east, t)))
        return self._numeric(north, east, t, lambda ph: np.cos(ph) @ self.amplitude_m)

    def gradient(self, north: Any, east: Any, t: Any) -> tuple[Any, Any]:
        """(∂ζ/∂N, ∂ζ/∂E), dimensionless (m/m), NED."""
        if is_symbolic(north, east, t):
            s = ca.sin(self._phase_symbolic(north, east, t))
            return (ca.dot(ca.DM(self.amplitude_m * self._k_north), s),
                    ca.dot(ca.DM(self.amplitude_m * self._k_east), s))
        weights = np.stack([self.amplitude_m * self._k_north, self.amplitude_m * self._k_east], axis=1)
        both = self._numeric(north, east, t, lambda ph: np.sin(ph) @ weights, extra=(2,))
        return both[..., 0], both[..., 1]

    def slope_angles(self, north: Any, east: Any, t: Any) -> tuple[Any, Any]:
        """(α_N, α_E) in rad: uphill direction of ∇ζ, magnitude atan|∇ζ| (the regular wave's α, in 2-D)."""
        g_n, g_e = self.gradient(north, east, t)
        rho, angle = _slope_norm_and_angle(g_n, g_e)
        return g_n * angle / rho, g_e * angle / rho

    def force_per_weight(self, north: Any, east: Any, t: Any) -> tuple[Any, Any]:
        """−½·sin 2|α| pointing downhill (the paper's (m g/2)·sin 2α per weight, in 2-D), NED."""
        g_n, g_e = self.gradient(north, east, t)
        rho, angle = _slope_norm_and_angle(g_n, g_e)
        sin2 = ca.sin(2 * angle) if is_symbolic(angle) else np.sin(2 * angle)
        scale = -0.5 * sin2 / rho
        return g_n * scale, g_e * scale

    # --- evaluation helpers ------------------------------------------------------------------------

    def _phase_symbolic(self, north: Any, east: Any, t: Any) -> Any:
        """Phase column (one entry per component) for scalar CasADi inputs."""
        return (ca.DM(self.frequency_rad_s) * t - ca.DM(self._k_north) * north - ca.DM(self._k_east) * east
                + ca.DM(self.phase_rad))

    def _numeric(self, north: Any, east: Any, t: Any, reduce: Any, extra: tuple[int, ...] = ()) -> Any:
        """Evaluate ``reduce(phase[samples, components])`` block by block over broadcast inputs."""
        n, e, tt = np.broadcast_arrays(np.asarray(north, float), np.asarray(east, float), np.asarray(t, float))
        shape = n.shape
        n, e, tt = n.ravel(), e.ravel(), tt.ravel()
        out = np.empty((n.size, *extra))
        for start in range(0, n.size, CHUNK):
            sl = slice(start, start + CHUNK)
            phase = (np.multiply.outer(tt[sl], self.frequency_rad_s) - np.multiply.outer(n[sl], self._k_north)
                     - np.multiply.outer(e[sl], self._k_east) + self.phase_rad)
            out[sl] = reduce(phase)
        return out.reshape(shape + extra)[()]


def _slope_norm_and_angle(g_n: Any, g_e: Any) -> tuple[Any, Any]:
    """(ρ, atan ρ) with ρ = √(g_N² + g_E² + ε²): smooth at a flat point, equal to |∇ζ| to 1e-24 relative."""
    rho_sq = g_n * g_n + g_e * g_e + SLOPE_EPSILON**2
    if is_symbolic(g_n, g_e):
        rho = ca.sqrt(rho_sq)
        return rho, ca.atan(rho)
    rho = np.sqrt(rho_sq)
    return rho, np.arctan(rho)


def bessel_j1(x: np.ndarray, nodes: int = 256) -> np.ndarray:
    """J₁(x) from Bessel's integral (1/2π)∫cos(τ − x sin τ)dτ over one period (trapezoid: spectral accuracy)."""
    tau = np.linspace(-math.pi, math.pi, nodes, endpoint=False)
    xs = np.asarray(x, float)
    return np.cos(tau - np.multiply.outer(xs, np.sin(tau))).mean(axis=-1)


def hull_averaging_factor(k_rad_m: np.ndarray, length_m: float, beam_m: float) -> np.ndarray:
    """Mean of a plane wave over a disc of the waterplane rectangle's area L·B: 2 J₁(kR)/(kR), R = √(L B/π)."""
    x = np.asarray(k_rad_m, float) * math.sqrt(length_m * beam_m / math.pi)
    safe = np.where(x > 1e-8, x, 1.0)
    return np.where(x > 1e-8, 2 * bessel_j1(safe) / safe, 1.0 - x**2 / 8)


def synthesise(spectrum_name: str, hs_m: float, tp_s: float, gamma: float, travel_dir_rad: float,
               spreading_s: float, n_components: int, seed: int, depth_m: float | None = None,
               band: tuple[float, float] = (0.5, 4.0), g: float = 9.81, roll_sign: float = -1.0) -> IrregularWaves:
    """Draw a sea from a spectrum: N equal bins over ``band`` × ωp, one random ω per bin, aᵢ = √(2 ∫_bin S dω).

    Each amplitude carries its bin's exact energy (the integral, not S(ωᵢ)·Δω), so m0 of the
    synthesised sea equals the spectrum's m0 over the band whatever frequencies are drawn.
    Frequencies, then phases, then (when ``spreading_s`` > 0) directions are drawn from one
    ``numpy.random.default_rng(seed)``, so a long- and a short-crested sea of one seed share ωᵢ and εᵢ.
    ``spreading_s`` = 0 is long-crested (every component travels towards ``travel_dir_rad``).
    """
    wp = 2 * math.pi / tp_s
    edges = np.linspace(band[0] * wp, band[1] * wp, n_components + 1)
    d_omega = edges[1] - edges[0]
    rng = np.random.default_rng(seed)
    omega = edges[:-1] + rng.uniform(0.0, 1.0, n_components) * d_omega
    phase = rng.uniform(0.0, 2 * math.pi, n_components)
    if spreading_s > 0:
        direction = sample_cos2s(rng, n_components, travel_dir_rad, spreading_s)
    else:
        direction = np.full(n_components, float(travel_dir_rad))
    fine = np.linspace(0.0, 1.0, BIN_NODES)[None, :] * d_omega + edges[:-1, None]  # nodes inside each bin
    density = spectrum(spectrum_name, fine, hs_m, tp_s, gamma)
    bin_energy = np.sum(0.5 * (density[:, 1:] + density[:, :-1]), axis=1) * (d_omega / (BIN_NODES - 1))
    amplitude = np.sqrt(2 * bin_energy)
    return IrregularWaves(amplitude, omega, wavenumber(omega, depth_m, g), direction, phase, roll_sign)
