"""The boat in its sea: builds the vessel plant and converts between plant state and autopilot views."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vessel import CalmWater, OceanCurrent, Plant, RegularWaves, otter_parameters
from vessel.config import ConfigError, validate

from .control import NavState
from .mixer import output_to_shaft_speed

PHYSICS_DT_S = 0.01
WAVE_CHOICES = ("calm", "paper")


def make_waves(name: str) -> CalmWater | RegularWaves:
    """The sea state by name: 'calm' or 'paper' (H 1.75 m, λ 35 m, T 6 s, travelling West)."""
    if name == "paper":
        return RegularWaves(height_m=1.75, length_m=35.0, period_s=6.0, travel_dir_rad=-math.pi / 2)
    return CalmWater()


def parse_numbers(text: str, count: int, what: str) -> list[float]:
    """``count`` comma-separated finite numbers, or a one-line ConfigError naming ``what``."""
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        values = []
    if len(values) != count or not all(math.isfinite(v) for v in values):
        raise ConfigError(f"{what}: expected {count} comma-separated numbers, got {text!r}")
    return values


def parse_sea(text: str) -> RegularWaves:
    """``H_M,LENGTH_M,PERIOD_S,DIR_DEG`` -> validated regular waves travelling towards DIR_DEG (0 = North)."""
    height, length, period, direction = parse_numbers(text, 4, "--sea")
    try:
        waves = RegularWaves(height, length, period, math.radians(direction))
    except ConfigError as exc:
        raise ConfigError(f"--sea.{exc}") from None
    validate(waves, "--sea")
    return waves


def parse_current(text: str) -> OceanCurrent:
    """``SPEED_M_S,DIR_DEG`` -> a validated uniform current flowing towards DIR_DEG."""
    speed, direction = parse_numbers(text, 2, "--current")
    current = OceanCurrent(speed, math.radians(direction))
    validate(current, "--current")
    return current


@dataclass
class Physics:
    """The plant and the shaft-speed limits that map motor outputs to propeller commands."""

    plant: Plant
    n_max: float
    n_min: float

    @classmethod
    def create(
        cls,
        waves: CalmWater | RegularWaves,
        heading_deg: float,
        current: OceanCurrent | None = None,
        vessel: str = "published",
        x0: np.ndarray | None = None,
    ) -> Physics:
        """An Otter stepped at 100 Hz: at rest at the origin pointing ``heading_deg``, or at state ``x0``."""
        params = otter_parameters(vessel)
        if x0 is None:
            x0 = np.zeros(14)
            x0[5] = math.radians(heading_deg)
        plant = Plant(params, waves, current or OceanCurrent(), dt=PHYSICS_DT_S, integrator="rk4", x0=x0)
        limits = params.matrices()
        return cls(plant, float(limits.n_max), float(limits.n_min))

    def shaft_commands(self, outputs: tuple[float, float]) -> tuple[float, float]:
        """Left/right motor outputs in [-1, 1] -> commanded shaft speeds (rad/s)."""
        return (
            output_to_shaft_speed(outputs[0], self.n_max, self.n_min),
            output_to_shaft_speed(outputs[1], self.n_max, self.n_min),
        )

    def wave_at(self, north: float, east: float, t: float) -> tuple[float, float]:
        """Wave elevation (m) and slope along the travel direction (rad) at a point, for logging."""
        waves = self.plant.waves
        slope = waves.slope_along_travel(north, east, t) if hasattr(waves, "slope_along_travel") else 0.0
        return float(waves.elevation(north, east, t)), float(slope)


def ned_velocity(x: np.ndarray) -> tuple[float, float, float]:
    """Body velocities (u, v, w) rotated into NED with the ZYX Euler angles of the state."""
    phi, theta, psi = x[3], x[4], x[5]
    u, v, w = x[6], x[7], x[8]
    cphi, sphi, cth, sth, cpsi, spsi = (
        math.cos(phi),
        math.sin(phi),
        math.cos(theta),
        math.sin(theta),
        math.cos(psi),
        math.sin(psi),
    )
    vn = cpsi * cth * u + (cpsi * sth * sphi - spsi * cphi) * v + (cpsi * sth * cphi + spsi * sphi) * w
    ve = spsi * cth * u + (spsi * sth * sphi + cpsi * cphi) * v + (spsi * sth * cphi - cpsi * sphi) * w
    vd = -sth * u + cth * sphi * v + cth * cphi * w
    return vn, ve, vd


def nav_state(x: np.ndarray) -> NavState:
    """What a perfect estimator reports from the plant state: position, heading, Earth yaw rate, velocity."""
    vn, ve, _ = ned_velocity(x)
    phi, theta = x[3], x[4]
    yaw_rate = (math.sin(phi) * x[10] + math.cos(phi) * x[11]) / max(1e-6, math.cos(theta))
    return NavState(float(x[0]), float(x[1]), float(x[2]), float(x[5]), float(yaw_rate), vn, ve)
