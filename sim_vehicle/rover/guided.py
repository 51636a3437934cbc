"""GUIDED-mode targets as Rover reads them from SET_ATTITUDE_TARGET and SET_POSITION_TARGET_* messages."""

from __future__ import annotations

import math
from dataclasses import dataclass

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim_vehicle.rover.control import NavState, NavTarget
from vessel.geo import Home, wrap_pi

M = mavlink
ATT_YAW_RATE_IGNORE = M.ATTITUDE_TARGET_TYPEMASK_BODY_YAW_RATE_IGNORE
ATT_THROTTLE_IGNORE = M.ATTITUDE_TARGET_TYPEMASK_THROTTLE_IGNORE
# Rover tests only the horizontal bits of each group; any set bit ignores the group
POS_XY_IGNORE = M.POSITION_TARGET_TYPEMASK_X_IGNORE | M.POSITION_TARGET_TYPEMASK_Y_IGNORE
VEL_XY_IGNORE = M.POSITION_TARGET_TYPEMASK_VX_IGNORE | M.POSITION_TARGET_TYPEMASK_VY_IGNORE
ACC_XY_IGNORE = M.POSITION_TARGET_TYPEMASK_AX_IGNORE | M.POSITION_TARGET_TYPEMASK_AY_IGNORE
YAW_IGNORE, YAW_RATE_IGNORE = M.POSITION_TARGET_TYPEMASK_YAW_IGNORE, M.POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE
LOCAL_NED, LOCAL_OFFSET_NED = M.MAV_FRAME_LOCAL_NED, M.MAV_FRAME_LOCAL_OFFSET_NED
BODY_NED, BODY_OFFSET_NED = M.MAV_FRAME_BODY_NED, M.MAV_FRAME_BODY_OFFSET_NED
GLOBAL_FRAMES = frozenset(
    {
        M.MAV_FRAME_GLOBAL,
        M.MAV_FRAME_GLOBAL_INT,
        M.MAV_FRAME_GLOBAL_RELATIVE_ALT,
        M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        M.MAV_FRAME_GLOBAL_TERRAIN_ALT,
        M.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT,
    }
)


@dataclass
class GuidedTarget:
    """One GUIDED demand: a waypoint, or a heading / turn rate with a speed (m/s); ``time`` of receipt (s)."""

    heading: float | None
    rate: float | None
    speed: float
    time: float
    waypoint: NavTarget | None = None

    @property
    def expires(self) -> bool:
        """Heading/rate/velocity targets time out after 3 s; waypoints do not."""
        return self.waypoint is None


def _finite(*values: float) -> bool:
    """True if every value is a finite number."""
    return all(math.isfinite(float(v)) for v in values)


def from_attitude(
    type_mask: int, q: list[float], yaw_rate: float, thrust: float, speed_max: float, now: float
) -> GuidedTarget | None:
    """SET_ATTITUDE_TARGET: heading from q (yaw-rate bit set) or body yaw rate; thrust × default speed."""
    if type_mask & ATT_THROTTLE_IGNORE or not _finite(thrust):
        return None
    speed = max(-1.0, min(1.0, thrust)) * speed_max
    if type_mask & ATT_YAW_RATE_IGNORE:
        if len(q) != 4 or not _finite(*q):
            return None
        w, x, y, z = (float(v) for v in q)
        if w * w + x * x + y * y + z * z < 1e-6:
            return None
        return GuidedTarget(math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z)), None, speed, now)
    if not _finite(yaw_rate):
        return None
    return GuidedTarget(None, float(yaw_rate), speed, now)


@dataclass(frozen=True)
class TargetFields:
    """What Rover reads of a SET_POSITION_TARGET_* message: type_mask, NED position (m, None if not given),
    velocity vx, vy (m/s, message frame), yaw (rad) and yaw rate (rad/s); ``yaw_offset`` (rad) is the current
    heading for body frames (added to velocity and yaw headings), else 0."""

    mask: int
    north: float | None
    east: float | None
    vx: float
    vy: float
    yaw: float
    yaw_rate: float
    yaw_offset: float = 0.0


def _used_fields_finite(f: TargetFields, vel_ignore: bool, yaw_ignore: bool, rate_ignore: bool) -> bool:
    """True if every field the mask asks for is a finite number."""
    return (
        (vel_ignore or _finite(f.vx, f.vy))
        and (yaw_ignore or _finite(f.yaw))
        and (rate_ignore or _finite(f.yaw_rate))
    )


def _velocity_target(
    f: TargetFields, speed_max: float, yaw_ignore: bool, rate_ignore: bool, now: float
) -> GuidedTarget | None:
    """Velocity alone (heading atan2(vy, vx)), or with yaw or yaw rate (speed signed by vx: astern if < 0)."""
    speed = min(speed_max, math.hypot(f.vx, f.vy))
    if yaw_ignore and rate_ignore:
        return GuidedTarget(wrap_pi(math.atan2(f.vy, f.vx) + f.yaw_offset), None, speed, now)
    signed = -speed if f.vx < 0 else speed
    if yaw_ignore:
        return GuidedTarget(None, float(f.yaw_rate), signed, now)
    if rate_ignore:
        return GuidedTarget(wrap_pi(float(f.yaw) + f.yaw_offset), None, signed, now)
    return None  # velocity with both yaw and yaw rate: Rover uses none of it


