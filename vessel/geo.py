"""Flat-earth conversion between latitude/longitude and local NED metres around a home position.

Uses ArduPilot's own spherical approximation (earth radius 6 378 100 m, east scaled by cos(home
latitude)), so that positions computed here agree with the NED offsets the autopilot reports.
"""

from __future__ import annotations

import math

EARTH_RADIUS_M = 6_378_100.0
METRES_PER_DEGREE = EARTH_RADIUS_M * math.pi / 180.0


def _east_scale(lat_deg: float) -> float:
    """Metres per degree of longitude divided by metres per degree of latitude at this latitude."""
    return max(math.cos(math.radians(lat_deg)), 0.01)


def ned_from_latlon(home_lat_deg: float, home_lon_deg: float, lat_deg: float, lon_deg: float
                    ) -> tuple[float, float]:
    """(north, east) in metres of a point relative to home."""
    d_lon = (lon_deg - home_lon_deg + 180.0) % 360.0 - 180.0
    north = (lat_deg - home_lat_deg) * METRES_PER_DEGREE
    east = d_lon * METRES_PER_DEGREE * _east_scale(home_lat_deg)
    return north, east


def latlon_from_ned(home_lat_deg: float, home_lon_deg: float, north_m: float, east_m: float
                    ) -> tuple[float, float]:
    """(lat, lon) in degrees of a point (north, east) metres from home."""
    lat = home_lat_deg + north_m / METRES_PER_DEGREE
    lon = home_lon_deg + east_m / (METRES_PER_DEGREE * _east_scale(home_lat_deg))
    lon = (lon + 180.0) % 360.0 - 180.0
    return lat, lon
