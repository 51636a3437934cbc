"""From demodulated phasors to one regular wave: the pitch–roll-buoy algebra, pure functions.

Phasors are complex amplitudes X of signals x(t) = Re(X·e^{iθ(t)}) at the tracked encounter phase θ.
For the estimate's wave ζ = a·sin Φ, Φ = ω t − k (N cos χ + E sin χ) + ε, at the boat:

* elevation phasor Z = −i·a·e^{i(Φ−θ)}, and the NED slope phasor S = −a·k·e^{i(Φ−θ)}·(cos χ, sin χ), so
  i·S / Z = k·(cos χ, sin χ): a real vector whose length is k (no dispersion relation) and whose
  direction is the travel direction — the 180° ambiguity is resolved by the quadrature of slope
  against heave; its imaginary part measures how far the data are from one long-crested wave;
* the encounter frequency is ω_e = ω − k·(V·d) for over-ground velocity V and travel direction d,
  so ω = ω_e + k·(V·d).
"""

from __future__ import annotations

import cmath
import math
from dataclasses import dataclass


@dataclass(frozen=True)
class WaveSolution:
    """One regular wave solved from phasors (SI, rad, NED; phase_now = Φ at the phasors' time)."""

    amplitude_m: float
    wavenumber: float
    travel_dir_rad: float
    omega: float
    phase_now: float
    consistency: float  # 0 = exactly one long-crested wave .. 1 = no such wave in the data


def principal_axis(c_nn: float, c_ne: float, c_ee: float) -> float:
    """Angle (rad, NED, in (−π/2, π/2]) of the major axis of a 2×2 covariance."""
    return 0.5 * math.atan2(2.0 * c_ne, c_nn - c_ee)


def solve_with_heave(slope_n: complex, slope_e: complex, elevation: complex, omega_e: float,
                     v_north: float, v_east: float, theta: float) -> WaveSolution | None:
    """The wave from slope and elevation phasors (see the module docstring); None if Z is zero."""
    if abs(elevation) < 1e-12:
        return None
    vn = 1j * slope_n / elevation
    ve = 1j * slope_e / elevation
    k_n, k_e = vn.real, ve.real
    k = math.hypot(k_n, k_e)
    size = math.sqrt(abs(vn) ** 2 + abs(ve) ** 2)
    if k < 1e-9 or size < 1e-9:
        return None
    consistency = math.hypot(vn.imag, ve.imag) / size
    chi = math.atan2(k_e, k_n)
    omega = omega_e + k_n * v_north + k_e * v_east
    phase_now = theta + cmath.phase(elevation) + math.pi / 2
    return WaveSolution(abs(elevation), k, chi, omega, phase_now, consistency)


def solve_slope_only(slope_n: complex, slope_e: complex, travel_dir_rad: float, wavenumber: float,
                     omega: float, theta: float) -> WaveSolution | None:
    """The wave from slope phasors alone, once k and the travel direction are known (from Doppler)."""
    d_n, d_e = math.cos(travel_dir_rad), math.sin(travel_dir_rad)
    along = d_n * slope_n + d_e * slope_e  # = −a·k·e^{i(Φ−θ)}
    across = -d_e * slope_n + d_n * slope_e
    if wavenumber <= 0 or abs(along) < 1e-12:
        return None
    consistency = abs(across) / math.hypot(abs(along), abs(across))
    phase_now = theta + cmath.phase(along) + math.pi
    return WaveSolution(abs(along) / wavenumber, wavenumber, travel_dir_rad, omega, phase_now, consistency)


def phase_offset(solution: WaveSolution, t_s: float, north: float, east: float) -> float:
    """ε of ζ = a·sin(ω t − k (N cos χ + E sin χ) + ε), given Φ at time ``t_s`` and position (N, E)."""
    s = north * math.cos(solution.travel_dir_rad) + east * math.sin(solution.travel_dir_rad)
    eps = solution.phase_now - solution.omega * t_s + solution.wavenumber * s
    return math.remainder(eps, 2 * math.pi)


def plausible(sol: WaveSolution, wavelength_min_m: float, wavelength_max_m: float) -> bool:
    """Wavelength within [min, max] m, a positive true frequency, all finite."""
    ok = all(math.isfinite(v) for v in (sol.amplitude_m, sol.wavenumber, sol.omega, sol.phase_now))
    return ok and sol.omega > 0 and wavelength_min_m <= 2 * math.pi / sol.wavenumber <= wavelength_max_m