def _from_parts(f: TargetFields, speed_max: float, wp_speed: float, nav: NavState, now: float) -> GuidedTarget | None:
    """Rover's reading of a position target's type_mask (any set bit of a group ignores that group).

    Accelerations must be ignored, else the whole message is (the GCS endpoint says so in a STATUSTEXT).
    Position wins, driven at ``wp_speed``; otherwise exactly one of: velocity alone, velocity with yaw or
    with yaw rate, yaw alone (turn on the spot) or yaw rate alone (spin); velocity is capped at ``speed_max``.
    """
    if not f.mask & ACC_XY_IGNORE:
        return None
    if not f.mask & POS_XY_IGNORE:
        if f.north is None or f.east is None or not _finite(f.north, f.east):
            return None
        return GuidedTarget(None, None, wp_speed, now, NavTarget(f.north, f.east, nav.north, nav.east, wp_speed))
    vel_ignore = bool(f.mask & VEL_XY_IGNORE)
    yaw_ignore, rate_ignore = bool(f.mask & YAW_IGNORE), bool(f.mask & YAW_RATE_IGNORE)
    if not _used_fields_finite(f, vel_ignore, yaw_ignore, rate_ignore):
        return None
    if not vel_ignore:
        return _velocity_target(f, speed_max, yaw_ignore, rate_ignore, now)
    if not yaw_ignore and rate_ignore:
        return GuidedTarget(wrap_pi(float(f.yaw) + f.yaw_offset), None, 0.0, now)
    if yaw_ignore and not rate_ignore:
        return GuidedTarget(None, float(f.yaw_rate), 0.0, now)
    return None


def from_local(
    msg: object, nav: NavState, speed_max: float, now: float, wp_speed: float | None = None
) -> GuidedTarget | None:
    """SET_POSITION_TARGET_LOCAL_NED in the four frames Rover accepts (origin = home); others dropped.

    ``speed_max`` (WP_SPEED) caps velocity targets; ``wp_speed`` is the speed toward a position (default
    ``speed_max``; DO_CHANGE_SPEED in GUIDED changes it).
    """
    frame, mask = int(msg.coordinate_frame), int(msg.type_mask)
    x, y = float(msg.x), float(msg.y)
    yaw_offset = 0.0
    if frame in (BODY_NED, BODY_OFFSET_NED):
        c, s = math.cos(nav.yaw), math.sin(nav.yaw)
        x, y = c * x - s * y, s * x + c * y
        yaw_offset = nav.yaw
    if frame == LOCAL_NED:
        north, east = x, y
    elif frame in (LOCAL_OFFSET_NED, BODY_NED, BODY_OFFSET_NED):
        north, east = nav.north + x, nav.east + y
    else:
        return None
    fields = TargetFields(
        mask, north, east, float(msg.vx), float(msg.vy), float(msg.yaw), float(msg.yaw_rate), yaw_offset
    )
    return _from_parts(fields, speed_max, speed_max if wp_speed is None else wp_speed, nav, now)


def from_global(
    msg: object, home: Home, nav: NavState, speed_max: float, now: float, wp_speed: float | None = None
) -> GuidedTarget | None:
    """SET_POSITION_TARGET_GLOBAL_INT (lat/lon in degE7); bad frames or coordinates are dropped."""
    if int(msg.coordinate_frame) not in GLOBAL_FRAMES:
        return None
    mask = int(msg.type_mask)
    lat, lon = msg.lat_int / 1e7, msg.lon_int / 1e7
    north = east = None
    if not mask & POS_XY_IGNORE:
        if not (-90 <= lat <= 90 and -180 <= lon <= 180) or (lat == 0 and lon == 0):
            return None
        north, east = home.to_ned(lat, lon)
    fields = TargetFields(mask, north, east, float(msg.vx), float(msg.vy), float(msg.yaw), float(msg.yaw_rate))
    return _from_parts(fields, speed_max, speed_max if wp_speed is None else wp_speed, nav, now)


def valid_location(lat_deg: float, lon_deg: float) -> bool:
    """A finite lat/lon in range and not 0/0 (which Rover takes as "no location")."""
    if not _finite(lat_deg, lon_deg) or not (-90 <= lat_deg <= 90 and -180 <= lon_deg <= 180):
        return False
    return not (lat_deg == 0 and lon_deg == 0)


def to_location(
    lat_deg: float, lon_deg: float, home: Home, nav: NavState, speed: float, now: float
) -> GuidedTarget | None:
    """A guided waypoint at lat/lon (DO_REPOSITION, MISSION_ITEM current=2); None if invalid."""
    if not valid_location(lat_deg, lon_deg):
        return None
    north, east = home.to_ned(lat_deg, lon_deg)
    return GuidedTarget(None, None, speed, now, NavTarget(north, east, nav.north, nav.east, speed))
