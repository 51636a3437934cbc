"""What an ideal strapdown IMU at the body origin (CO) measures: specific force and body rates.

An accelerometer measures specific force, the non-gravitational acceleration of its case, in the body
frame (x forward, y starboard, z down: FRD). For a boat whose body velocity is ν = [u, v, w, p, q, r]
that is

    f_b = v̇_b + ω_b × v_b − R(η)ᵀ·[0, 0, g]ᵀ

with v̇_b the first three rows of ν̇ (from ``vessel.dynamics``, which already holds the current's
d/dt ν_c term), ω_b = [p, q, r] and R(η) the ZYX body-to-NED rotation. Level at rest this is
(0, 0, −g) — ArduPilot's accelerometer convention. The gyroscope measures ω_b itself.

ν̇ depends on the actual shaft speeds n (part of the 14-state x), not on the shaft commands, so the
IMU is a function of (x, t) alone. Noise, bias and lag belong to a sensor model on top of this.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from vessel.dynamics import NX_PLANT, OceanCurrent, plant_ode
from vessel.mathops import is_symbolic, ops
from vessel.params import OtterParameters
from vessel.plant import Plant
from vessel.sea.waves import CalmWater, WaveField
from vessel.sea.wind import Wind


def gravity_body(phi: Any, theta: Any, g: float) -> tuple[Any, Any, Any]:
    """R(η)ᵀ·[0, 0, g]: gravity (m/s², pointing down in NED) in the body frame; yaw does not matter."""
    xp = ops(phi, theta)
    return -g * xp.sin(theta), g * xp.cos(theta) * xp.sin(phi), g * xp.cos(theta) * xp.cos(phi)


def specific_force(nu: Any, nu_dot: Any, phi: Any, theta: Any, g: float) -> Any:
    """f_b = v̇ + ω × v − R(η)ᵀ·g_NED, m/s², body FRD; numpy in → numpy array out, CasADi in → SX column.

    ``nu`` and ``nu_dot`` are the 6-vectors [u, v, w, p, q, r] and their time derivatives (body frame);
    ``phi``, ``theta`` roll and pitch (rad); ``g`` gravity (m/s²).
    """
    u, v, w, p, q, r = (nu[i] for i in range(6))
    g_x, g_y, g_z = gravity_body(phi, theta, g)
    f_x = nu_dot[0] + (q * w - r * v) - g_x
    f_y = nu_dot[1] + (r * u - p * w) - g_y
    f_z = nu_dot[2] + (p * v - q * u) - g_z
    if is_symbolic(nu, nu_dot, phi, theta):
        return ca.vertcat(f_x, f_y, f_z)
    return np.array([f_x, f_y, f_z], dtype=float)


def imu_function(params: OtterParameters, waves: WaveField | None = None,
                 current: OceanCurrent | None = None, surface_heave: bool = False,
                 wind: Wind | None = None) -> ca.Function:
    """(x[14], t s) -> imu[6] = (f_x, f_y, f_z m/s², p, q, r rad/s), body FRD, from the plant's own ẋ.

    ``surface_heave`` and ``wind`` must match the plant's (``Plant.surface_heave``, ``Plant.wind``): they change ν̇.
    """
    ode = plant_ode(params, waves or CalmWater(), current or OceanCurrent(), surface_heave, wind)
    x = ca.SX.sym("x", NX_PLANT)
    t = ca.SX.sym("t")
    xdot = ode(x, ca.DM.zeros(2), t)  # shaft commands only move ṅ, which the IMU does not see
    nu, nu_dot = x[6:12], xdot[6:12]
    f = specific_force(nu, nu_dot, x[3], x[4], params.g)
    return ca.Function("imu", [x, t], [ca.vertcat(f, nu[3:6])], ["x", "t"], ["imu"])


def specific_force_body(params: OtterParameters, x: np.ndarray, t: float = 0.0,
                        waves: WaveField | None = None, current: OceanCurrent | None = None) -> np.ndarray:
    """One-off specific force (m/s², body FRD) at plant state x[14] and time t; builds the function each call.

    For repeated use (a simulator loop) take :class:`ImuModel`, which compiles once.
    """
    out = imu_function(params, waves, current)(np.asarray(x, float), float(t))
    return np.asarray(out, float).ravel()[0:3]


class ImuModel:
    """The ideal IMU of one plant configuration, evaluated through CasADi's buffer interface (≈ 1 µs)."""

    def __init__(self, params: OtterParameters, waves: WaveField | None = None,
                 current: OceanCurrent | None = None, surface_heave: bool = False, wind: Wind | None = None) -> None:
        self._function = imu_function(params, waves, current, surface_heave, wind)
        self._x = np.zeros(NX_PLANT)
        self._t = np.zeros(1)
        self._out = np.zeros(6)
        buffer, self._evaluate = self._function.buffer()
        buffer.set_arg(0, memoryview(self._x))
        buffer.set_arg(1, memoryview(self._t))
        buffer.set_res(0, memoryview(self._out))
        self._buffer = buffer  # keeps the bindings alive

    @classmethod
    def for_plant(cls, plant: Plant) -> ImuModel:
        """The IMU of this plant's vessel, sea, current, heave model and wind."""
        return cls(plant.params, plant.waves, plant.current, plant.surface_heave, plant.wind)

    def measure(self, x: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(specific force m/s², body rates rad/s), both body FRD, at plant state x[14] and time t (s)."""
        self._x[:] = x
        self._t[0] = t
        self._evaluate()
        return self._out[0:3].copy(), self._out[3:6].copy()
