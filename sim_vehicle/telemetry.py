"""Builds the telemetry messages a Rover sends, from the simulator's true state and the vehicle's view."""

from __future__ import annotations

import math
from dataclasses import dataclass

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from vessel.geo import Home, wrap_pi

from .auto import MissionRunner
from .mission import MissionStore
from .modes import MODE_INFO, Mode, base_mode
from .params import ParamTable
from .physics import Physics, nav_state, ned_velocity
from .vehicle import Vehicle

FIRMWARE_VERSION = (4, 5, 7)  # the ArduRover release whose behaviour this simulator follows
# MISSION_FLOAT, PARAM_FLOAT, MISSION_INT, COMMAND_INT, SET_ATTITUDE_TARGET, SET_POSITION_TARGET_LOCAL_NED and
# _GLOBAL_INT, MAVLINK2, MISSION_FENCE, MISSION_RALLY (no FTP, terrain or compass calibration here)
CAPABILITIES = 1 | 2 | 4 | 8 | 64 | 128 | 256 | 8192 | 16384 | 32768
SENSORS = (
    0x1 | 0x2 | 0x4 | 0x20 | 0x8000 | 0x200000 | 0x2000000
)  # gyro, accel, mag, GPS, motors, AHRS, battery
RC_RECEIVER_BIT = 0x10000
PREARM_BIT = 0x10000000
BATTERY_CAPACITY_MAH = 96000.0  # the Otter's 4 x 24 Ah packs
BATTERY_VOLTS = 25.2


@dataclass
class Battery:
    """A simple energy account: current from propeller demand, remaining charge by coulomb counting."""

    consumed_mah: float = 0.0
    current_a: float = 1.0

    def update(self, outputs: tuple[float, float], dt: float) -> None:
        """Hotel load plus a thruster load rising with |output|^1.5 (40 A per motor at full power)."""
        self.current_a = 1.0 + 40.0 * sum(abs(o) ** 1.5 for o in outputs)
        self.consumed_mah += self.current_a * dt / 3.6

    @property
    def remaining_pct(self) -> int:
        """Remaining charge, %."""
        return max(0, min(100, round(100.0 * (1.0 - self.consumed_mah / BATTERY_CAPACITY_MAH))))

    @property
    def voltage_mv(self) -> int:
        """Pack voltage sagging slightly with load and charge used, mV."""
        return round(
            1000.0 * (BATTERY_VOLTS - 0.02 * self.current_a - 3.0 * self.consumed_mah / BATTERY_CAPACITY_MAH)
        )


def _cdeg(rad: float) -> int:
    """Heading in centidegrees 0..35999."""
    return round(math.degrees(rad) * 100.0) % 36000


def _i16(value: float) -> int:
    """Clamp into int16."""
    return max(-32768, min(32767, round(value)))


