"""Wind on the Otter's topsides, and waves riding on a current: what a real boat meets that the model lacks.

Wind (NED, the direction it blows **from**, as ArduPilot SITL's ``SIM_WIND_DIR``): a mean speed plus gusts, a
first-order (Gauss–Markov) process of standard deviation ``gust_std_mps`` and time constant ``gust_time_s``,
synthesised as a seeded sum of sinusoids from its spectrum S(ω) = (2σ²T/π)/(1 + (ωT)²), so that the plant stays
a deterministic function of time (a CasADi expression, like the waves). The force on the hull comes from the air
velocity relative to the boat in body axes, a = Rᵀ(ψ)·w − (u, v) (roll and pitch ignored)::

    X = ½ ρ_a C_X A_F |a| a_x      Y = ½ ρ_a C_Y A_L |a| a_y      N = −ρ_a C_N A_L L a_x a_y     K = z_p Y

(Fossen's quasi-static form with cos γ and sin γ written out: with γ_rw = −atan2(v_rw, u_rw) the angle of the
boat's velocity relative to the air, N = ½ ρ_a C_N A_L L |a|² sin 2γ_rw, so C_N > 0 turns the bow away from a wind
on the bow, as for a hull with its windage forward.) The coefficients are the hull's (``OtterParameters.wind_*``):
no measured Otter coefficients are published; the defaults (C_X 0.5, C_Y 0.875, C_N 0.15, A_F 0.15 m², A_L 0.35 m²)
are the order of MSS's Blendermann (1994) "speed boat" type (C_D,t 0.90, C_D,l 0.55–0.60) for the Otter's
topsides, and are meant to be identified or replaced per boat.

Current and waves: in real water waves ride on the current, so a fixed observer sees a component of intrinsic
frequency ω and wave vector k at ω_e = ω + k·U_c (the Doppler shift; the wavelength is unchanged).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vessel.config import ConfigError, bounded
from vessel.mathops import ops

AIR_DENSITY = 1.225  # kg/m³, sea level, 15 °C
GUST_COMPONENTS = 40
AIR_SPEED_EPS = 1e-4  # m/s: keeps |a| smooth (differentiable) at zero relative wind


@dataclass(frozen=True)
class Wind:
    """A wind of mean ``speed_mps`` from NED direction ``from_rad`` (0: from the North), with gusts."""

    speed_mps: float = bounded(0.0, 0.0, 40.0, "m/s", "mean wind speed")
    from_rad: float = bounded(0.0, -2 * math.pi, 2 * math.pi, "rad", "direction it blows from (0 = from North)")
    gust_std_mps: float = bounded(0.0, 0.0, 20.0, "m/s", "gust standard deviation")
    gust_time_s: float = bounded(5.0, 0.1, 600.0, "s", "gust time constant")
    seed: int = 0
    _gusts: tuple[np.ndarray, np.ndarray, np.ndarray] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "_gusts", gust_components(self.gust_std_mps, self.gust_time_s, self.seed))

    @property
    def calm(self) -> bool:
        """True when there is no wind at all (the plant then has no wind terms)."""
        return self.speed_mps == 0.0 and self.gust_std_mps == 0.0

    def speed_at(self, t: Any) -> Any:
        """Wind speed at time t (s): mean plus gusts (numbers or CasADi symbols)."""
        amplitude, omega, phase = self._gusts
        if amplitude.size == 0:
            return self.speed_mps + 0 * t
        xp = ops(t)
        gust = sum(float(a) * xp.cos(float(w) * t + float(p)) for a, w, p in zip(amplitude, omega, phase, strict=True))
        return xp.fmax(self.speed_mps + gust, 0.0)  # a lull stills the air; it never blows it backwards

    def velocity_ned(self, t: Any) -> tuple[Any, Any]:
        """The air's velocity (north, east), m/s, NED: it blows towards ``from_rad`` + π."""
        speed = self.speed_at(t)
        return -speed * math.cos(self.from_rad), -speed * math.sin(self.from_rad)


def gust_components(std_mps: float, time_s: float, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Amplitudes (m/s), frequencies (rad/s) and phases (rad) of a first-order gust process of standard deviation
    ``std_mps``: log-spaced from 0.02/T to 20/T, amplitudes from the spectrum, scaled to the exact variance."""
    if std_mps <= 0:
        empty = np.zeros(0)
        return empty, empty, empty
    edges = np.geomspace(0.02 / time_s, 20.0 / time_s, GUST_COMPONENTS + 1)
    omega = np.sqrt(edges[:-1] * edges[1:])
    density = (2 * std_mps**2 * time_s / math.pi) / (1 + (omega * time_s) ** 2)
    amplitude = np.sqrt(2 * density * np.diff(edges))
    amplitude *= std_mps / math.sqrt(0.5 * float(np.sum(amplitude**2)))
    phase = np.random.default_rng([7919, seed]).uniform(0.0, 2 * math.pi, GUST_COMPONENTS)
    return amplitude, omega, phase


def wind_force(params: Any, wind: Wind, psi: Any, u: Any, v: Any, t: Any) -> tuple[Any, Any, Any, Any]:
    """(X N, Y N, K N·m, N N·m) of the wind on the hull, body axes, at heading ψ (rad) and body velocity (u, v)."""
    xp = ops(psi, u, v, t)
    w_n, w_e = wind.velocity_ned(t)
    c, s = xp.cos(psi), xp.sin(psi)
    a_x = c * w_n + s * w_e - u
    a_y = -s * w_n + c * w_e - v
    speed = xp.sqrt(a_x * a_x + a_y * a_y + AIR_SPEED_EPS**2)
    cx, cy, cn = params.wind_coefficients
    q = 0.5 * AIR_DENSITY
    surge = q * cx * params.wind_area_front * speed * a_x
    sway = q * cy * params.wind_area_side * speed * a_y
    yaw = -AIR_DENSITY * cn * params.wind_area_side * params.length * a_x * a_y  # ½ρ C_N A_L L |a|² sin 2γ_rw
    return surge, sway, params.wind_pressure_height * sway, yaw


def doppler_frequency(omega: Any, wavenumber: Any, travel_dir_rad: Any, current_speed_mps: float,
                      current_dir_rad: float) -> Any:
    """ω + k·U_c: the frequency a fixed observer sees of a wave riding on the current (rad/s); numbers or arrays."""
    return omega + wavenumber * current_speed_mps * np.cos(np.asarray(travel_dir_rad) - current_dir_rad)


def check_not_blocked(omega: Any, wavenumber: Any, travel_dir_rad: Any, current_speed_mps: float,
                      current_dir_rad: float, where: str) -> None:
    """A current against the waves at half their phase speed or more (their deep-water group velocity: the energy
    can no longer travel against it) is refused: such waves steepen and break, they do not reach the boat."""
    along = current_speed_mps * np.cos(np.asarray(travel_dir_rad) - current_dir_rad)
    if np.any(along <= -0.5 * np.asarray(omega) / np.asarray(wavenumber)):
        raise ConfigError(f"{where}: the current blocks the waves (against them at half their phase speed or more); "
                          f"allowed: an opposing current below half the waves' phase speed")
