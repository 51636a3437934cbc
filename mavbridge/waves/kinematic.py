"""A kinematic truth for the estimator: a point that rides the sea exactly, seen through the sensor model.

The point moves at a given over-ground speed along a heading schedule ψ(t); its roll and pitch are
the surface slope (β = 0 in ``vessel.sea.waves.surface_relative_attitude``: pitch = slope along the hull,
roll = ``roll_sign`` × slope across it), and it heaves with the surface (z = −ζ). Its NED acceleration
(finite differences of the path) gives the IMU's specific force. ``vessel.sensors`` adds the
autopilot's noise, lags and GPS rate. Also the figures the tests and the benchmark compare: errors of
an estimate against the true wave, and the predicted-phase error at the end of the horizon.
Used by tests and ``bench/wave_estimation.py``; no I/O.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np

from mavbridge.waves.source import MotionSample, WaveEstimate
from vessel import RegularWaves
from vessel.sensors import (
    SensorModel,
    SensorParams,
    SensorReading,
    rotation_body_to_ned,
    specific_force_from_acceleration,
)

Heading = Callable[[float], float]


def paper_sea(phase_rad: float = 0.0) -> RegularWaves:
    """The paper's regular sea: 1.75 m, 35 m, 6 s, travelling −90° (West), with a hidden phase."""
    return RegularWaves(1.75, 35.0, 6.0, -math.pi / 2, phase_rad=phase_rad)


@dataclass
class KinematicBoat:
    """A point on the surface of ``waves`` at speed ``speed_mps`` (m/s, or a schedule of t) along ``heading(t)``."""

    waves: RegularWaves
    speed_mps: float | Heading
    heading: Heading
    roll_sign: float = 1.0
    heave: bool = True
    dt: float = 0.01  # integration step of the path

    def __post_init__(self) -> None:
        self._t = 0.0
        self._pos = np.zeros(2)

    def speed(self, t: float) -> float:
        """Over-ground speed at time ``t``, m/s."""
        return float(self.speed_mps(t)) if callable(self.speed_mps) else float(self.speed_mps)

    def _position_at(self, t: float) -> np.ndarray:
        """Position at a time slightly ahead of or behind the integrated one (straight-line extrapolation)."""
        psi = self.heading(self._t)
        return self._pos + self.speed(self._t) * (t - self._t) * np.array([math.cos(psi), math.sin(psi)])

    def _down(self, t: float) -> float:
        p = self._position_at(t)
        return -float(self.waves.elevation(p[0], p[1], t)) if self.heave else 0.0

    def _attitude(self, t: float) -> np.ndarray:
        """(φ, θ, ψ) riding the surface at time ``t`` near the integrated time."""
        p = self._position_at(t)
        psi = self.heading(t)
        a_n, a_e = self.waves.slope_angles(p[0], p[1], t)
        pitch = a_n * math.cos(psi) + a_e * math.sin(psi)
        roll = self.roll_sign * (a_e * math.cos(psi) - a_n * math.sin(psi))
        return np.array([roll, pitch, psi])

    def state(self) -> tuple[float, np.ndarray, np.ndarray, np.ndarray]:
        """(t, η, ν, body specific force) now; rates and accelerations by central differences."""
        t, (n, e) = self._t, self._pos
        h = 1e-3
        att = self._attitude(t)
        d_att = (self._attitude(t + h) - self._attitude(t - h)) / (2 * h)
        d_att[2] = math.remainder(self._attitude(t + h)[2] - self._attitude(t - h)[2], 2 * math.pi) / (2 * h)
        roll, pitch, psi = att
        rates = np.array([d_att[0] - d_att[2] * math.sin(pitch),
                          d_att[1] * math.cos(roll) + d_att[2] * math.cos(pitch) * math.sin(roll),
                          -d_att[1] * math.sin(roll) + d_att[2] * math.cos(pitch) * math.cos(roll)])
        z0, zp, zm = self._down(t), self._down(t + h), self._down(t - h)
        w_down = (zp - zm) / (2 * h)
        a_down = (zp - 2 * z0 + zm) / (h * h)
        eta = np.array([n, e, z0, roll, pitch, psi])
        speed = self.speed(t)
        v_ned = np.array([speed * math.cos(psi), speed * math.sin(psi), w_down])
        nu = np.concatenate([rotation_body_to_ned(roll, pitch, psi).T @ v_ned, rates])
        turn = speed * d_att[2]  # centripetal acceleration of the path, m/s²
        a_ned = np.array([-turn * math.sin(psi), turn * math.cos(psi), a_down])
        f = specific_force_from_acceleration(a_ned, eta[3:6])
        return t, eta, nu, f

    def advance(self, seconds: float) -> None:
        """Move along the heading schedule for ``seconds``."""
        steps = max(1, round(seconds / self.dt))
        h = seconds / steps
        for _ in range(steps):
            psi = self.heading(self._t + h / 2)
            self._pos = self._pos + self.speed(self._t + h / 2) * h * np.array([math.cos(psi), math.sin(psi)])
            self._t += h


