"""Unit tests of the simulator's pieces: mixer, RC scaling, parameters, geometry, streams, controllers."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from sim_vehicle.mavlink.streams import Schedule
from sim_vehicle.rover.control import NavState, NavTarget, navigate
from sim_vehicle.rover.mixer import output_to_pwm, output_to_shaft_speed, pwm_to_output, skid_mix
from sim_vehicle.rover.modes import Mode, base_mode, lookup
from sim_vehicle.rover.params import INT8, REAL32, ParamTable, cast, parse_parm
from sim_vehicle.rover.rc import RcInput, stick
from vessel.config import ConfigError
from vessel.geo import Home, parse_home, wrap_pi


def test_skid_mix_matches_ardupilot() -> None:
    """left = t + s, right = t − s; with saturation at the default mix both are scaled by 1/(|t|+|s|)."""
    assert skid_mix(0.0, 1.0) == (1.0, 1.0)
    assert skid_mix(1.0, 0.0) == (1.0, -1.0)
    assert skid_mix(0.2, 0.5) == pytest.approx((0.7, 0.3))
    left, right = skid_mix(0.5, 1.0)  # |t|+|s| = 1.5
    assert left == pytest.approx(1.0) and right == pytest.approx(1 / 1.5 - 0.5 / 1.5)
    left, right = skid_mix(0.5, 1.0, str_thr_mix=1.0)  # steering first: throttle gets what is left
    assert (left, right) == pytest.approx((1.0, 0.0))
    assert skid_mix(-0.3, -0.5) == pytest.approx((-0.8, -0.2))
    assert skid_mix(0.0, -1.0, asym=2.0) == (-1.0, -1.0)
    assert skid_mix(0.0, -0.25, asym=2.0) == pytest.approx((-0.5, -0.5))


def test_pwm_round_trip_and_shaft_speed() -> None:
    """Outputs map to SERVO PWM about trim and back; +1 is n_max, −1 is |n_min| astern."""
    assert output_to_pwm(1.0, 1100, 1500, 1900, False) == 1900
    assert output_to_pwm(-1.0, 1100, 1500, 1900, False) == 1100
    assert output_to_pwm(0.5, 1100, 1500, 1900, True) == 1300
    for out in (-1.0, -0.3, 0.0, 0.42, 1.0):
        assert pwm_to_output(output_to_pwm(out, 1100, 1500, 1900, False), 1100, 1500, 1900, False) == (
            pytest.approx(out, abs=3e-3)
        )
    assert pwm_to_output(0, 1100, 1500, 1900, False) == 0.0
    assert pwm_to_output(5000, 1100, 1500, 1900, False) == 1.0
    assert output_to_shaft_speed(1.0, 104.0, -101.0) == 104.0
    assert output_to_shaft_speed(-1.0, 104.0, -101.0) == -101.0


def test_stick_dead_zone_and_limits() -> None:
    """Dead zone around trim, linear beyond, clamped, reversible; no signal is centre."""
    assert stick(1500, 1100, 1500, 1900, 30, False) == 0.0
    assert stick(1525, 1100, 1500, 1900, 30, False) == 0.0
    assert stick(1900, 1100, 1500, 1900, 30, False) == 1.0
    assert stick(1100, 1100, 1500, 1900, 30, False) == -1.0
    assert stick(5000, 1100, 1500, 1900, 30, True) == -1.0
    assert stick(1715, 1100, 1500, 1900, 30, False) == pytest.approx(0.5)
    assert stick(0, 1100, 1500, 1900, 30, False) == 0.0


def test_rc_override_codes_and_expiry() -> None:
    """65535 keeps, 0 releases (ch1-8), 65534 releases ch9-16; overrides expire per channel."""
    rc = RcInput()
    rc.apply_override([1900, 65535, 1800] + [65535] * 15, now=0.0)
    assert rc.pwm(1, 1.0, 3.0) == 1900 and rc.pwm(2, 1.0, 3.0) == 1500
    rc.apply_override([65535, 65535, 65535] + [65535] * 15, now=2.0)
    assert rc.pwm(1, 3.5, 3.0) == 1500  # expired: its own time is still 0
    rc.apply_override([0] + [65535] * 17, now=4.0)
    assert rc.pwm(1, 4.1, 3.0) == 1500
    rc.apply_override([65535] * 8 + [1700] + [0] * 9, now=5.0)
    assert rc.pwm(9, 5.1, 3.0) == 1700
    rc.apply_override([65535] * 8 + [65534] + [0] * 9, now=5.5)
    assert rc.pwm(9, 5.6, 3.0) == 1500
    rc.apply_override([1600] + [65535] * 17, now=6.0)
    assert rc.pwm(1, 100.0, -1.0) == 1600 and rc.pwm(1, 6.1, 0.0) == 1500
    assert RcInput(receiver=False).pwm(3, 0.0, 3.0) == 0


def test_params_cast_store_and_parm(tmp_path: Path) -> None:
    """Integer types round and clamp; changes persist in the store; .parm lines parse with both separators."""
    assert cast(INT8, 300) == 127 and cast(INT8, 2.6) == 3 and cast(REAL32, 0.1) == 0.1
    store = tmp_path / "state" / "params.json"
    table = ParamTable(store=store)
    assert table["FRAME_CLASS"] == 2 and table["SERVO1_FUNCTION"] == 73
    assert table.set("WP_SPEED", 3.0) and not table.set("WP_SPEED", math.nan) and not table.set("NOPE", 1)
    assert ParamTable(store=store)["WP_SPEED"] == 3.0
    assert ParamTable(store=store, defaults={"WP_RADIUS": 5})["WP_RADIUS"] == 5
    parsed = parse_parm(["# comment", "WP_SPEED 2.5", "fs_action,1  # inline", ""], "x.parm")
    assert parsed == {"WP_SPEED": 2.5, "FS_ACTION": 1.0}
    with pytest.raises(ConfigError, match=r"x.parm:1"):
        parse_parm(["WP_SPEED two"], "x.parm")
    store.write_text("{not json")
    with pytest.raises(ConfigError, match="--wipe"):
        ParamTable(store=store)


def test_home_and_flat_earth() -> None:
    """--home parsing and a NED round trip; bad homes are refused."""
    home = parse_home("-35.363261,149.165230,584,353")
    assert home == Home()
    lat, lon, alt = home.to_geodetic(100.0, -50.0, 0.5)
    assert home.to_ned(lat, lon) == pytest.approx((100.0, -50.0), abs=1e-6) and alt == 583.5
    for bad in ("1,2,3", "a,b,c,d", "95,0,0,0", "nan,0,0,0"):
        with pytest.raises(ValueError):
            parse_home(bad)
    assert wrap_pi(3 * math.pi) == pytest.approx(-math.pi)


def test_modes_and_base_mode() -> None:
    """Mode numbers, heartbeat bits, and refusal of unknown numbers."""
    assert base_mode(Mode.MANUAL, False) == 65 and base_mode(Mode.GUIDED, True) == 1 | 8 | 128
    assert base_mode(Mode.HOLD, False) == 1
    assert lookup(15) == Mode.GUIDED and lookup(99) is None
    assert lookup(math.nan) is None and lookup(2.5) is None


def test_stream_schedule() -> None:
    """SR defaults at 1 Hz, REQUEST_DATA_STREAM rates, SET_MESSAGE_INTERVAL stop/restore."""
    sched = Schedule(ParamTable(), 0)
    assert 30 in sched.due(0.0) and 30 not in sched.due(0.5) and 30 in sched.due(1.0)
    sched.set_stream(10, 4.0, True)  # EXTRA1 at 4 Hz
    assert sched.interval(30) == 0.25
    sched.set_interval(30, -1)
    assert sched.interval(30) is None and 30 not in sched.due(5.0)
    sched.set_interval(30, 0)
    assert sched.interval(30) == 0.25  # back to its stream's current rate (the 4 Hz REQUEST_DATA_STREAM set)
    sched.set_stream(0, 0, False)
    assert sched.due(10.0) == []


def test_navigator_aims_along_the_leg() -> None:
    """Off the leg the navigator steers back towards it, and slows down to stop at the end."""
    nav = NavState(north=0.0, east=5.0, yaw=0.0)
    cmd = navigate(NavTarget(50.0, 0.0, 0.0, 0.0, 2.0), nav, lookahead_m=5.0, accel=1.0)
    assert cmd.heading < 0 and cmd.xtrack == pytest.approx(-5.0) and cmd.speed == 2.0
    near = navigate(NavTarget(50.0, 0.0, 0.0, 0.0, 2.0), NavState(north=49.5), lookahead_m=5.0, accel=1.0)
    assert near.speed == pytest.approx(1.0)
