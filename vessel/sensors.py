"""What the autopilot would report about the boat: the sensor model ArduPilot SITL applies, pure numbers.

The plant knows its true state; an autopilot only streams estimates of it. ``SensorModel`` turns the
true state (NED pose η, body velocity ν, body specific force — the caller computes it) into what an
ArduPilot Rover streams: ATTITUDE (roll, pitch, yaw with noise and a small lag; body rates with gyro
noise), GPS position and velocity (NED, relative to home) refreshed at a fixed rate with a lag and
noise and held between fixes, and the IMU's body specific force (SCALED_IMU / RAW_IMU; gravity
included: level and at rest it reads (0, 0, −g)) with noise. The same model serves the simulator and
the in-process runner, so both see identical sensors. No I/O; randomness only from the seeded
``numpy.random.Generator`` given to the model.

Parameters (SI inside; the fields carry their unit in the name, as the YAML would):

=====================  ===================  ========  =======  =============================================
field                  ArduPilot SITL name  unit      default  source / note
=====================  ===================  ========  =======  =============================================
gyro_noise_dps         SIM_GYR1_RND         deg/s     0.1      libraries/SITL/SITL.cpp (default 0) and
                                                               AP_InertialSensor_SITL.cpp: SITL scales a
                                                               uniform ±value by throttle; here the value
                                                               is the std of white Gaussian noise (a MEMS
                                                               gyro at ~20 Hz output rate)
accel_noise_mps2       SIM_ACC1_RND         m/s²      0.05     same files (default 0, SITL adds a 0.01
                                                               m/s² floor); std of white Gaussian noise
gps_hz                 SIM_GPS1_HZ          Hz        5        libraries/SITL/SIM_GPS.cpp (default 5);
                                                               0 = a fresh fix at every sample (ideal)
gps_lag_ms             SIM_GPS1_LAG_MS      ms        100      SIM_GPS.cpp (default 100): the fix shows
                                                               the state this long ago (interpolated)
gps_alt_noise_m        SIM_GPS1_NOISE       m         0        SIM_GPS.cpp (default 0): amplitude of a
                                                               slow sine (0.0005 rad/ms) on the altitude
gps_vel_noise_mps      SIM_GPS1_VERR        m/s       0.05     SIM_GPS.cpp (default 0, uniform ±VERR per
                                                               NED axis); here Gaussian std per axis
gps_hpos_noise_m       (none)               m         0.3      ours: SITL adds no horizontal noise; white
                                                               Gaussian per fix, north and east
gps_vpos_noise_m       (none)               m         0.3      ours: white Gaussian per fix, down
att_noise_deg          (none)               deg       0.2      ours: the AHRS/EKF attitude of ATTITUDE;
                                                               issue 11 asks for 0.1–0.3° noise
att_lag_ms             (none)               ms        20       ours: small AHRS output lag on attitude and
                                                               rates (interpolated history)
=====================  ===================  ========  =======  =============================================

``SensorParams.ideal()`` sets every noise and lag to zero and ``gps_hz`` to 0: the readings are then
exactly the true state (today's behaviour).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field, fields, replace

import numpy as np

from vessel.config import bounded, validate

GRAVITY = 9.81  # m/s², the vessel model's g


@dataclass(frozen=True)
class SensorParams:
    """Noise, lag and rate of each simulated sensor (see the module docstring for names and sources)."""

    gyro_noise_dps: float = bounded(0.1, 0.0, 100.0, "deg/s", "gyro white-noise std (SIM_GYR1_RND)")
    accel_noise_mps2: float = bounded(0.05, 0.0, 50.0, "m/s²", "accelerometer white-noise std (SIM_ACC1_RND)")
    gps_hz: float = bounded(5.0, 0.0, 100.0, "Hz", "GPS fix rate (SIM_GPS1_HZ); 0 = every sample")
    gps_lag_ms: float = bounded(100.0, 0.0, 2000.0, "ms", "GPS lag (SIM_GPS1_LAG_MS)")
    gps_alt_noise_m: float = bounded(0.0, 0.0, 100.0, "m", "slow-sine altitude error amplitude (SIM_GPS1_NOISE)")
    gps_vel_noise_mps: float = bounded(0.05, 0.0, 10.0, "m/s", "GPS velocity noise std per axis (SIM_GPS1_VERR)")
    gps_hpos_noise_m: float = bounded(0.3, 0.0, 100.0, "m", "GPS horizontal position noise std per axis")
    gps_vpos_noise_m: float = bounded(0.3, 0.0, 100.0, "m", "GPS vertical position noise std")
    att_noise_deg: float = bounded(0.2, 0.0, 30.0, "deg", "AHRS attitude noise std per angle")
    att_lag_ms: float = bounded(20.0, 0.0, 2000.0, "ms", "AHRS attitude and rate lag")

    def __post_init__(self) -> None:
        validate(self)

    @classmethod
    def ideal(cls) -> SensorParams:
        """Exact sensors: no noise, no lag, a fresh GPS fix at every sample."""
        return cls(**{f.name: 0.0 for f in fields(cls)})

    def with_(self, **changes: float) -> SensorParams:
        """A copy with some fields changed (validated)."""
        return replace(self, **changes)


@dataclass(frozen=True)
class SensorReading:
    """What the autopilot streams at one instant (SI, radians, NED; positions relative to home).

    ``attitude`` (φ, θ, ψ) rad with ψ in (−π, π]; ``rates`` body (p, q, r) rad/s; ``position_ned`` m and
    ``velocity_ned`` m/s of the latest GPS fix; ``accel_body`` body specific force m/s² (None when the
    caller gave none); ``gps_fix_time_s`` the time of the state the fix shows (sample time − lag).
    """

    t_s: float
    attitude: np.ndarray
    rates: np.ndarray
    position_ned: np.ndarray
    velocity_ned: np.ndarray
    accel_body: np.ndarray | None
    gps_fix_time_s: float
    gps_fresh: bool


def rotation_body_to_ned(phi: float, theta: float, psi: float) -> np.ndarray:
    """R_zyx(φ, θ, ψ) as a numpy 3×3 matrix: body-frame vectors to NED."""
    cf, sf, ct, st, cp, sp = (math.cos(phi), math.sin(phi), math.cos(theta), math.sin(theta),
                              math.cos(psi), math.sin(psi))
    return np.array([[cp * ct, -sp * cf + cp * st * sf, sp * sf + cp * cf * st],
                     [sp * ct, cp * cf + sf * st * sp, -cp * sf + st * sp * cf],
                     [-st, ct * sf, ct * cf]])


def body_velocity_from_ned(phi: float, theta: float, psi: float, north: float, east: float,
                           down: float) -> tuple[float, float, float]:
    """R_zyx(φ, θ, ψ)ᵀ·(north, east, down): a NED vector in the body frame, in plain floats (the control step's path:
    a numpy 3×3 and its product cost more than the sums, paced; the same numbers to within rounding)."""
    cf, sf, ct, st, cp, sp = (math.cos(phi), math.sin(phi), math.cos(theta), math.sin(theta),
                              math.cos(psi), math.sin(psi))
    return (cp * ct * north + sp * ct * east - st * down,
            (-sp * cf + cp * st * sf) * north + (cp * cf + sf * st * sp) * east + ct * sf * down,
            (sp * sf + cp * cf * st) * north + (-cp * sf + st * sp * cf) * east + ct * cf * down)


def ned_velocity_from_body(phi: float, theta: float, psi: float, u: float, v: float,
                           w: float) -> tuple[float, float, float]:
    """R_zyx(φ, θ, ψ)·(u, v, w): a body vector in NED, in plain floats (see ``body_velocity_from_ned``)."""
    cf, sf, ct, st, cp, sp = (math.cos(phi), math.sin(phi), math.cos(theta), math.sin(theta),
                              math.cos(psi), math.sin(psi))
    return (cp * ct * u + (-sp * cf + cp * st * sf) * v + (sp * sf + cp * cf * st) * w,
            sp * ct * u + (cp * cf + sf * st * sp) * v + (-cp * sf + st * sp * cf) * w,
            -st * u + ct * sf * v + ct * cf * w)


def specific_force_from_acceleration(accel_ned: np.ndarray, attitude: np.ndarray,
                                     g: float = GRAVITY) -> np.ndarray:
    """Body specific force f_b = Rᵀ·(a − g_ned) of a point with NED acceleration ``accel_ned`` (m/s²).

    The kinematic definition (what an ideal accelerometer at that point reads); the vessel model's own
    version, from its dynamics, lives in ``vessel.imu``.
    """
    R = rotation_body_to_ned(float(attitude[0]), float(attitude[1]), float(attitude[2]))
    return R.T @ (np.asarray(accel_ned, float) - np.array([0.0, 0.0, g]))


def wrap_pi(angle: float) -> float:
    """Angle wrapped into (−π, π]."""
    wrapped = math.remainder(angle, 2 * math.pi)
    return math.pi if wrapped == -math.pi else wrapped


@dataclass
class _History:
    """Recent (t, vector) samples, for reading a value as it was ``lag`` seconds ago (interpolated)."""

    keep_s: float
    items: deque = field(default_factory=deque)

    def push(self, t: float, value: np.ndarray) -> None:
        self.items.append((t, value))
        while len(self.items) > 2 and self.items[1][0] <= t - self.keep_s:
            self.items.popleft()

    def at(self, t: float, unwrap_index: int | None = None) -> np.ndarray:
        """The value at time ``t``: linear interpolation, the oldest sample before the history starts."""
        items = self.items
        if t <= items[0][0]:
            return items[0][1].copy()
        if t >= items[-1][0]:
            return items[-1][1].copy()
        for i in range(len(items) - 1, 0, -1):  # newest first: the lag is short
            t0, v0 = items[i - 1]
            t1, v1 = items[i]
            if t0 <= t <= t1:
                w = 0.0 if t1 == t0 else (t - t0) / (t1 - t0)
                d = v1 - v0
                if unwrap_index is not None:  # a heading crossing ±π interpolates the short way
                    d[unwrap_index] = wrap_pi(float(d[unwrap_index]))
                return v0 + w * d
        return items[-1][1].copy()


class SensorModel:
    """Turns the plant's true state into autopilot readings; call :meth:`sample` in time order."""

    def __init__(self, params: SensorParams | None = None, rng: np.random.Generator | None = None) -> None:
        self.params = params or SensorParams()
        self.rng = rng if rng is not None else np.random.default_rng(0)
        keep = max(self.params.gps_lag_ms, self.params.att_lag_ms) / 1000.0 + 1.0
        self._att = _History(keep)
        self._nav = _History(keep)
        self._next_fix_s: float | None = None
        self._fix: tuple[np.ndarray, np.ndarray, float] | None = None

    def sample(self, t_s: float, eta: np.ndarray, nu: np.ndarray,
               specific_force_body: np.ndarray | None = None) -> SensorReading:
        """Readings at time ``t_s`` from the true η = [N, E, D, φ, θ, ψ] and ν = [u, v, w, p, q, r]."""
        p = self.params
        eta = np.asarray(eta, float)
        nu = np.asarray(nu, float)
        att_true = np.concatenate([eta[3:6], nu[3:6]])
        R = rotation_body_to_ned(float(eta[3]), float(eta[4]), float(eta[5]))
        self._att.push(t_s, att_true)
        self._nav.push(t_s, np.concatenate([eta[0:3], R @ nu[0:3]]))

        att = self._att.at(t_s - p.att_lag_ms / 1000.0, unwrap_index=2)
        attitude = att[0:3] + self.rng.normal(0.0, math.radians(p.att_noise_deg), 3)
        attitude[2] = wrap_pi(float(attitude[2]))
        rates = att[3:6] + self.rng.normal(0.0, math.radians(p.gyro_noise_dps), 3)

        fresh = self._update_fix(t_s)
        assert self._fix is not None
        position, velocity, fix_time = self._fix

        accel = None
        if specific_force_body is not None:
            accel = np.asarray(specific_force_body, float) + self.rng.normal(0.0, p.accel_noise_mps2, 3)
        return SensorReading(t_s, attitude, rates, position.copy(), velocity.copy(), accel, fix_time, fresh)

    def _update_fix(self, t_s: float) -> bool:
        """Take a new GPS fix when one is due (every sample if gps_hz is 0); True if one was taken."""
        p = self.params
        if p.gps_hz > 0 and self._next_fix_s is not None and t_s < self._next_fix_s - 1e-9:
            return False
        if p.gps_hz > 0:
            period = 1.0 / p.gps_hz
            self._next_fix_s = (math.floor(t_s / period + 1e-9) + 1) * period
        fix_time = t_s - p.gps_lag_ms / 1000.0
        nav = self._nav.at(fix_time)
        noise_pos = self.rng.normal(0.0, 1.0, 3) * np.array([p.gps_hpos_noise_m, p.gps_hpos_noise_m,
                                                              p.gps_vpos_noise_m])
        position = nav[0:3] + noise_pos
        position[2] -= p.gps_alt_noise_m * math.sin(t_s * 1000.0 * 0.0005)  # altitude error: down = −alt
        velocity = nav[3:6] + self.rng.normal(0.0, p.gps_vel_noise_mps, 3)
        self._fix = (position, velocity, fix_time)
        return True
