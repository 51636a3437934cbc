"""A waypoint mission as ArduPilot stores it: home at seq 0, then NAV_WAYPOINT items, validated.

Latitude and longitude are in degrees (the MAVLink edge); altitude in metres (ignored by a boat).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from vessel.geo import ned_from_latlon

MAV_CMD_NAV_WAYPOINT = 16
SUPPORTED_COMMANDS = {MAV_CMD_NAV_WAYPOINT: "NAV_WAYPOINT"}
# MAV_FRAME: GLOBAL, GLOBAL_RELATIVE_ALT, GLOBAL_INT, GLOBAL_RELATIVE_ALT_INT
SUPPORTED_FRAMES = (0, 3, 5, 6)
FRAME_GLOBAL = 0
FRAME_GLOBAL_RELATIVE_ALT = 3


class MissionError(ValueError):
    """A mission or mission file is unusable; the message is one line that names the item or field."""


@dataclass(frozen=True)
class MissionItem:
    """One mission item: a MAVLink command at a position, with its four command parameters."""

    lat_deg: float
    lon_deg: float
    alt_m: float = 0.0
    command: int = MAV_CMD_NAV_WAYPOINT
    frame: int = FRAME_GLOBAL_RELATIVE_ALT
    params: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    autocontinue: bool = True


@dataclass(frozen=True)
class Mission:
    """Home (seq 0) and the items to execute (seq 1…)."""

    home: MissionItem
    items: tuple[MissionItem, ...] = field(default_factory=tuple)

    def all_items(self) -> list[MissionItem]:
        """Items in upload order, home first."""
        return [self.home, *self.items]


def check_latlon(lat: float, lon: float, where: str) -> None:
    """Raise MissionError unless latitude is in [-90, 90] and longitude in [-180, 180] degrees."""
    if not (isinstance(lat, (int, float)) and math.isfinite(lat) and -90.0 <= lat <= 90.0):
        raise MissionError(f"{where}: latitude {lat!r} is outside the allowed range [-90, 90] deg")
    if not (isinstance(lon, (int, float)) and math.isfinite(lon) and -180.0 <= lon <= 180.0):
        raise MissionError(f"{where}: longitude {lon!r} is outside the allowed range [-180, 180] deg")


def validate(mission: Mission, source: str = "mission") -> Mission:
    """Check every item: position ranges, supported commands and frames, finite numbers; return it."""
    check_latlon(mission.home.lat_deg, mission.home.lon_deg, f"{source}: home")
    if not mission.items:
        raise MissionError(f"{source}: no waypoint after home (at least 1 NAV_WAYPOINT is needed)")
    for index, item in enumerate(mission.items, start=1):
        where = f"{source}: item {index}"
        if item.command not in SUPPORTED_COMMANDS:
            raise MissionError(f"{where}: command {item.command} is not supported "
                               f"(supported: NAV_WAYPOINT {MAV_CMD_NAV_WAYPOINT})")
        if item.frame not in SUPPORTED_FRAMES:
            raise MissionError(f"{where}: frame {item.frame} is not supported (supported: "
                               f"{', '.join(map(str, SUPPORTED_FRAMES))})")
        check_latlon(item.lat_deg, item.lon_deg, where)
        if not math.isfinite(item.alt_m):
            raise MissionError(f"{where}: altitude {item.alt_m!r} is not a finite number of metres")
        hold = item.params[0]
        if math.isfinite(hold) and not 0.0 <= hold <= 3600.0:
            raise MissionError(f"{where}: hold time {hold!r} is outside the allowed range [0, 3600] s")
    return mission


def check_range(mission: Mission, max_range_m: float, source: str = "mission") -> Mission:
    """Raise MissionError unless every item is within ``max_range_m`` metres of the mission's home (flat earth,
    as the autopilot and the companion measure it); return the mission. The companion refuses to engage on a
    waypoint farther than its own --max-range (the same default), so such a mission could never be flown."""
    home = mission.home
    for index, item in enumerate(mission.items, start=1):
        distance = math.hypot(*ned_from_latlon(home.lat_deg, home.lon_deg, item.lat_deg, item.lon_deg))
        if not distance <= max_range_m:
            raise MissionError(f"{source}: item {index} is {distance / 1000:,.1f} km from home, farther than "
                               f"--max-range {max_range_m:g} m")
    return mission
