"""Flat-earth conversion between the plant's NED metres and latitude/longitude around home."""

from __future__ import annotations

import math
from dataclasses import dataclass

EARTH_RADIUS_M = 6378137.0  # WGS-84 equatorial radius, as ArduPilot's location code uses


@dataclass(frozen=True)
class Home:
    """Home position and the boat's initial heading (degrees, metres AMSL)."""

    lat_deg: float = -35.363261
    lon_deg: float = 149.165230
    alt_m: float = 584.0
    heading_deg: float = 353.0

    def to_geodetic(self, north: float, east: float, down: float = 0.0) -> tuple[float, float, float]:
        """NED offset from home (m) -> latitude, longitude (deg) and altitude AMSL (m)."""
        lat = self.lat_deg + math.degrees(north / EARTH_RADIUS_M)
        lon = self.lon_deg + math.degrees(east / (EARTH_RADIUS_M * math.cos(math.radians(self.lat_deg))))
        return lat, lon, self.alt_m - down

    def to_ned(self, lat_deg: float, lon_deg: float) -> tuple[float, float]:
        """Latitude, longitude (deg) -> north, east offset from home (m)."""
        north = math.radians(lat_deg - self.lat_deg) * EARTH_RADIUS_M
        east = math.radians(lon_deg - self.lon_deg) * EARTH_RADIUS_M * math.cos(math.radians(self.lat_deg))
        return north, east


def parse_home(text: str) -> Home:
    """Parse ``LAT,LON,ALT,HEADING`` (as ArduPilot SITL's ``--home``); ValueError with a reason if bad."""
    parts = text.split(",")
    if len(parts) != 4:
        raise ValueError(f"expected LAT,LON,ALT,HEADING, got {text!r}")
    try:
        lat, lon, alt, hdg = (float(p) for p in parts)
    except ValueError:
        raise ValueError(f"expected four numbers LAT,LON,ALT,HEADING, got {text!r}") from None
    if not all(math.isfinite(v) for v in (lat, lon, alt, hdg)):
        raise ValueError(f"home must be finite numbers, got {text!r}")
    if not (-89.0 <= lat <= 89.0 and -180.0 <= lon <= 180.0):
        raise ValueError(f"home latitude must be in [-89, 89] and longitude in [-180, 180], got {text!r}")
    return Home(lat, lon, alt, hdg % 360.0)


def wrap_pi(angle: float) -> float:
    """Angle wrapped into [-π, π)."""
    return (angle + math.pi) % (2 * math.pi) - math.pi