class Telemetry:
    """Message factory reading the live simulator objects at the moment a message is built."""

    def __init__(
        self,
        physics: Physics,
        vehicle: Vehicle,
        home: Home,
        params: ParamTable,
        store: MissionStore,
        runner: MissionRunner,
        battery: Battery,
        boot_unix_us: int,
    ) -> None:
        self.physics, self.vehicle, self.home, self.params = physics, vehicle, home, params
        self.store, self.runner, self.battery = store, runner, battery
        self.boot_unix_us = boot_unix_us
        self.builders = {
            0: self.heartbeat,
            1: self.sys_status,
            2: self.system_time,
            24: self.gps_raw_int,
            30: self.attitude,
            32: self.local_position_ned,
            33: self.global_position_int,
            34: self.rc_channels_scaled,
            36: self.servo_output_raw,
            42: self.mission_current,
            49: self.gps_global_origin,
            62: self.nav_controller_output,
            65: self.rc_channels,
            74: self.vfr_hud,
            147: self.battery_status,
            148: self.autopilot_version,
            242: self.home_position,
        }

    # time
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

    def build(self, msg_id: int) -> mavlink.MAVLink_message | None:
        """The message with ``msg_id`` now, or None if not available (unknown id, or not in this mode)."""
        builder = self.builders.get(msg_id)
        return builder() if builder is not None else None

    # messages
    def heartbeat(self) -> mavlink.MAVLink_message:
        """Rover boat heartbeat."""
        v = self.vehicle
        if v.failsafe_active:
            status = mavlink.MAV_STATE_CRITICAL
        elif v.mode == Mode.HOLD:
            status = mavlink.MAV_STATE_STANDBY
        else:
            status = mavlink.MAV_STATE_ACTIVE
        vtype = (
            mavlink.MAV_TYPE_SURFACE_BOAT
            if self.params["FRAME_CLASS"] == 2
            else mavlink.MAV_TYPE_GROUND_ROVER
        )
        return mavlink.MAVLink_heartbeat_message(
            vtype, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, base_mode(v.mode, v.armed), int(v.mode), status, 3
        )

    def sys_status(self) -> mavlink.MAVLink_message:
        """Sensor bits, load and battery."""
        v = self.vehicle
        present = SENSORS | PREARM_BIT
        healthy = SENSORS
        if v.rc.receiver or v.rc.last_override_time is not None:
            present |= RC_RECEIVER_BIT
            if not v.failsafes["rc"].triggered:
                healthy |= RC_RECEIVER_BIT
        if v.armed or not v.prearm_failure():
            healthy |= PREARM_BIT
        b = self.battery
        return mavlink.MAVLink_sys_status_message(
            present,
            present,
            healthy,
            150,
            b.voltage_mv,
            round(b.current_a * 100),
            b.remaining_pct,
            0,
            0,
            0,
            0,
            0,
            0,
        )

    def system_time(self) -> mavlink.MAVLink_message:
        """Unix time on the simulated clock."""
        return mavlink.MAVLink_system_time_message(self.boot_unix_us + self.boot_us, self.boot_ms)

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
        cog = _cdeg(math.atan2(ve, vn)) if speed > 0.05 else 0
        return mavlink.MAVLink_gps_raw_int_message(
            self.boot_us,
            3,
            round(lat * 1e7),
            round(lon * 1e7),
            round(alt * 1000),
            80,
            120,
            min(65534, round(speed * 100)),
            cog,
            12,
            round(alt * 1000),
            300,
            500,
            20,
            0,
            0,
        )

    def attitude(self) -> mavlink.MAVLink_message:
        """Euler angles and body rates of the plant now."""
        x = self.physics.plant.state
        return mavlink.MAVLink_attitude_message(
            self.boot_ms,
            float(x[3]),
            float(x[4]),
            wrap_pi(float(x[5])),
            float(x[9]),
            float(x[10]),
            float(x[11]),
        )

    def global_position_int(self) -> mavlink.MAVLink_message:
        """Position, NED velocity and heading."""
        x = self.physics.plant.state
        lat, lon, alt = self._position()
        vn, ve, vd = ned_velocity(x)
        return mavlink.MAVLink_global_position_int_message(
            self.boot_ms,
            round(lat * 1e7),
            round(lon * 1e7),
            round(alt * 1000),
            round(-float(x[2]) * 1000),
            _i16(vn * 100),
            _i16(ve * 100),
            _i16(vd * 100),
            _cdeg(float(x[5])),
        )

    def local_position_ned(self) -> mavlink.MAVLink_message:
        """Position and velocity relative to the EKF origin (home)."""
        x = self.physics.plant.state
        vn, ve, vd = ned_velocity(x)
        return mavlink.MAVLink_local_position_ned_message(
            self.boot_ms, float(x[0]), float(x[1]), float(x[2]), vn, ve, vd
        )

    def vfr_hud(self) -> mavlink.MAVLink_message:
        """Ground speed (also in the airspeed field), heading, throttle %, altitude, climb."""
        x = self.physics.plant.state
        vn, ve, vd = ned_velocity(x)
        speed = math.hypot(vn, ve)
        _, _, alt = self._position()
        return mavlink.MAVLink_vfr_hud_message(
            speed,
            speed,
            _cdeg(float(x[5])) // 100,
            min(100, round(abs(self.vehicle.throttle) * 100)),
            alt,
            -vd,
        )

    def servo_output_raw(self) -> mavlink.MAVLink_message:
        """PWM on outputs 1-16."""
        pwm = [p if 0 <= p < 65535 else 0 for p in self.vehicle.servo_pwm]
        return mavlink.MAVLink_servo_output_raw_message(self.boot_us % 2**32, 0, *pwm)

    def rc_channels(self) -> mavlink.MAVLink_message:
        """Effective RC input (receiver and overrides)."""
        v = self.vehicle
        pwm = [max(0, min(65535, p)) for p in v.rc.all_pwm(v.now, self.params["RC_OVERRIDE_TIME"])]
        count = 16 if v.rc.receiver else sum(1 for p in pwm if p > 0)
        return mavlink.MAVLink_rc_channels_message(self.boot_ms, count, *pwm, 0, 0, 255)

    def rc_channels_scaled(self) -> mavlink.MAVLink_message:
        """Skid outputs as Rover's "servo out": chan1 left, chan3 right, ±10000."""
        left, right = self.vehicle.outputs
        return mavlink.MAVLink_rc_channels_scaled_message(
            self.boot_ms, 0, _i16(left * 10000), 0, _i16(right * 10000), 0, 0, 0, 0, 0, 255
        )

    def mission_current(self) -> mavlink.MAVLink_message:
        """Current nav item, the last seq and the mission state."""
        total = max(0, len(self.store.items(0)) - 1)
        seq = self.runner.current if self.store.present() else 0
        state = self.runner.mission_state(self.vehicle.mode == Mode.AUTO)
        return mavlink.MAVLink_mission_current_message(seq, total, state, 0)

    def nav_controller_output(self) -> mavlink.MAVLink_message | None:
        """Navigator state, only in autopilot modes."""
        v = self.vehicle
        if not MODE_INFO[v.mode].autopilot:
            return None
        out = v.nav_output
        nav = nav_state(self.physics.plant.state)
        if out is None:
            heading = v.guided.heading if v.guided is not None and v.guided.heading is not None else nav.yaw
            return mavlink.MAVLink_nav_controller_output_message(
                0, 0, _i16(math.degrees(heading)), _i16(math.degrees(heading)), 0, 0, 0, 0
            )
        return mavlink.MAVLink_nav_controller_output_message(
            0,
            0,
            _i16(math.degrees(wrap_pi(out.heading))),
            _i16(math.degrees(wrap_pi(out.bearing))),
            min(65535, round(out.distance)),
            0,
            out.speed - nav.forward_speed,
            out.xtrack,
        )

    def battery_status(self) -> mavlink.MAVLink_message:
        """The one battery."""
        b = self.battery
        cells = [min(65534, b.voltage_mv)] + [65535] * 9
        return mavlink.MAVLink_battery_status_message(
            0,
            0,
            0,
            32767,
            cells,
            round(b.current_a * 100),
            round(b.consumed_mah),
            -1,
            b.remaining_pct,
            0,
            1,
            [0, 0, 0, 0],
            0,
            0,
        )

    def home_position(self) -> mavlink.MAVLink_message:
        """Home (also the EKF origin)."""
        h = self.home
        return mavlink.MAVLink_home_position_message(
            round(h.lat_deg * 1e7),
            round(h.lon_deg * 1e7),
            round(h.alt_m * 1000),
            0,
            0,
            0,
            [1, 0, 0, 0],
            0,
            0,
            0,
            self.boot_us,
        )

    def gps_global_origin(self) -> mavlink.MAVLink_message:
        """The EKF origin (home)."""
        h = self.home
        return mavlink.MAVLink_gps_global_origin_message(
            round(h.lat_deg * 1e7), round(h.lon_deg * 1e7), round(h.alt_m * 1000), self.boot_us
        )

    def autopilot_version(self) -> mavlink.MAVLink_message:
        """Capabilities (MISSION_INT among them) and the firmware version followed."""
        major, minor, patch = FIRMWARE_VERSION
        version = major << 24 | minor << 16 | patch << 8 | 255
        return mavlink.MAVLink_autopilot_version_message(
            CAPABILITIES, version, 0, 0, 0, b"\0" * 8, b"\0" * 8, b"\0" * 8, 0, 0, 0, [0] * 18
        )