def to_motion_sample(reading: SensorReading, with_imu: bool = True) -> MotionSample:
    """What the companion gets from the autopilot, as the estimator's input type."""
    return MotionSample(reading.t_s, reading.attitude, reading.rates, reading.position_ned,
                        reading.velocity_ned, reading.accel_body if with_imu else None)


def motion_samples(boat: KinematicBoat, duration_s: float, rate_hz: float = 20.0,
                   sensors: SensorParams | None = None, seed: int = 0, t0: float = 0.0,
                   with_imu: bool = True) -> Iterator[MotionSample]:
    """The boat's autopilot stream at ``rate_hz`` for ``duration_s`` (autopilot clock starts at ``t0``)."""
    model = SensorModel(sensors or SensorParams(), np.random.default_rng(seed))
    dt = 1.0 / rate_hz
    for _ in range(round(duration_s * rate_hz)):
        t, eta, nu, f = boat.state()
        reading = model.sample(t0 + t, eta, nu, f)
        yield to_motion_sample(reading, with_imu)
        boat.advance(dt)


@dataclass(frozen=True)
class EstimateErrors:
    """An estimate against the truth: direction °, period %, wavelength %, height %, phase error °."""

    direction_deg: float
    period_pct: float
    length_pct: float
    height_pct: float
    phase_deg: float

    def within(self, direction: float = 10, period: float = 5, length: float = 15, height: float = 15,
               phase: float = 30) -> bool:
        """True if every error is inside the issue's acceptance bounds (defaults)."""
        return (abs(self.direction_deg) <= direction and abs(self.period_pct) <= period
                and abs(self.length_pct) <= length and abs(self.height_pct) <= height
                and abs(self.phase_deg) <= phase)


def estimate_errors(est: WaveEstimate, truth: RegularWaves, t_s: float, north: float, east: float,
                    t_truth_offset: float = 0.0) -> EstimateErrors:
    """Errors of ``est`` at autopilot time ``t_s`` and position (N, E); truth time = t_s − offset.

    The phase error is that of the predicted wave Φ = ω t − k s + ε (elevation and slope share it) at
    the given time and place — pass the boat's position at the horizon's end.
    """
    def phase(w: float, k: float, chi: float, eps: float, t: float) -> float:
        return w * t - k * (north * math.cos(chi) + east * math.sin(chi)) + eps

    p_est = phase(2 * math.pi / est.period_s, 2 * math.pi / est.length_m, est.travel_dir_rad, est.phase_rad, t_s)
    p_true = phase(truth.frequency, truth.wavenumber, truth.travel_dir_rad, truth.phase_rad,
                   t_s - t_truth_offset)
    return EstimateErrors(
        math.degrees(math.remainder(est.travel_dir_rad - truth.travel_dir_rad, 2 * math.pi)),
        100 * (est.period_s / truth.period_s - 1), 100 * (est.length_m / truth.length_m - 1),
        100 * (est.height_m / truth.height_m - 1), math.degrees(math.remainder(p_est - p_true, 2 * math.pi)))
