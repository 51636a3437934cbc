"""What a DataFlash or Otter API log holds, said as the MAVLink messages an ArduPilot autopilot streams.

Built with pymavlink's own message classes (the ``ardupilotmega`` dialect the companion speaks), in the units
and scales of the wire: angles in rad, rates in rad/s, latitude/longitude in 1e-7 degrees, velocities in
cm/s (NED), specific force in milli-g (ArduPilot's SCALED_IMU: divided by 9.80665 m/s²), PWM in µs.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from mavbridge.link.connection import mavlink
from vessel.geo import latlon_from_ned

GRAVITY_MSS = 9.80665  # ArduPilot's milli-g scale (as mavbridge.companion.state reads it back)
ARMED = mavlink.MAV_MODE_FLAG_SAFETY_ARMED
CUSTOM = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
POSITION_ONLY = 0b1101_1111_1000  # POSITION_TARGET_TYPEMASK: velocity, acceleration, yaw and yaw rate ignored


def _clip_int(value: float, lo: int, hi: int) -> int:
    return int(max(lo, min(hi, round(value))))


def attitude(ms: int, roll: float, pitch: float, yaw: float, rates: Sequence[float]) -> object:
    """ATTITUDE: Euler angles (rad, yaw within ±π) and body rates p, q, r (rad/s) at ``ms`` since boot."""
    return mavlink.MAVLink_attitude_message(ms, roll, pitch, math.remainder(yaw, 2 * math.pi), *rates)


def position(ms: int, lat_deg: float, lon_deg: float, alt_m: float, velocity_ned: Sequence[float],
             course_deg: float | None = None) -> object:
    """GLOBAL_POSITION_INT: position (deg, m above sea level and above home alike) and NED velocity (m/s)."""
    vn, ve, vd = (_clip_int(v * 100.0, -32768, 32767) for v in velocity_ned)
    heading = 65535 if course_deg is None else _clip_int((course_deg % 360.0) * 100.0, 0, 35999)
    return mavlink.MAVLink_global_position_int_message(ms, round(lat_deg * 1e7), round(lon_deg * 1e7),
                                                       round(alt_m * 1000), round(alt_m * 1000), vn, ve, vd, heading)


def imu(ms: int, accel_mss: Sequence[float], gyro_rad_s: Sequence[float]) -> object:
    """SCALED_IMU: body FRD specific force (m/s² → milli-g) and rates (rad/s → mrad/s)."""
    acc = [_clip_int(a / GRAVITY_MSS * 1000.0, -32768, 32767) for a in accel_mss]
    gyr = [_clip_int(g * 1000.0, -32768, 32767) for g in gyro_rad_s]
    return mavlink.MAVLink_scaled_imu_message(ms, *acc, *gyr, 0, 0, 0)


def named_value(ms: int, name: str, value: float) -> object:
    """NAMED_VALUE_FLOAT ``name`` (at most 10 characters) = ``value`` at ``ms`` since boot: a figure MAVLink has no
    message for (an autopilot's script, or the Otter API's shaft speeds and controller forces)."""
    return mavlink.MAVLink_named_value_float_message(ms, name.encode()[:10], float(value))


def position_target(ms: int, lat_deg: float, lon_deg: float, north_m: float, east_m: float) -> object:
    """POSITION_TARGET_GLOBAL_INT of a target ``north_m``/``east_m`` from a reference at ``lat_deg``/``lon_deg``
    (flat earth): its position only (velocity, acceleration and yaw ignored, as the type mask says)."""
    lat, lon = latlon_from_ned(lat_deg, lon_deg, north_m, east_m)
    return mavlink.MAVLink_position_target_global_int_message(ms, mavlink.MAV_FRAME_GLOBAL_INT, POSITION_ONLY,
                                                              round(lat * 1e7), round(lon * 1e7), 0.0, 0.0, 0.0,
                                                              0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


def heartbeat(vehicle_type: int, custom_mode: int, armed: bool) -> object:
    """HEARTBEAT of an ArduPilot autopilot of ``vehicle_type`` in ``custom_mode``, armed or not."""
    base = CUSTOM | (ARMED if armed else 0)
    return mavlink.MAVLink_heartbeat_message(vehicle_type, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, base, custom_mode,
                                             mavlink.MAV_STATE_ACTIVE, 3)


def servo_outputs(us: int, pwm: Sequence[int]) -> object:
    """SERVO_OUTPUT_RAW of outputs 1..16 (µs; missing ones 0)."""
    values = [_clip_int(p, 0, 65535) for p in [*pwm, *[0] * 16][:16]]
    return mavlink.MAVLink_servo_output_raw_message(us % 2**32, 0, *values)


def rc_inputs(ms: int, pwm: Sequence[int]) -> object:
    """RC_CHANNELS of inputs 1..18 (µs; missing ones 0)."""
    values = [_clip_int(p, 0, 65535) for p in [*pwm, *[0] * 18][:18]]
    return mavlink.MAVLink_rc_channels_message(ms, sum(1 for p in values if p > 0), *values, 255)


def mission_item(seq: int, command: int, lat_deg: float, lon_deg: float, alt_m: float, frame: int,
                 params: Sequence[float]) -> object:
    """MISSION_ITEM_INT ``seq`` (0 is home on ArduPilot) of the mission."""
    p = [float(v) for v in [*params, 0.0, 0.0, 0.0, 0.0][:4]]
    return mavlink.MAVLink_mission_item_int_message(0, 0, seq, frame, command, 0, 1, *p, round(lat_deg * 1e7),
                                                    round(lon_deg * 1e7), alt_m, mavlink.MAV_MISSION_TYPE_MISSION)


def parameter(name: str, value: float) -> object:
    """PARAM_VALUE ``name`` = ``value`` (as a float, which is how the companion reads it)."""
    return mavlink.MAVLink_param_value_message(name.encode()[:16], float(value), mavlink.MAV_PARAM_TYPE_REAL32, 0, 0)
