"""End-to-end driving: RC overrides in MANUAL through the skid mixer, and GUIDED attitude targets."""

from __future__ import annotations

import math

from sim_vehicle.harness import SimProcess
from tests.rover import ARM, DO_REPOSITION, GUIDED, HOLD, KEEP, MANUAL, SET_MESSAGE_INTERVAL
from tests.waits import command, run_for, set_mode, taken_by, wait_for, wait_mode

SIM_OPTIONS = {"speedup": 20}  # the shared ``sim`` fixture's process


def _override(conn, ch1: int, ch3: int) -> None:
    conn.mav.rc_channels_override_send(1, 1, ch1, KEEP, ch3, KEEP, KEEP, KEEP, KEEP, KEEP)


def _servos(conn) -> tuple[int, int, float]:
    msg = wait_for(conn, "SERVO_OUTPUT_RAW", 5)
    return msg.servo1_raw, msg.servo3_raw, msg.time_usec / 1e6


def _position(conn):
    return wait_for(conn, "GLOBAL_POSITION_INT", 5)


def _servos_at(conn, sim_t: float) -> tuple[int, int]:
    """First SERVO_OUTPUT_RAW at or after simulated time ``sim_t``."""
    msg = wait_for(conn, "SERVO_OUTPUT_RAW", 20, lambda m: m.time_usec / 1e6 >= sim_t)
    return msg.servo1_raw, msg.servo3_raw


def test_override_from_gcs_drives_forward_then_expires(sim: SimProcess) -> None:
    """ch3 1900 / ch1 1500 from sysid 255 drives ahead; RC_OVERRIDE_TIME later the props stop."""
    conn = sim.connect()
    assert command(conn, SET_MESSAGE_INTERVAL, 36, 100000) == 0  # SERVO_OUTPUT_RAW at 10 Hz
    assert set_mode(conn, MANUAL) == 0 and command(conn, ARM, 1) == 0
    start = _position(conn)
    run_for(conn, 10.0, lambda: _override(conn, 1500, 1900))
    s1, s3, _ = _servos(conn)
    assert (s1, s3) == (1900, 1900)
    end = _position(conn)
    heading = math.radians(start.hdg / 100)
    dn = (end.lat - start.lat) * 1e-7 * 111_319.5
    de = (end.lon - start.lon) * 1e-7 * 111_319.5 * math.cos(math.radians(start.lat * 1e-7))
    ahead = dn * math.cos(heading) + de * math.sin(heading)
    assert ahead > 15.0, (dn, de)
    assert math.hypot(end.vx, end.vy) > 250  # cm/s
    _override(conn, 1500, 1900)
    last = taken_by(conn)  # the simulator took the last override by this simulated time
    assert _servos_at(conn, last + 2.0) == (1900, 1900)  # RC_OVERRIDE_TIME is 3 s
    assert _servos_at(conn, last + 4.2) == (1500, 1500)  # after the MOT_SLEWRATE ramp (1 s)
    assert command(conn, ARM, 0) == 0


def test_override_from_other_system_is_ignored(sim: SimProcess) -> None:
    """The same override from sysid 200 does not move the propellers."""
    other = sim.connect(source_system=200)
    assert command(other, SET_MESSAGE_INTERVAL, 36, 100000) == 0
    assert set_mode(other, MANUAL) == 0 and command(other, ARM, 1) == 0
    run_for(other, 3.0, lambda: _override(other, 1500, 1900))
    assert _servos(other)[:2] == (1500, 1500)
    assert command(other, ARM, 0) == 0


