"""The boat in its world: builds the vessel plant and converts between plant state and autopilot views."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from sim_vehicle.rover.control import NavState
from sim_vehicle.rover.mixer import output_to_shaft_speed
from sim_vehicle.scenario import seeded_waves
from sim_vehicle.sensing import WIND_PARAMS, Sensing
from vessel import Plant, World
from vessel.sea.wind import Wind

PHYSICS_DT_S = 0.01


@dataclass
class Physics:
    """The plant and the shaft-speed limits that map motor outputs to propeller commands."""

    plant: Plant
    n_max: float
    n_min: float
    sensing: Sensing | None = None  # what the autopilot senses; None: the true state (see attach_sensing)

    @classmethod
    def create(cls, world: World, seed: int | None = None, surface_heave: bool = False,
               wind: Wind | None = None) -> Physics:  # (wind None: the world's; the simulator passes SIM_WIND_*'s)
        """An Otter stepped at 100 Hz in the world's sea, from the world's start (propellers stopped).

        ``seed`` gives the sea its hidden phase origin (``scenario.seeded_waves``; None: the sea as
        written, phase 0 at boot); ``surface_heave`` makes the hull heave with the surface; ``wind`` is the
        SIM_WIND_* parameters' (``wind_of``).
        """
        params = world.params()
        wind = world.sea.wind() if wind is None else wind
        waves = world.sea.waves(params)
        if seed is not None:
            waves = seeded_waves(waves, seed)
        plant = Plant(params, waves, world.sea.current(), dt=PHYSICS_DT_S, integrator="rk4",
                      x0=world.plant_state(), surface_heave=surface_heave, wind=wind)
        limits = params.matrices()
        return cls(plant, float(limits.n_max), float(limits.n_min))

    def set_wind(self, wind: Wind | None) -> None:
        """A new wind from the next step on (SIM_WIND_* changed): the plant is built again around the same state,
        time and sea (a fraction of a second of building, between two steps), and the sensors follow it."""
        old = self.plant
        self.plant = Plant(old.params, old.waves, old.current, dt=old.dt, integrator=old.integrator, x0=old.state,
                           t0=old.time, surface_heave=old.surface_heave, wind=wind)
        if self.sensing is not None:
            self.sensing.rebind(self.plant)

    def attach_sensing(self, read: Callable[[str], float], ideal: bool, seed: int) -> None:
        """Sensors on the plant, set by the SIM_* parameters ``read(name)``; ``ideal`` forces exact readings."""
        self.sensing = Sensing(self.plant, read, ideal, seed)

    def shaft_commands(self, outputs: tuple[float, float]) -> tuple[float, float]:
        """Left/right motor outputs in [-1, 1] -> commanded shaft speeds (rad/s)."""
        return (
            output_to_shaft_speed(outputs[0], self.n_max, self.n_min),
            output_to_shaft_speed(outputs[1], self.n_max, self.n_min),
        )

    def wave_at(self, north: float, east: float, t: float) -> tuple[float, float, float, float]:
        """Wave elevation (m, up), slope along the travel direction (rad; 0 for an irregular sea) and the
        slope angles towards North and East (rad, ``WaveField.slope_angles``) at a point, for logging."""
        waves = self.plant.waves
        slope = waves.slope_along_travel(north, east, t) if hasattr(waves, "slope_along_travel") else 0.0
        slope_n, slope_e = waves.slope_angles(north, east, t)
        return float(waves.elevation(north, east, t)), float(slope), float(slope_n), float(slope_e)


def wind_setting(read: Callable[[str], float]) -> tuple[float, float, float]:
    """(SIM_WIND_SPD m/s, SIM_WIND_DIR deg from, SIM_WIND_TURB m/s) as the parameters hold them."""
    return read("SIM_WIND_SPD"), read("SIM_WIND_DIR"), read("SIM_WIND_TURB")


def wind_of(setting: tuple[float, float, float], seed: int = 0) -> Wind | None:
    """The wind the SIM_WIND_* parameters describe (speed and turbulence clamped to their ranges), None: still air."""
    speed, from_deg, turbulence = setting
    speed = min(max(speed, 0.0), 40.0) if math.isfinite(speed) else 0.0
    turbulence = min(max(turbulence, 0.0), 20.0) if math.isfinite(turbulence) else 0.0
    from_rad = math.radians(math.remainder(from_deg, 360.0)) if math.isfinite(from_deg) else 0.0
    wind = Wind(speed, from_rad, turbulence, seed=seed)
    return None if wind.calm else wind


def seed_wind_parameters(world: World, params: Any) -> None:
    """The world's wind as the SIM_WIND_* parameters' starting values, where a parameter file left them at 0."""
    sea = world.sea
    for name, value in zip(WIND_PARAMS, (sea.wind_speed_mps, sea.wind_from_deg, sea.wind_gust_mps), strict=True):
        if params[name] == 0.0 and value != 0.0:
            params.set(name, value, save=False)


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
