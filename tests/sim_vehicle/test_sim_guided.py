"""MANUAL_CONTROL overrides and GUIDED targets as Rover reads them (from branch wip-sim-manual-control).

Checked against Rover's GCS_Mavlink.cpp (handle_manual_control_axes, handle_set_position_target_*) and
mode_guided.cpp (set_desired_speed): any set bit of a type_mask group ignores it, accelerations must be
ignored, DO_CHANGE_SPEED changes the waypoint speed but is refused for heading / turn-rate targets.
"""

from __future__ import annotations

import math
from typing import Any

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim_vehicle.harness import SimProcess
from tests.rover import ARM, DO_CHANGE_SPEED, DO_REPOSITION, FAILED, GUIDED, MANUAL, SET_MESSAGE_INTERVAL
from tests.waits import command, drain, run_for, set_mode, wait_for

M = mavlink
M_PER_DEG = 111_319.5
POS_IGNORE = 0b111 * M.POSITION_TARGET_TYPEMASK_X_IGNORE  # x, y, z
VEL_IGNORE = 0b111 * M.POSITION_TARGET_TYPEMASK_VX_IGNORE  # vx, vy, vz
ACC_IGNORE = 0b111 * M.POSITION_TARGET_TYPEMASK_AX_IGNORE  # ax, ay, az
YAW_IGNORE, YAW_RATE_IGNORE = M.POSITION_TARGET_TYPEMASK_YAW_IGNORE, M.POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE
POS_ONLY = VEL_IGNORE | ACC_IGNORE | YAW_IGNORE | YAW_RATE_IGNORE
VEL_ONLY_XY = POS_IGNORE | M.POSITION_TARGET_TYPEMASK_VZ_IGNORE | ACC_IGNORE  # plus a yaw or yaw-rate bit


def _forward_speed(pos: Any, att: Any) -> float:
    """Velocity along the heading (m/s) from GLOBAL_POSITION_INT and ATTITUDE."""
    return (pos.vx * math.cos(att.yaw) + pos.vy * math.sin(att.yaw)) / 100.0


def _manual(conn: Any, y: int, z: int) -> None:
    """MANUAL_CONTROL to system 1: y steering, z throttle (-1000..1000)."""
    conn.mav.manual_control_send(1, 0, y, z, 0, 0)


def _pose(conn: Any) -> tuple[Any, Any]:
    return wait_for(conn, "GLOBAL_POSITION_INT", 5), wait_for(conn, "ATTITUDE", 5)


def _ahead(pos: Any, yaw: float, metres: float) -> tuple[float, float]:
    """lat/lon (deg) ``metres`` ahead of ``pos`` along ``yaw`` (rad from north)."""
    lat, lon = pos.lat * 1e-7, pos.lon * 1e-7
    dn, de = metres * math.cos(yaw), metres * math.sin(yaw)
    return lat + dn / M_PER_DEG, lon + de / (M_PER_DEG * math.cos(math.radians(lat)))


def _mean(conn: Any, sim_s: float, read: Any, period_s: float = 0.5) -> float:
    """Mean of ``read()`` sampled every ``period_s`` simulated seconds for ``sim_s`` of them."""
    samples: list[float] = []
    run_for(conn, sim_s, lambda: samples.append(read()), period_s=period_s)
    assert samples, "no samples taken"
    return sum(samples) / len(samples)


def _ground_speed(conn: Any) -> float:
    pos = wait_for(conn, "GLOBAL_POSITION_INT", 2)
    return math.hypot(pos.vx, pos.vy) / 100.0


def _local_target(conn: Any, mask: int, vx: float, yaw: float = 0.0, yaw_rate: float = 0.0) -> None:
    conn.mav.set_position_target_local_ned_send(
        0, 1, 1, M.MAV_FRAME_LOCAL_NED, mask, 0, 0, 0, vx, 0, 0, 0, 0, 0, yaw, yaw_rate
    )


def test_manual_control_from_gcs_drives_forward_other_sysid_ignored(sim: SimProcess, gcs: Any) -> None:
    """z=800 from sysid 255 overrides the throttle channel; the same from sysid 200 does nothing."""
    assert command(gcs, SET_MESSAGE_INTERVAL, 36, 100000) == 0  # SERVO_OUTPUT_RAW at 10 Hz
    assert set_mode(gcs, MANUAL) == 0 and command(gcs, ARM, 1) == 0
    other = sim.connect(source_system=200)
    run_for(other, 3.0, lambda: _manual(other, 0, 800))
    drain(gcs)
    servo = wait_for(gcs, "SERVO_OUTPUT_RAW", 5)
    assert (servo.servo1_raw, servo.servo3_raw) == (1500, 1500)
    assert wait_for(gcs, "RC_CHANNELS", 5).chan3_raw == 1500
    run_for(gcs, 6.0, lambda: _manual(gcs, 0, 800))
    rc = wait_for(gcs, "RC_CHANNELS", 5)
    assert (rc.chan1_raw, rc.chan3_raw) == (1500, 1820)  # RC3 1100..1900: 1100 + 800 * (800 + 1000) / 2000
    servo = wait_for(gcs, "SERVO_OUTPUT_RAW", 5)
    assert servo.servo1_raw > 1700 and servo.servo3_raw > 1700
    assert _forward_speed(*_pose(gcs)) > 1.0


