"""What the simulated autopilot senses: ``vessel.sensors`` fed by the plant's true state and IMU.

Every physics step :meth:`Sensing.update` samples the sensor model once (attitude with AHRS noise and
lag, gyro rates with noise, a GPS fix at ``SIM_GPS1_HZ`` showing the state ``SIM_GPS1_LAG_MS`` ago, the
accelerometer's body specific force from ``vessel.imu`` with noise); the telemetry then reads the latest
reading, so every channel sends the same values for one instant, as an autopilot's estimate would.

The model's settings are the ``SIM_*`` parameters of the simulator's table (:data:`SIM_PARAMS`, names
from ArduPilot SITL where they exist), read again whenever one changes. Ideal sensing (``--ideal-sensors``,
or every ``SIM_*`` value 0) bypasses the model: the readings are then the plant's state itself, exactly
the values the simulator sent before it had sensors.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from vessel.imu import ImuModel
from vessel.plant import Plant
from vessel.sensors import SensorModel, SensorParams, SensorReading

SIM_PARAMS: tuple[tuple[str, str], ...] = (
    ("SIM_GYR1_RND", "gyro_noise_dps"),
    ("SIM_ACC1_RND", "accel_noise_mps2"),
    ("SIM_GPS1_HZ", "gps_hz"),
    ("SIM_GPS1_LAG_MS", "gps_lag_ms"),
    ("SIM_GPS1_NOISE", "gps_alt_noise_m"),
    ("SIM_GPS1_VERR", "gps_vel_noise_mps"),
    ("SIM_GPS1_HNOISE", "gps_hpos_noise_m"),  # ours: SITL has no horizontal position noise
    ("SIM_GPS1_VNOISE", "gps_vpos_noise_m"),  # ours
    ("SIM_AHRS_NOISE", "att_noise_deg"),  # ours: the attitude estimate's noise
    ("SIM_AHRS_LAG_MS", "att_lag_ms"),  # ours: the attitude estimate's lag
)
"""(parameter name, ``SensorParams`` field): the simulator's sensor parameters, units as the field's."""


WIND_PARAMS: tuple[str, ...] = ("SIM_WIND_SPD", "SIM_WIND_DIR", "SIM_WIND_TURB")
"""ArduPilot SITL's wind: mean speed (m/s), the direction it blows from (deg, 0 = from North) and turbulence, here
the gusts' standard deviation (m/s). They start at the world's wind (``sea.wind_*``) unless a parameter file sets
them, and a change takes effect at the next physics step."""


def sim_param_defaults() -> list[tuple[str, float]]:
    """(name, default) of each SIM_ sensor parameter: the realistic defaults of ``SensorParams``."""
    defaults = SensorParams()
    return [(name, float(getattr(defaults, field))) for name, field in SIM_PARAMS]


def sensor_params(read: Callable[[str], float]) -> SensorParams:
    """SensorParams from the parameter table (``read(name)`` -> value); out-of-range values are clamped."""
    values = {}
    for name, field in SIM_PARAMS:
        meta = next(f.metadata for f in SensorParams.__dataclass_fields__.values() if f.name == field)
        value = float(read(name))
        values[field] = min(meta["hi"], max(meta["lo"], value if math.isfinite(value) else 0.0))
    return SensorParams(**values)


class Sensing:
    """The latest sensor reading of one plant; ideal (the true state) when ``ideal`` or every SIM_ value is 0."""

    def __init__(self, plant: Plant, read: Callable[[str], float], ideal: bool, seed: int) -> None:
        self.plant, self.read, self.force_ideal = plant, read, ideal
        self.imu = ImuModel.for_plant(plant)
        self.rng = np.random.default_rng(seed)
        self._settings: tuple[float, ...] | None = None
        self.model: SensorModel | None = None
        self.reading: SensorReading | None = None
        self.fix_received_s = 0.0  # when the latest GPS fix arrived (GPS_RAW_INT's time_usec, as Rover's)

    def rebind(self, plant: Plant) -> None:
        """Read ``plant`` from now on (the same boat, built again: a new wind); the sensors' state is kept."""
        self.plant = plant
        self.imu = ImuModel.for_plant(plant)

    @property
    def ideal(self) -> bool:
        """True when the readings are the plant's true state (no model)."""
        return self.model is None

    def _refresh_model(self) -> None:
        """Rebuild the model when a SIM_ parameter changed (over MAVLink or a .parm file)."""
        settings = tuple(float(self.read(name)) for name, _ in SIM_PARAMS)
        if settings == self._settings:
            return
        self._settings = settings
        if self.force_ideal or not any(settings):
            self.model, self.reading = None, None
        else:
            self.model = SensorModel(sensor_params(self.read), self.rng)

    def update(self) -> None:
        """Sample the sensors at the plant's time (call once per physics step, after the step)."""
        self._refresh_model()
        if self.model is None:
            return
        x, t = self.plant.state, self.plant.time
        force, _ = self.imu.measure(x, t)
        self.reading = self.model.sample(t, x[0:6], x[6:12], force)
        if self.reading.gps_fresh:
            self.fix_received_s = t

    def attitude(self) -> tuple[np.ndarray, np.ndarray]:
        """(φ, θ, ψ) rad and body rates (p, q, r) rad/s as the autopilot reports them."""
        if self.reading is None:
            x = self.plant.state
            return x[3:6], x[9:12]
        return self.reading.attitude, self.reading.rates

    def gps(self) -> tuple[np.ndarray, np.ndarray, float] | None:
        """(position NED m from home, velocity NED m/s, time s it arrived) of the latest fix; None when ideal."""
        if self.reading is None:
            return None
        return self.reading.position_ned, self.reading.velocity_ned, self.fix_received_s

    def imu_reading(self) -> tuple[np.ndarray, np.ndarray]:
        """(body specific force m/s², body rates rad/s), FRD: noisy, or exact when ideal."""
        if self.reading is None or self.reading.accel_body is None:
            x = self.plant.state
            force, rates = self.imu.measure(x, self.plant.time)
            return force, rates
        return self.reading.accel_body, self.reading.rates

