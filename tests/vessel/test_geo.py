"""vessel.geo, the one geo module: ArduPilot's flat earth, exact round trips, degE7 and the one angle wrap."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from vessel.geo import (
    EARTH_RADIUS_M,
    METRES_PER_DEGREE,
    Home,
    deg_e7,
    from_deg_e7,
    latlon_from_ned,
    longitude_scale,
    ned_from_latlon,
    parse_home,
    wrap_pi,
)

CMAC = Home()
OFFSETS_M = np.linspace(-10_000.0, 10_000.0, 21)  # a 20 km square around home, 1 km apart


def test_ardupilot_constants() -> None:
    """RADIUS_OF_EARTH = 6378100 m; LATLON_TO_M (LOCATION_SCALING_FACTOR) = 0.011131884502145034 m per degE7."""
    assert EARTH_RADIUS_M == 6_378_100.0
    assert METRES_PER_DEGREE / 1e7 == pytest.approx(0.011131884502145034, rel=1e-15)
    assert longitude_scale(0.0) == 1.0 and longitude_scale(89.9999) == 0.01  # ArduPilot's floor
    north, east = ned_from_latlon(0.0, 0.0, 1e-7, 1e-7)  # one degE7 at the equator
    assert (north, east) == pytest.approx((0.011131884502145034, 0.011131884502145034), rel=1e-15)


@pytest.mark.parametrize("home", [CMAC, Home(51.5, -0.12), Home(0.0, 0.0), Home(-60.0, -170.0)])
def test_latlon_to_ned_and_back_is_exact_to_a_nanometre(home: Home) -> None:
    """What arrives on the wire (degE7 positions) -> NED -> lat/lon gives the same point to 1e-9 m."""
    worst = 0.0
    for north, east in itertools.product(OFFSETS_M, OFFSETS_M):
        lat, lon = latlon_from_ned(home.lat_deg, home.lon_deg, north, east)
        lat, lon = from_deg_e7(deg_e7(lat)), from_deg_e7(deg_e7(lon))  # a position as MAVLink carries it
        n, e = home.to_ned(lat, lon)
        lat2, lon2, _ = home.to_geodetic(n, e)
        worst = max(worst, math.hypot(*ned_from_latlon(lat, lon, lat2, lon2)))
    assert worst <= 1e-9


@pytest.mark.parametrize("home", [CMAC, Home(51.5, -0.12), Home(0.0, 0.0)])
def test_ned_to_latlon_and_back_to_the_spacing_of_doubles(home: Home) -> None:
    """NED -> lat/lon -> NED: north to 1e-9 m; east to half the spacing of doubles at home's longitude.

    A longitude near 149° is a double with 2.8e-14° (2.6 nm at CMAC) between neighbours, so no
    conversion can return east more exactly than half of that; a MAVLink degE7 step is 1.1 cm.
    """
    east_bound = max(1e-9, 0.5 * math.ulp(abs(home.lon_deg) + 0.1) * METRES_PER_DEGREE
                     * longitude_scale(home.lat_deg))
    for north, east in itertools.product(OFFSETS_M, OFFSETS_M):
        lat, lon, _ = home.to_geodetic(north, east)
        n, e = home.to_ned(lat, lon)
        assert abs(n - north) <= 1e-9 and abs(e - east) <= east_bound


def test_across_the_antimeridian_the_short_way() -> None:
    home = Home(10.0, 179.9999)
    lat, lon = latlon_from_ned(home.lat_deg, home.lon_deg, 0.0, 1000.0)
    assert -180.0 <= lon < -179.99  # wrapped into [-180, 180)
    north, east = home.to_ned(lat, lon)
    assert north == 0.0 and east == pytest.approx(1000.0, abs=1e-8)
    assert ned_from_latlon(0.0, -179.9, 0.0, 179.9)[1] == pytest.approx(-0.2 * METRES_PER_DEGREE, rel=1e-9)


def test_simulator_and_companion_agree_through_deg_e7() -> None:
    """The simulator's GLOBAL_POSITION_INT, read back by the companion, is the plant's NED to degE7 rounding."""
    home_lat, home_lon = from_deg_e7(deg_e7(CMAC.lat_deg)), from_deg_e7(deg_e7(CMAC.lon_deg))  # HOME_POSITION
    assert (home_lat, home_lon) == (CMAC.lat_deg, CMAC.lon_deg)  # CMAC is a degE7 point
    for north, east in itertools.product(OFFSETS_M, OFFSETS_M):
        lat, lon, _ = CMAC.to_geodetic(north, east)
        n, e = ned_from_latlon(home_lat, home_lon, from_deg_e7(deg_e7(lat)), from_deg_e7(deg_e7(lon)))
        assert abs(n - north) <= 0.5 * METRES_PER_DEGREE / 1e7 + 1e-9
        assert abs(e - east) <= 0.5 * METRES_PER_DEGREE / 1e7 * longitude_scale(CMAC.lat_deg) + 1e-9


def test_deg_e7_rounds_to_nearest() -> None:
    assert deg_e7(-35.363261) == -353632610 and deg_e7(149.16523) == 1491652300
    assert deg_e7(1.00000006) == 10000001 and from_deg_e7(-353632610) == -35.363261


def test_one_wrap_half_open_interval() -> None:
    """[-π, π) in radians, [-180, 180) in degrees; values inside come back bit for bit."""
    assert wrap_pi(math.pi) == -math.pi and wrap_pi(-math.pi) == -math.pi
    assert wrap_pi(3 * math.pi) == pytest.approx(-math.pi) and wrap_pi(-3.5 * math.pi) == pytest.approx(0.5 * math.pi)
    for angle in (0.1, -3.14159, 3.14159, 1e-300):
        assert wrap_pi(angle) == angle
    assert wrap_pi(180.0, 180.0) == -180.0 and wrap_pi(540.5, 180.0) == pytest.approx(-179.5)
    assert wrap_pi(-190.0, 180.0) == pytest.approx(170.0) and wrap_pi(179.9, 180.0) == 179.9


def test_home_text_is_what_parse_home_reads() -> None:
    home = Home(-35.363261, 149.16523, 584.0, 90.0)
    assert parse_home(home.text()) == home
    assert parse_home(CMAC.text()) == CMAC