def test_change_speed_applies_to_current_and_later_guided_targets(gcs: Any) -> None:
    """DO_REPOSITION 100 m ahead then DO_CHANGE_SPEED 0.8: cruise near 0.8 m/s, also toward a new target."""
    assert set_mode(gcs, GUIDED) == 0 and command(gcs, ARM, 1) == 0
    pos, att = _pose(gcs)
    lat, lon = _ahead(pos, att.yaw, 100.0)
    assert command(gcs, DO_REPOSITION, -1, 0, 0, 0, lat, lon, 0) == 0
    assert command(gcs, DO_CHANGE_SPEED, 1, 0.8, -1) == 0
    run_for(gcs, 8.0)
    assert _mean(gcs, 6.0, lambda: _ground_speed(gcs)) == pytest.approx(0.8, abs=0.2)
    pos, att = _pose(gcs)
    lat, lon = _ahead(pos, att.yaw, 80.0)
    gcs.mav.set_position_target_global_int_send(
        0, 1, 1, M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, POS_ONLY, round(lat * 1e7), round(lon * 1e7), 0,
        0, 0, 0, 0, 0, 0, 0, 0,
    )
    run_for(gcs, 4.0)
    assert _mean(gcs, 5.0, lambda: _ground_speed(gcs)) == pytest.approx(0.8, abs=0.2)


def test_change_speed_is_refused_for_a_heading_target(gcs: Any) -> None:
    """A heading/speed target (SET_ATTITUDE_TARGET) carries its own speed: DO_CHANGE_SPEED FAILED as in Rover."""
    assert set_mode(gcs, GUIDED) == 0
    assert command(gcs, DO_CHANGE_SPEED, 1, 0.8, -1) == 0  # loitering on entry: accepted
    q = [math.cos(math.pi / 4), 0.0, 0.0, math.sin(math.pi / 4)]
    gcs.mav.set_attitude_target_send(0, 1, 1, M.ATTITUDE_TARGET_TYPEMASK_BODY_YAW_RATE_IGNORE, q, 0, 0, 0, 0.5)
    run_for(gcs, 0.5)
    assert command(gcs, DO_CHANGE_SPEED, 1, 0.8, -1) == FAILED


def test_velocity_with_yaw_rate_turns(gcs: Any) -> None:
    """vx=1 with yaw rate 0.3 rad/s: the boat circles at about 0.3 rad/s."""
    assert set_mode(gcs, GUIDED) == 0 and command(gcs, ARM, 1) == 0
    mask = VEL_ONLY_XY | YAW_IGNORE
    run_for(gcs, 5.0, lambda: _local_target(gcs, mask, 1.0, yaw_rate=0.3))

    def rate() -> float:
        _local_target(gcs, mask, 1.0, yaw_rate=0.3)
        return wait_for(gcs, "ATTITUDE", 2).yawspeed

    assert _mean(gcs, 4.0, rate, period_s=0.3) == pytest.approx(0.3, abs=0.08)


def test_negative_vx_with_yaw_goes_astern(gcs: Any) -> None:
    """vx=-0.5 with yaw = current heading: the boat keeps its heading and moves backwards."""
    assert set_mode(gcs, GUIDED) == 0 and command(gcs, ARM, 1) == 0
    heading = wait_for(gcs, "ATTITUDE", 5).yaw
    mask = VEL_ONLY_XY | YAW_RATE_IGNORE
    run_for(gcs, 6.0, lambda: _local_target(gcs, mask, -0.5, yaw=heading))
    pos, att = _pose(gcs)
    assert _forward_speed(pos, att) < -0.25
    assert abs(math.remainder(att.yaw - heading, 2 * math.pi)) < 0.2


def test_position_target_without_acc_ignore_is_refused_with_a_text(gcs: Any) -> None:
    """Accelerations not ignored: Rover drops the whole message and says how to fix the mask."""
    assert set_mode(gcs, GUIDED) == 0 and command(gcs, ARM, 1) == 0
    mask = POS_ONLY & ~ACC_IGNORE
    gcs.mav.set_position_target_local_ned_send(
        0, 1, 1, M.MAV_FRAME_LOCAL_OFFSET_NED, mask, 30, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0
    )
    first = wait_for(gcs, "STATUSTEXT", 5, lambda m: m.text.startswith("Ignoring SET_POSITION_TARGET"))
    rest = wait_for(gcs, "STATUSTEXT", 5, lambda m: m.id == first.id and m.chunk_seq == 1)  # 50-byte chunks
    assert first.text + rest.text == "Ignoring SET_POSITION_TARGET_LOCAL_NED; set ACC_IGNORE in mask"
    run_for(gcs, 4.0)
    assert _ground_speed(gcs) < 0.3  # it stayed loitering
