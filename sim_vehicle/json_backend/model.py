"""The plant behind the JSON backend: the normal simulator's ``vessel.Plant``, stepped by the firmware's clock.

Each new servo frame advances the plant by 1/frame_rate. The plant is exactly the one
``sim_vehicle.physics.Physics`` builds (RK4, same parameters, sea, current and start state), with its
step set to the frame period, and the same heave model (``surface_heave``: the hull heaves with the sea,
the simulator's default in irregular seas); frames longer than the simulator's own step (PHYSICS_DT_S) are split
into equal sub-steps no longer than it, so a low SIM_RATE_HZ cannot make the integration coarser than
the normal simulator's. A frame-rate change hands state and time over to a plant built for the new
step (built once per rate, kept for reuse). Motor outputs map to shaft-speed commands with the
simulator's own ``output_to_shaft_speed``.

The reply values come from one CasADi function of (x, t), compiled like the plant when it is large
(an irregular sea, ``vessel.jit``): the ideal IMU of ``vessel.imu`` (specific
force and body rates, FRD), NED position, NED velocity R(η)·[u, v, w] and the attitude quaternion.
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np

from sim_vehicle.json_backend.protocol import quaternion_from_euler
from sim_vehicle.physics import PHYSICS_DT_S
from sim_vehicle.rover.mixer import output_to_shaft_speed
from vessel import NX_PLANT, OceanCurrent, Plant, WaveField
from vessel.dynamics import rotation_body_to_ned
from vessel.imu import imu_function
from vessel.jit import compiled, worth_compiling
from vessel.params import OtterParameters
from vessel.sea.wind import Wind

MAX_PLANTS = 8  # distinct frame rates kept built; a firmware changes SIM_RATE_HZ rarely


def sensor_function(params: OtterParameters, waves: WaveField, current: OceanCurrent,
                    surface_heave: bool = False, wind: Wind | None = None) -> ca.Function:
    """(x[14], t) -> [gyro 3 rad/s, accel_body 3 m/s² (FRD), position 3 m NED, velocity 3 m/s NED, q 4].

    ``surface_heave`` must be the plant's: it changes ẇ, so the specific force.
    """
    imu = imu_function(params, waves, current, surface_heave, wind)
    x = ca.SX.sym("x", NX_PLANT)
    t = ca.SX.sym("t")
    reading = imu(x, t)
    velocity = rotation_body_to_ned(x[3], x[4], x[5]) @ x[6:9]
    q = ca.vertcat(*quaternion_from_euler(x[3], x[4], x[5]))
    q = ca.if_else(q[0] < 0, -q, q)  # the same rotation; w >= 0 reads better in logs
    out = ca.vertcat(reading[3:6], reading[0:3], x[0:3], velocity, q)
    return ca.Function("json_sensors", [x, t], [out], ["x", "t"], ["sensors"])


def substeps_for(frame_dt: float) -> int:
    """How many equal plant steps make one frame, so that none is longer than PHYSICS_DT_S."""
    return max(1, math.ceil(frame_dt / PHYSICS_DT_S - 1e-9))


class JsonPhysics:
    """The Otter in its sea, advanced frame by frame; holds the state between frames."""

    def __init__(self, params: OtterParameters, waves: WaveField, current: OceanCurrent,
                 x0: np.ndarray, surface_heave: bool = False, wind: Wind | None = None) -> None:
        self.params = params
        self.wind = wind  # the world's wind (None: still air)
        self.surface_heave = surface_heave  # heave restoring on z + ζ (the hull rides the sea); off: the paper's
        self.waves = waves
        self.current = current
        self.x0 = np.array(x0, float)
        limits = params.matrices()
        self.n_max, self.n_min = float(limits.n_max), float(limits.n_min)
        self._plants: dict[float, tuple[Plant, int]] = {}
        self._plant: Plant | None = None
        self._sensors = sensor_function(params, waves, current, surface_heave, wind)
        if worth_compiling(self._sensors):  # an irregular sea: as large as the plant step, so compiled like it
            self._sensors = compiled(self._sensors)
        self._sx = np.zeros(NX_PLANT)
        self._st = np.zeros(1)
        self._sout = np.zeros(16)
        buffer, self._evaluate = self._sensors.buffer()
        buffer.set_arg(0, memoryview(self._sx))
        buffer.set_arg(1, memoryview(self._st))
        buffer.set_res(0, memoryview(self._sout))
        self._buffer = buffer
        self.reset()

    def reset(self) -> None:
        """Back to the start state at t = 0 (the firmware restarted)."""
        self._plant = None
        self._x = self.x0.copy()
        self._t = 0.0
        self.n_cmd = (0.0, 0.0)

    @property
    def state(self) -> np.ndarray:
        """x[14] now (a view into the plant while stepping: copy it to keep it)."""
        return self._x

    @property
    def time(self) -> float:
        """Physics time in s since the (re)start."""
        return self._t

    def prepare(self, frame_dt: float) -> None:
        """Build (and, in an irregular sea, compile) the plant for this frame period before the first frame."""
        self._plant_for(frame_dt)

    def _plant_for(self, frame_dt: float) -> tuple[Plant, int]:
        """The plant (and sub-step count) for this frame period, built on first use."""
        entry = self._plants.get(frame_dt)
        if entry is None:
            k = substeps_for(frame_dt)
            plant = Plant(self.params, self.waves, self.current, dt=frame_dt / k, integrator="rk4", x0=self.x0,
                          surface_heave=self.surface_heave, wind=self.wind)
            if len(self._plants) >= MAX_PLANTS:
                stale = next(d for d, (p, _) in self._plants.items() if p is not self._plant)
                del self._plants[stale]
            entry = self._plants[frame_dt] = (plant, k)
        return entry

    def step(self, outputs: tuple[float, float], frame_dt: float) -> None:
        """Advance one frame of ``frame_dt`` s with left/right motor outputs in [-1, 1] held."""
        plant, k = self._plant_for(frame_dt)
        if plant is not self._plant:
            plant.reset(self.state.copy(), self.time)
            self._plant = plant
        self.n_cmd = (output_to_shaft_speed(outputs[0], self.n_max, self.n_min),
                      output_to_shaft_speed(outputs[1], self.n_max, self.n_min))
        for _ in range(k):
            self._x = plant.step(self.n_cmd)
        self._t = plant.time

    def sensors(self) -> np.ndarray:
        """The 16 reply values now (gyro, accel_body, position, velocity, quaternion), a fresh array."""
        self._sx[:] = self.state
        self._st[0] = self.time
        self._evaluate()
        return self._sout.copy()

    def reply_values(self) -> list[float]:
        """timestamp followed by the 16 sensor values, as plain floats for the encoder."""
        self._sx[:] = self.state
        self._st[0] = self.time
        self._evaluate()
        return [self.time, *self._sout.tolist()]
