"""Telemetry of the plant's true state as a Rover reports it: fix, position, velocity, attitude, home.

Also the simulated clock every message is stamped with (``time_boot_ms``, ``time_usec``).
"""

from __future__ import annotations

import math

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from vessel.geo import Home, wrap_pi

from .physics import Physics, ned_velocity
from .vehicle import Vehicle


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

    def _position(self) -> tuple[float, float, float]:
        """Latitude, longitude (deg) and altitude AMSL (m) of the boat now."""
        x = self.physics.plant.state
        return self.home.to_geodetic(float(x[0]), float(x[1]), float(x[2]))

    def gps_raw_int(self) -> mavlink.MAVLink_message:
        """A perfect 3-D fix."""
        x = self.physics.plant.state
        lat, lon, alt = self._position()
        vn, ve, _ = ned_velocity(x)
        speed = math.hypot(vn, ve)
        cog = cdeg(math.atan2(ve, vn)) if speed > 0.05 else 0
        return mavlink.MAVLink_gps_raw_int_message(
            time_usec=self.boot_us,
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
        """Euler angles and body rates of the plant now."""
        x = self.physics.plant.state
        return mavlink.MAVLink_attitude_message(
            time_boot_ms=self.boot_ms,
            roll=float(x[3]),
            pitch=float(x[4]),
            yaw=wrap_pi(float(x[5])),
            rollspeed=float(x[9]),
            pitchspeed=float(x[10]),
            yawspeed=float(x[11]),
        )

    def global_position_int(self) -> mavlink.MAVLink_message:
        """Position, NED velocity and heading."""
        x = self.physics.plant.state
        lat, lon, alt = self._position()
        vn, ve, vd = ned_velocity(x)
        return mavlink.MAVLink_global_position_int_message(
            time_boot_ms=self.boot_ms,
            lat=round(lat * 1e7),
            lon=round(lon * 1e7),
            alt=round(alt * 1000),
            relative_alt=round(-float(x[2]) * 1000),
            vx=i16(vn * 100),
            vy=i16(ve * 100),
            vz=i16(vd * 100),
            hdg=cdeg(float(x[5])),
        )

    def local_position_ned(self) -> mavlink.MAVLink_message:
        """Position and velocity relative to the EKF origin (home)."""
        x = self.physics.plant.state
        vn, ve, vd = ned_velocity(x)
        return mavlink.MAVLink_local_position_ned_message(
            time_boot_ms=self.boot_ms, x=float(x[0]), y=float(x[1]), z=float(x[2]), vx=vn, vy=ve, vz=vd
        )

    def vfr_hud(self) -> mavlink.MAVLink_message:
        """Ground speed (also in the airspeed field), heading, throttle %, altitude, climb."""
        x = self.physics.plant.state
        vn, ve, vd = ned_velocity(x)
        speed = math.hypot(vn, ve)
        _, _, alt = self._position()
        return mavlink.MAVLink_vfr_hud_message(
            airspeed=speed,
            groundspeed=speed,
            heading=cdeg(float(x[5])) // 100,
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
