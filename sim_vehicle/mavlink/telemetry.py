"""Builds the telemetry messages a Rover sends, from the simulator's true state and the vehicle's view."""

from __future__ import annotations

import math

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim_vehicle.mavlink.telemetry_plant import PlantTelemetry, SimClock, i16
from sim_vehicle.physics import Physics, nav_state
from sim_vehicle.rover.auto import MissionRunner
from sim_vehicle.rover.battery import Battery
from sim_vehicle.rover.mission import MissionStore
from sim_vehicle.rover.modes import MODE_INFO, Mode, base_mode
from sim_vehicle.rover.params import ParamTable
from sim_vehicle.rover.vehicle import Vehicle
from vessel.geo import Home, wrap_pi

FIRMWARE_VERSION = (4, 5, 7)  # the ArduRover release whose behaviour this simulator follows
M = mavlink
# no FTP, terrain or compass calibration here
CAPABILITIES = (
    M.MAV_PROTOCOL_CAPABILITY_MISSION_FLOAT
    | M.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT
    | M.MAV_PROTOCOL_CAPABILITY_MISSION_INT
    | M.MAV_PROTOCOL_CAPABILITY_COMMAND_INT
    | M.MAV_PROTOCOL_CAPABILITY_SET_ATTITUDE_TARGET
    | M.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED
    | M.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_GLOBAL_INT
    | M.MAV_PROTOCOL_CAPABILITY_MAVLINK2
    | M.MAV_PROTOCOL_CAPABILITY_MISSION_FENCE
    | M.MAV_PROTOCOL_CAPABILITY_MISSION_RALLY
)
SENSORS = (
    M.MAV_SYS_STATUS_SENSOR_3D_GYRO
    | M.MAV_SYS_STATUS_SENSOR_3D_ACCEL
    | M.MAV_SYS_STATUS_SENSOR_3D_MAG
    | M.MAV_SYS_STATUS_SENSOR_GPS
    | M.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS
    | M.MAV_SYS_STATUS_AHRS
    | M.MAV_SYS_STATUS_SENSOR_BATTERY
)
RC_RECEIVER_BIT = M.MAV_SYS_STATUS_SENSOR_RC_RECEIVER
PREARM_BIT = M.MAV_SYS_STATUS_PREARM_CHECK
# No fence is simulated, so the GEOFENCE bit reads as ArduPilot's does with none (FENCE_ENABLE 0): not present,
# not enabled, healthy ("not failed if not present"). A clear health bit reads as a breach to ground stations
# (MAVProxy says "fence breach").
GEOFENCE_BIT = M.MAV_SYS_STATUS_GEOFENCE


def sensor_bits(rc_present: bool, rc_healthy: bool, prearm_ok: bool) -> tuple[int, int, int]:
    """SYS_STATUS (present, enabled, health) bitmasks: the fixed sensors, the RC receiver once RC was seen (healthy
    while its failsafe is clear), the pre-arm check (healthy when it passes) and the absent fence's health."""
    present = SENSORS | PREARM_BIT
    healthy = SENSORS | GEOFENCE_BIT
    if rc_present:
        present |= RC_RECEIVER_BIT
        if rc_healthy:
            healthy |= RC_RECEIVER_BIT
    if prearm_ok:
        healthy |= PREARM_BIT
    return present, present, healthy
FRAME_CLASS_BOAT = 2


def _nav_controller_output(
    heading: float, bearing: float, distance_m: float, speed_error: float, xtrack_m: float
) -> mavlink.MAVLink_message:
    """NAV_CONTROLLER_OUTPUT: desired heading and bearing to the target (rad, NED), distance, errors."""
    return mavlink.MAVLink_nav_controller_output_message(
        nav_roll=0,
        nav_pitch=0,
        nav_bearing=i16(math.degrees(heading)),
        target_bearing=i16(math.degrees(bearing)),
        wp_dist=min(65535, round(distance_m)),
        alt_error=0,
        aspd_error=speed_error,
        xtrack_error=xtrack_m,
    )