def test_release_hold_and_disarm_stop_the_props(sim: SimProcess) -> None:
    """Channel value 0 releases, HOLD stops the props, disarming stops them; steering mixes into the sides."""
    conn = sim.connect()
    assert command(conn, SET_MESSAGE_INTERVAL, 36, 100000) == 0
    assert set_mode(conn, MANUAL) == 0 and command(conn, ARM, 1) == 0
    _override(conn, 1900, 1500)  # full right turn on the spot: left ahead, right astern
    run_for(conn, 1.2)
    assert _servos(conn)[:2] == (1900, 1100)
    _override(conn, 1500, 1700)
    run_for(conn, 1.2)
    s1, s3, _ = _servos(conn)
    assert s1 == s3 and 1650 < s1 < 1750
    _override(conn, 0, 0)
    run_for(conn, 1.2)
    assert _servos(conn)[:2] == (1500, 1500)
    _override(conn, 1500, 1900)
    assert set_mode(conn, HOLD) == 0
    run_for(conn, 1.2)
    assert _servos(conn)[:2] == (1500, 1500)
    assert set_mode(conn, MANUAL) == 0
    _override(conn, 1500, 1900)
    run_for(conn, 1.2)
    assert _servos(conn)[:2] == (1900, 1900)
    assert command(conn, ARM, 0) == 0
    run_for(conn, 1.2)
    assert _servos(conn)[:2] == (1500, 1500)
    _override(conn, 0, 0)


def test_guided_attitude_target_east_then_stop(sim: SimProcess) -> None:
    """Yaw 90°, thrust 0.5 (WP_SPEED 2): East at about 1 m/s; 3 s after the last target it stops."""
    conn = sim.connect()
    assert set_mode(conn, GUIDED) == 0 and command(conn, ARM, 1) == 0
    q = [math.cos(math.pi / 4), 0.0, 0.0, math.sin(math.pi / 4)]

    def target() -> None:
        conn.mav.set_attitude_target_send(0, 1, 1, 0b00000111, q, 0.0, 0.0, 0.0, 0.5)

    run_for(conn, 30.0, target)
    speeds = []
    for _ in range(5):
        pos = _position(conn)
        speeds.append((pos.vx / 100, pos.vy / 100, pos.hdg / 100))
        target()
    for vn, ve, hdg in speeds:
        assert abs(hdg - 90) < 5
        assert abs(ve - 1.0) < 0.15 and abs(vn) < 0.2
    wait_for(conn, "STATUSTEXT", 10, lambda m: "target not received" in m.text)
    run_for(conn, 8.0)
    pos = _position(conn)
    assert math.hypot(pos.vx, pos.vy) < 30  # cm/s: the boat has stopped (it loiters)
    assert command(conn, ARM, 0) == 0


def test_guided_position_targets_and_reposition(sim: SimProcess) -> None:
    """A LOCAL_OFFSET_NED position target is reached (MISSION_ITEM_REACHED 0); DO_REPOSITION rules."""
    conn = sim.connect()
    assert set_mode(conn, MANUAL) == 0
    here = _position(conn)
    assert command(conn, DO_REPOSITION, -1, 0, 0, 0, here.lat / 1e7, here.lon / 1e7 + 1e-4) == 2  # not GUIDED, no flag
    assert command(conn, DO_REPOSITION, -1, 1, 0, 0, 0, 0) == 2  # 0/0 is refused
    goto = conn.mav.mission_item_int_encode(1, 1, 0, 0, 16, 2, 1, 0, 0, 0, 0, here.lat, here.lon + 1000, 0, 0)
    conn.mav.send(goto)
    assert wait_for(conn, "MISSION_ACK", 5).type == 1  # guided "go to" outside GUIDED
    assert command(conn, DO_REPOSITION, -1, 1, 0, 0, here.lat / 1e7, here.lon / 1e7) == 0  # flag switches to GUIDED
    wait_mode(conn, GUIDED)
    assert command(conn, ARM, 1) == 0
    xy_only = 0b0000_1111_1111_1100
    conn.mav.set_position_target_local_ned_send(0, 1, 1, 7, xy_only, 0, 20, 0, 0, 0, 0, 0, 0, 0, 0, 0)
    assert wait_for(conn, "MISSION_ITEM_REACHED", 30).seq == 0
    there = _position(conn)
    east = (there.lon - here.lon) * 1e-7 * 111_319.5 * math.cos(math.radians(here.lat * 1e-7))
    assert 16 < east < 24
    assert command(conn, ARM, 0) == 0
    assert set_mode(conn, MANUAL) == 0
