"""Telemetry of the plant's state as a Rover reports it: fix, position, velocity, attitude, IMU, home.

Values come from the simulator's sensors (``sim_vehicle.sensing``: noisy, lagged, GPS at its own rate)
or, with ideal sensing, from the true state. Also the simulated clock every message is stamped with
(``time_boot_ms``, ``time_usec``).
"""

from __future__ import annotations

import math

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim_vehicle.physics import Physics, ned_velocity
from sim_vehicle.rover.vehicle import Vehicle
from vessel.geo import Home, wrap_pi

MG_PER_MPS2 = 1000.0 / 9.80665  # ArduPilot reports accelerations in mG with GRAVITY_MSS


def cdeg(rad: float) -> int:
    """Heading in centidegrees 0..35999."""
    return round(math.degrees(rad) * 100.0) % 36000


def i16(value: float) -> int:
    """Clamp into int16."""
    return max(-32768, min(32767, round(value)))


class SimClock:
    """Simulated time since boot, read from the plant (the simulator owns time)."""

    def __init__(self, physics: Physics) -> None:
        self.physics = physics

    @property
    def t(self) -> float:
        """Simulated time since boot, s."""
        return self.physics.plant.time

    @property
    def boot_ms(self) -> int:
        """time_boot_ms (wraps like a uint32)."""
        return round(self.t * 1000.0) % 2**32

    @property
    def boot_us(self) -> int:
        """Simulated microseconds since boot."""
        return round(self.t * 1e6)