class Telemetry(SimClock):
    """Message factory reading the live simulator objects at the moment a message is built.

    Status messages are built here; those of the plant's state by ``plant`` (a PlantTelemetry).
    """

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
        super().__init__(physics)
        self.vehicle, self.home, self.params = vehicle, home, params
        self.plant = PlantTelemetry(physics, vehicle, home)
        self.store, self.runner, self.battery = store, runner, battery
        self.boot_unix_us = boot_unix_us
        self.builders = {
            M.MAVLINK_MSG_ID_HEARTBEAT: self.heartbeat,
            M.MAVLINK_MSG_ID_SYS_STATUS: self.sys_status,
            M.MAVLINK_MSG_ID_SYSTEM_TIME: self.system_time,
            M.MAVLINK_MSG_ID_GPS_RAW_INT: self.plant.gps_raw_int,
            M.MAVLINK_MSG_ID_ATTITUDE: self.plant.attitude,
            M.MAVLINK_MSG_ID_LOCAL_POSITION_NED: self.plant.local_position_ned,
            M.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: self.plant.global_position_int,
            M.MAVLINK_MSG_ID_RC_CHANNELS_SCALED: self.rc_channels_scaled,
            M.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW: self.servo_output_raw,
            M.MAVLINK_MSG_ID_MISSION_CURRENT: self.mission_current,
            M.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN: self.plant.gps_global_origin,
            M.MAVLINK_MSG_ID_NAV_CONTROLLER_OUTPUT: self.nav_controller_output,
            M.MAVLINK_MSG_ID_RC_CHANNELS: self.rc_channels,
            M.MAVLINK_MSG_ID_VFR_HUD: self.plant.vfr_hud,
            M.MAVLINK_MSG_ID_BATTERY_STATUS: self.battery_status,
            M.MAVLINK_MSG_ID_AUTOPILOT_VERSION: self.autopilot_version,
            M.MAVLINK_MSG_ID_HOME_POSITION: self.plant.home_position,
            M.MAVLINK_MSG_ID_RAW_IMU: self.plant.raw_imu,
            M.MAVLINK_MSG_ID_SCALED_IMU: self.plant.scaled_imu,
            M.MAVLINK_MSG_ID_SCALED_IMU2: self.plant.scaled_imu2,
        }

    # time

    def build(self, msg_id: int) -> mavlink.MAVLink_message | None:
        """The message with ``msg_id`` now, or None if not available (unknown id, or not in this mode)."""
        builder = self.builders.get(msg_id)
        return builder() if builder is not None else None

    # messages
    def heartbeat(self) -> mavlink.MAVLink_message:
        """Rover boat heartbeat."""
        v = self.vehicle
        if v.failsafes.active:
            status = mavlink.MAV_STATE_CRITICAL
        elif v.mode == Mode.HOLD:
            status = mavlink.MAV_STATE_STANDBY
        else:
            status = mavlink.MAV_STATE_ACTIVE
        vtype = (
            mavlink.MAV_TYPE_SURFACE_BOAT
            if self.params["FRAME_CLASS"] == FRAME_CLASS_BOAT
            else mavlink.MAV_TYPE_GROUND_ROVER
        )
        return mavlink.MAVLink_heartbeat_message(
            type=vtype,
            autopilot=mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA,
            base_mode=base_mode(v.mode, v.armed),
            custom_mode=int(v.mode),
            system_status=status,
            mavlink_version=3,
        )

    def sys_status(self) -> mavlink.MAVLink_message:
        """Sensor bits, load and battery."""
        v = self.vehicle
        present, enabled, healthy = sensor_bits(v.rc.receiver or v.rc.last_override_time is not None,
                                                not v.failsafes.rc.triggered, v.armed or not v.prearm_failure())
        b = self.battery
        return mavlink.MAVLink_sys_status_message(
            onboard_control_sensors_present=present,
            onboard_control_sensors_enabled=enabled,
            onboard_control_sensors_health=healthy,
            load=150,
            voltage_battery=b.voltage_mv,
            current_battery=round(b.current_a * 100),
            battery_remaining=b.remaining_pct,
            drop_rate_comm=0,
            errors_comm=0,
            errors_count1=0,
            errors_count2=0,
            errors_count3=0,
            errors_count4=0,
        )

    def system_time(self) -> mavlink.MAVLink_message:
        """Unix time on the simulated clock."""
        return mavlink.MAVLink_system_time_message(
            time_unix_usec=self.boot_unix_us + self.boot_us, time_boot_ms=self.boot_ms
        )

    def servo_output_raw(self) -> mavlink.MAVLink_message:
        """PWM on outputs 1-16."""
        pwm = [p if 0 <= p < 65535 else 0 for p in self.vehicle.servos.pwm]
        servos = {f"servo{n}_raw": value for n, value in enumerate(pwm, start=1)}
        return mavlink.MAVLink_servo_output_raw_message(time_usec=self.boot_us % 2**32, port=0, **servos)

    def rc_channels(self) -> mavlink.MAVLink_message:
        """Effective RC input (receiver and overrides)."""
        v = self.vehicle
        pwm = [max(0, min(65535, p)) for p in v.rc.all_pwm(v.now, self.params["RC_OVERRIDE_TIME"])]
        count = 16 if v.rc.receiver else sum(1 for p in pwm if p > 0)
        chans = {f"chan{n}_raw": value for n, value in enumerate([*pwm, 0, 0][:18], start=1)}
        return mavlink.MAVLink_rc_channels_message(time_boot_ms=self.boot_ms, chancount=count, rssi=255, **chans)

    def rc_channels_scaled(self) -> mavlink.MAVLink_message:
        """Skid outputs as Rover's "servo out": chan1 left, chan3 right, ±10000."""
        left, right = self.vehicle.outputs
        scaled = {f"chan{n}_scaled": 0 for n in range(1, 9)}
        scaled.update(chan1_scaled=i16(left * 10000), chan3_scaled=i16(right * 10000))
        return mavlink.MAVLink_rc_channels_scaled_message(time_boot_ms=self.boot_ms, port=0, rssi=255, **scaled)

    def mission_current(self) -> mavlink.MAVLink_message:
        """Current nav item, the last seq and the mission state."""
        total = max(0, len(self.store.items(0)) - 1)
        seq = self.runner.current if self.store.present() else 0
        state = self.runner.mission_state(self.vehicle.mode == Mode.AUTO)
        return mavlink.MAVLink_mission_current_message(seq=seq, total=total, mission_state=state, mission_mode=0)

    def nav_controller_output(self) -> mavlink.MAVLink_message | None:
        """Navigator state, only in autopilot modes."""
        v = self.vehicle
        if not MODE_INFO[v.mode].autopilot:
            return None
        out, guided = v.navigator.output, v.navigator.guided
        nav = nav_state(self.physics.plant.state)
        if out is None:
            heading = guided.heading if guided is not None and guided.heading is not None else nav.yaw
            return _nav_controller_output(heading, heading, 0.0, 0.0, 0.0)
        return _nav_controller_output(
            wrap_pi(out.heading), wrap_pi(out.bearing), out.distance, out.speed - nav.forward_speed, out.xtrack
        )

    def battery_status(self) -> mavlink.MAVLink_message:
        """The one battery."""
        b = self.battery
        cells = [min(65534, b.voltage_mv)] + [65535] * 9
        return mavlink.MAVLink_battery_status_message(
            id=0,
            battery_function=mavlink.MAV_BATTERY_FUNCTION_UNKNOWN,
            type=mavlink.MAV_BATTERY_TYPE_UNKNOWN,
            temperature=32767,  # unknown
            voltages=cells,
            current_battery=round(b.current_a * 100),
            current_consumed=round(b.consumed_mah),
            energy_consumed=-1,
            battery_remaining=b.remaining_pct,
            time_remaining=0,
            charge_state=mavlink.MAV_BATTERY_CHARGE_STATE_OK,
            voltages_ext=[0, 0, 0, 0],
            mode=0,
            fault_bitmask=0,
        )

    def autopilot_version(self) -> mavlink.MAVLink_message:
        """Capabilities (MISSION_INT among them) and the firmware version followed."""
        major, minor, patch = FIRMWARE_VERSION
        version = major << 24 | minor << 16 | patch << 8 | 255
        return mavlink.MAVLink_autopilot_version_message(
            capabilities=CAPABILITIES,
            flight_sw_version=version,
            middleware_sw_version=0,
            os_sw_version=0,
            board_version=0,
            flight_custom_version=b"\0" * 8,
            middleware_custom_version=b"\0" * 8,
            os_custom_version=b"\0" * 8,
            vendor_id=0,
            product_id=0,
            uid=0,
            uid2=[0] * 18,
        )
