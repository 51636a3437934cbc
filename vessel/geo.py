"""The one geo module: home position, flat-earth conversions, degE7 helpers and the angle wrap.

Every package converts between latitude/longitude and local NED metres here, so that the simulator's
reported positions and the companion's reading of them agree to rounding. The conversion is
ArduPilot's own spherical flat-earth approximation (``Location::offset`` / ``get_distance_NE`` in
``libraries/AP_Common/Location.cpp``): north = Δlat · LATLON_TO_M, east = Δlon · LATLON_TO_M ·
``longitude_scale``, where ``LATLON_TO_M`` (the ``LOCATION_SCALING_FACTOR`` of ``Location.h``, metres
per 1e-7 degree) is ``1e-7 · DEG_TO_RAD · RADIUS_OF_EARTH`` with ``RADIUS_OF_EARTH = 6378100`` m
(``libraries/AP_Math/definitions.h``), and ``longitude_scale(lat) = max(cos(lat), 0.01)`` at the
*home* latitude. Not WGS-84's 6 378 137 m: ArduPilot does not use it for these offsets.

Angles: one wrap, :func:`wrap_pi`, into the half-open interval [−half_turn, half_turn) — [−π, π) for
radians (heading errors, yaw as ATTITUDE reports it) and [−180, 180) for longitudes in degrees. Values
already inside the interval are returned unchanged (bit for bit), so wrapping never adds rounding.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

EARTH_RADIUS_M = 6_378_100.0  # ArduPilot's RADIUS_OF_EARTH
METRES_PER_DEGREE = EARTH_RADIUS_M * math.pi / 180.0  # 1e7 · LATLON_TO_M (LOCATION_SCALING_FACTOR)
DEG_E7 = 1e7  # MAVLink's integer latitude/longitude unit: degrees · 1e7
MIN_LONGITUDE_SCALE = 0.01  # ArduPilot's floor on cos(latitude)
# The farthest a waypoint may be from home or from the boat (m) unless the operator says otherwise: one default
# for `mavbridge run` (the engage gate), `mavbridge check` and `mission upload`, which share nothing else.
DEFAULT_MAX_RANGE_M = 5000.0


def wrap_pi(angle: float, half_turn: float = math.pi) -> float:
    """``angle`` wrapped into [−half_turn, half_turn): radians by default, degrees with half_turn = 180."""
    if -half_turn <= angle < half_turn:
        return angle
    return (angle + half_turn) % (2.0 * half_turn) - half_turn


def deg_e7(degrees: float) -> int:
    """Degrees as MAVLink's integer degE7 (rounded to nearest, as ArduPilot stores locations)."""
    return round(degrees * DEG_E7)


def from_deg_e7(value: float) -> float:
    """MAVLink's integer degE7 as degrees."""
    return value / DEG_E7


def longitude_scale(lat_deg: float) -> float:
    """Metres per degree of longitude over metres per degree of latitude: ArduPilot's longitude_scale."""
    return max(math.cos(math.radians(lat_deg)), MIN_LONGITUDE_SCALE)


def ned_from_latlon(home_lat_deg: float, home_lon_deg: float, lat_deg: float, lon_deg: float
                    ) -> tuple[float, float]:
    """(north, east) in metres of a point relative to home (longitude difference taken the short way)."""
    d_lon = wrap_pi(lon_deg - home_lon_deg, 180.0)
    north = (lat_deg - home_lat_deg) * METRES_PER_DEGREE
    east = d_lon * METRES_PER_DEGREE * longitude_scale(home_lat_deg)
    return north, east


def latlon_from_ned(home_lat_deg: float, home_lon_deg: float, north_m: float, east_m: float
                    ) -> tuple[float, float]:
    """(lat, lon) in degrees of a point (north, east) metres from home; longitude in [−180, 180)."""
    lat = home_lat_deg + north_m / METRES_PER_DEGREE
    lon = home_lon_deg + east_m / (METRES_PER_DEGREE * longitude_scale(home_lat_deg))
    return lat, wrap_pi(lon, 180.0)


@dataclass(frozen=True)
class Home:
    """Home position (deg, deg, m AMSL) and the boat's initial heading (deg, 0 = North); default CMAC."""

    lat_deg: float = -35.363261  # ArduPilot SITL's default location, Canberra Model Aircraft Club
    lon_deg: float = 149.165230
    alt_m: float = 584.0
    heading_deg: float = 353.0

    def to_geodetic(self, north: float, east: float, down: float = 0.0) -> tuple[float, float, float]:
        """NED offset from home (m) -> latitude, longitude (deg) and altitude AMSL (m)."""
        lat, lon = latlon_from_ned(self.lat_deg, self.lon_deg, north, east)
        return lat, lon, self.alt_m - down

    def to_ned(self, lat_deg: float, lon_deg: float) -> tuple[float, float]:
        """Latitude, longitude (deg) -> north, east offset from home (m)."""
        return ned_from_latlon(self.lat_deg, self.lon_deg, lat_deg, lon_deg)

    def text(self) -> str:
        """``LAT,LON,ALT,HEADING`` as :func:`parse_home` (and ``sim-vehicle --home``) reads it."""
        return f"{self.lat_deg!r},{self.lon_deg!r},{self.alt_m!r},{self.heading_deg!r}"


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
