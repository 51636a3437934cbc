"""GUIDED-mode targets as Rover reads them from SET_ATTITUDE_TARGET and SET_POSITION_TARGET_* messages."""

from __future__ import annotations

import math
from dataclasses import dataclass

from vessel.geo import Home

from .control import NavState, NavTarget

ATT_YAW_RATE_IGNORE, ATT_THROTTLE_IGNORE = 4, 64
POS_XY_IGNORE, VEL_XY_IGNORE, YAW_IGNORE, YAW_RATE_IGNORE = 0b11, 0b11 << 3, 1 << 10, 1 << 11
LOCAL_NED, LOCAL_OFFSET_NED, BODY_NED, BODY_OFFSET_NED = 1, 7, 8, 9
GLOBAL_FRAMES = frozenset({0, 3, 10, 5, 6, 11})


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


def _from_parts(
    mask: int,
    north: float | None,
    east: float | None,
    vn: float,
    ve: float,
    yaw: float,
    yaw_rate: float,
    nav: NavState,
    speed_max: float,
    now: float,
) -> GuidedTarget | None:
    """Rover's precedence: position, else velocity, else yaw (turn on the spot), else yaw rate (spin)."""
    if mask & POS_XY_IGNORE != POS_XY_IGNORE and north is not None and east is not None:
        if not _finite(north, east):
            return None
        return GuidedTarget(
            None, None, speed_max, now, NavTarget(north, east, nav.north, nav.east, speed_max)
        )
    if mask & VEL_XY_IGNORE != VEL_XY_IGNORE:
        if not _finite(vn, ve):
            return None
        return GuidedTarget(math.atan2(ve, vn), None, min(speed_max, math.hypot(vn, ve)), now)
    if not mask & YAW_IGNORE and _finite(yaw):
        return GuidedTarget(float(yaw), None, 0.0, now)
    if not mask & YAW_RATE_IGNORE and _finite(yaw_rate):
        return GuidedTarget(None, float(yaw_rate), 0.0, now)
    return None


def from_local(msg: object, nav: NavState, speed_max: float, now: float) -> GuidedTarget | None:
    """SET_POSITION_TARGET_LOCAL_NED in the four frames Rover accepts (origin = home); others dropped."""
    frame, mask = int(msg.coordinate_frame), int(msg.type_mask)
    x, y, vx, vy = float(msg.x), float(msg.y), float(msg.vx), float(msg.vy)
    if frame in (BODY_NED, BODY_OFFSET_NED):
        c, s = math.cos(nav.yaw), math.sin(nav.yaw)
        x, y, vx, vy = c * x - s * y, s * x + c * y, c * vx - s * vy, s * vx + c * vy
    if frame == LOCAL_NED:
        north, east = x, y
    elif frame in (LOCAL_OFFSET_NED, BODY_NED, BODY_OFFSET_NED):
        north, east = nav.north + x, nav.east + y
    else:
        return None
    return _from_parts(mask, north, east, vx, vy, float(msg.yaw), float(msg.yaw_rate), nav, speed_max, now)


def from_global(msg: object, home: Home, nav: NavState, speed_max: float, now: float) -> GuidedTarget | None:
    """SET_POSITION_TARGET_GLOBAL_INT (lat/lon in degE7); bad frames or coordinates are dropped."""
    if int(msg.coordinate_frame) not in GLOBAL_FRAMES:
        return None
    mask = int(msg.type_mask)
    lat, lon = msg.lat_int / 1e7, msg.lon_int / 1e7
    north = east = None
    if mask & POS_XY_IGNORE != POS_XY_IGNORE:
        if not (-90 <= lat <= 90 and -180 <= lon <= 180) or (lat == 0 and lon == 0):
            return None
        north, east = home.to_ned(lat, lon)
    return _from_parts(
        mask,
        north,
        east,
        float(msg.vx),
        float(msg.vy),
        float(msg.yaw),
        float(msg.yaw_rate),
        nav,
        speed_max,
        now,
    )


def to_location(
    lat_deg: float, lon_deg: float, home: Home, nav: NavState, speed: float, now: float
) -> GuidedTarget | None:
    """A guided waypoint at lat/lon (DO_REPOSITION, MISSION_ITEM current=2); None if invalid."""
    if not _finite(lat_deg, lon_deg) or not (-90 <= lat_deg <= 90 and -180 <= lon_deg <= 180):
        return None
    if lat_deg == 0 and lon_deg == 0:
        return None
    north, east = home.to_ned(lat_deg, lon_deg)
    return GuidedTarget(None, None, speed, now, NavTarget(north, east, nav.north, nav.east, speed))