class PlantTelemetry(SimClock):
    """GPS_RAW_INT, ATTITUDE, GLOBAL_POSITION_INT, LOCAL_POSITION_NED, VFR_HUD, HOME_POSITION, GPS_GLOBAL_ORIGIN."""

    def __init__(self, physics: Physics, vehicle: Vehicle, home: Home) -> None:
        super().__init__(physics)
        self.vehicle, self.home = vehicle, home

    def _nav(self) -> tuple[tuple[float, float, float], tuple[float, float, float], float]:
        """(N, E, D m from home; vN, vE, vD m/s; time s the values are from): the GPS fix or the true state."""
        fix = self.physics.sensing.gps() if self.physics.sensing is not None else None
        if fix is None:
            x = self.physics.plant.state
            return (float(x[0]), float(x[1]), float(x[2])), ned_velocity(x), self.t
        pos, vel, t_fix = fix
        return (float(pos[0]), float(pos[1]), float(pos[2])), (float(vel[0]), float(vel[1]), float(vel[2])), t_fix

    def _attitude(self) -> tuple[list[float], list[float]]:
        """(φ, θ, ψ) rad and (p, q, r) rad/s as reported: sensed, or the true state."""
        if self.physics.sensing is None:
            x = self.physics.plant.state
            return [float(v) for v in x[3:6]], [float(v) for v in x[9:12]]
        att, rates = self.physics.sensing.attitude()
        return [float(v) for v in att], [float(v) for v in rates]

    def gps_raw_int(self) -> mavlink.MAVLink_message:
        """A 3-D fix; ``time_usec`` is when the latest fix arrived (boot clock), as Rover sends it."""
        (n, e, d), (vn, ve, _), t_fix = self._nav()
        lat, lon, alt = self.home.to_geodetic(n, e, d)
        speed = math.hypot(vn, ve)
        cog = cdeg(math.atan2(ve, vn)) if speed > 0.05 else 0
        return mavlink.MAVLink_gps_raw_int_message(
            time_usec=round(t_fix * 1e6),
            fix_type=mavlink.GPS_FIX_TYPE_3D_FIX,
            lat=round(lat * 1e7),
            lon=round(lon * 1e7),
            alt=round(alt * 1000),
            eph=80,
            epv=120,
            vel=min(65534, round(speed * 100)),
            cog=cog,
            satellites_visible=12,
            alt_ellipsoid=round(alt * 1000),
            h_acc=300,
            v_acc=500,
            vel_acc=20,
            hdg_acc=0,
            yaw=0,
        )

    def attitude(self) -> mavlink.MAVLink_message:
        """Euler angles and body rates (the AHRS estimate; exact with ideal sensing)."""
        (roll, pitch, yaw), (p, q, r) = self._attitude()
        return mavlink.MAVLink_attitude_message(
            time_boot_ms=self.boot_ms, roll=roll, pitch=pitch, yaw=wrap_pi(yaw),
            rollspeed=p, pitchspeed=q, yawspeed=r,
        )

    def global_position_int(self) -> mavlink.MAVLink_message:
        """Position, NED velocity and heading."""
        (n, e, d), (vn, ve, vd), _ = self._nav()
        lat, lon, alt = self.home.to_geodetic(n, e, d)
        return mavlink.MAVLink_global_position_int_message(
            time_boot_ms=self.boot_ms,
            lat=round(lat * 1e7),
            lon=round(lon * 1e7),
            alt=round(alt * 1000),
            relative_alt=round(-d * 1000),
            vx=i16(vn * 100),
            vy=i16(ve * 100),
            vz=i16(vd * 100),
            hdg=cdeg(self._attitude()[0][2]),
        )

    def local_position_ned(self) -> mavlink.MAVLink_message:
        """Position and velocity relative to the EKF origin (home)."""
        (n, e, d), (vn, ve, vd), _ = self._nav()
        return mavlink.MAVLink_local_position_ned_message(
            time_boot_ms=self.boot_ms, x=n, y=e, z=d, vx=vn, vy=ve, vz=vd
        )

    def _imu(self) -> tuple[list[float], list[float]]:
        """(body specific force m/s², body rates rad/s), FRD."""
        sensing = self.physics.sensing
        if sensing is None:
            return [0.0, 0.0, -9.81], [float(v) for v in self.physics.plant.state[9:12]]
        force, rates = sensing.imu_reading()
        return [float(v) for v in force], [float(v) for v in rates]

    def _imu_fields(self) -> dict[str, int]:
        """The accelerometer (mG) and gyro (mrad/s) fields shared by RAW_IMU and SCALED_IMU*."""
        force, rates = self._imu()
        acc = {f"{a}acc": i16(v * MG_PER_MPS2) for a, v in zip("xyz", force, strict=True)}
        gyro = {f"{a}gyro": i16(v * 1000.0) for a, v in zip("xyz", rates, strict=True)}
        return {**acc, **gyro, "xmag": 0, "ymag": 0, "zmag": 0}

    def raw_imu(self) -> mavlink.MAVLink_message:
        """RAW_IMU as ArduPilot fills it: the first IMU's values in mG and mrad/s (RAW_SENS stream)."""
        return mavlink.MAVLink_raw_imu_message(time_usec=self.boot_us, id=0, temperature=0, **self._imu_fields())

    def scaled_imu(self) -> mavlink.MAVLink_message:
        """SCALED_IMU: the first IMU (on request only, as in Rover)."""
        return mavlink.MAVLink_scaled_imu_message(time_boot_ms=self.boot_ms, temperature=0, **self._imu_fields())

    def scaled_imu2(self) -> mavlink.MAVLink_message:
        """SCALED_IMU2: the second IMU (RAW_SENS stream; SITL has two): here the same sensor's reading."""
        return mavlink.MAVLink_scaled_imu2_message(time_boot_ms=self.boot_ms, temperature=0, **self._imu_fields())

    def vfr_hud(self) -> mavlink.MAVLink_message:
        """Ground speed (also in the airspeed field), heading, throttle %, altitude, climb."""
        (n, e, d), (vn, ve, vd), _ = self._nav()
        speed = math.hypot(vn, ve)
        _, _, alt = self.home.to_geodetic(n, e, d)
        return mavlink.MAVLink_vfr_hud_message(
            airspeed=speed,
            groundspeed=speed,
            heading=cdeg(self._attitude()[0][2]) // 100,
            throttle=min(100, round(abs(self.vehicle.throttle) * 100)),
            alt=alt,
            climb=-vd,
        )

    def home_position(self) -> mavlink.MAVLink_message:
        """Home (also the EKF origin)."""
        h = self.home
        return mavlink.MAVLink_home_position_message(
            latitude=round(h.lat_deg * 1e7),
            longitude=round(h.lon_deg * 1e7),
            altitude=round(h.alt_m * 1000),
            x=0,
            y=0,
            z=0,
            q=[1, 0, 0, 0],
            approach_x=0,
            approach_y=0,
            approach_z=0,
            time_usec=self.boot_us,
        )

    def gps_global_origin(self) -> mavlink.MAVLink_message:
        """The EKF origin (home)."""
        h = self.home
        return mavlink.MAVLink_gps_global_origin_message(
            latitude=round(h.lat_deg * 1e7),
            longitude=round(h.lon_deg * 1e7),
            altitude=round(h.alt_m * 1000),
            time_usec=self.boot_us,
        )
