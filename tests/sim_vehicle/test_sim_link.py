"""End-to-end: a pymavlink TCP client against a real sim-vehicle process (heartbeat, params, modes)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from sim_vehicle.harness import SimProcess
from tests.rover import (
    ARM,
    AUTO,
    DO_CHANGE_SPEED,
    DO_SET_MODE,
    GUIDED,
    HOLD,
    MANUAL,
    REQUEST_MESSAGE,
    RTL,
    SET_MESSAGE_INTERVAL,
)
from tests.waits import command, command_texts, list_parameters, set_mode, wait_for, wait_mode

# the tests of this module share the conftest ``sim`` process (10x) and leave it disarmed in MANUAL
MISSION_START = 300


def test_boat_heartbeat(sim: SimProcess) -> None:
    """A TCP client sees a Rover-boat heartbeat from system 1 component 1."""
    conn = sim.connect()
    hb = wait_for(conn, "HEARTBEAT", 5, lambda m: m.get_srcSystem() == 1)
    assert (hb.type, hb.autopilot, hb.get_srcComponent()) == (11, 3, 1)
    assert hb.base_mode & 1 and hb.base_mode & 64 and not hb.base_mode & 128
    assert hb.custom_mode == MANUAL and hb.system_status == 4


def test_download_every_parameter(sim: SimProcess) -> None:
    """PARAM_REQUEST_LIST yields each index once, with Rover's names and types."""
    by_name = list_parameters(sim.connect())
    assert by_name["FRAME_CLASS"].param_value == 2 and by_name["FRAME_CLASS"].param_type == 2
    assert by_name["SYSID_MYGCS"].param_value == 255
    assert by_name["SERVO1_FUNCTION"].param_value == 73 and by_name["SERVO3_FUNCTION"].param_value == 74
    assert by_name["WP_SPEED"].param_type == 9
    for name in (
        "RC_OVERRIDE_TIME",
        "FS_ACTION",
        "FS_TIMEOUT",
        "FS_GCS_ENABLE",
        "WP_RADIUS",
        "CRUISE_SPEED",
        "CRUISE_THROTTLE",
        "RC1_MIN",
        "RC3_MAX",
        "RC1_TRIM",
        "RC3_DZ",
        "SR0_EXTRA1",
    ):
        assert name in by_name


def test_param_read_and_set(sim: SimProcess) -> None:
    """Read by name answers with index 65535; set echoes the new value; NaN and unknown names are refused."""
    conn = sim.connect()
    conn.mav.param_request_read_send(1, 1, b"WP_RADIUS", -1)
    msg = wait_for(conn, "PARAM_VALUE", 5, lambda m: m.param_id == "WP_RADIUS")
    assert msg.param_value == 2.0 and msg.param_index == 65535
    conn.mav.param_set_send(1, 1, b"WP_RADIUS", 3.5, 9)
    assert wait_for(conn, "PARAM_VALUE", 5, lambda m: m.param_id == "WP_RADIUS").param_value == 3.5
    conn.mav.param_set_send(1, 1, b"WP_RADIUS", float("nan"), 9)
    assert wait_for(conn, "PARAM_ERROR", 5).error == 2
    conn.mav.param_set_send(1, 1, b"NO_SUCH_PARAM", 1.0, 9)
    assert wait_for(conn, "PARAM_ERROR", 5, lambda m: m.param_id == "NO_SUCH_PARAM").error == 1
    conn.mav.param_set_send(1, 1, b"FRAME_CLASS", 2.7, 9)  # wrong type: cast to INT8 like AP_Param
    assert wait_for(conn, "PARAM_VALUE", 5, lambda m: m.param_id == "FRAME_CLASS").param_value == 3
    conn.mav.param_set_send(1, 1, b"FRAME_CLASS", 2, 2)
    assert wait_for(conn, "PARAM_VALUE", 5, lambda m: m.param_id == "FRAME_CLASS").param_value == 2
    conn.mav.param_set_send(1, 1, b"WP_RADIUS", 2.0, 9)
    assert wait_for(conn, "PARAM_VALUE", 5, lambda m: m.param_id == "WP_RADIUS").param_value == 2.0


def test_modes_with_acks(sim: SimProcess) -> None:
    """MANUAL -> GUIDED -> HOLD with ACCEPTED ACKs and heartbeats that follow; mode 99 fails."""
    conn = sim.connect()
    for mode in (MANUAL, GUIDED, HOLD):
        assert set_mode(conn, mode) == 0
        wait_mode(conn, mode)
    assert wait_for(conn, "HEARTBEAT", 5).system_status == 3  # STANDBY in HOLD
    assert set_mode(conn, 99) == 4
    conn.mav.set_mode_send(1, 1, GUIDED)
    ack = wait_for(conn, "COMMAND_ACK", 5, lambda m: m.command == 11)
    assert ack.result == 0
    conn.mav.set_mode_send(1, 0, MANUAL)  # without CUSTOM_MODE_ENABLED
    assert wait_for(conn, "COMMAND_ACK", 5, lambda m: m.command == 11).result == 2
    assert set_mode(conn, MANUAL) == 0


def test_arm_and_disarm(sim: SimProcess) -> None:
    """Arming sets the armed bit and says so; disarming clears it."""
    conn = sim.connect()
    assert set_mode(conn, MANUAL) == 0
    assert command(conn, ARM, 1) == 0
    wait_for(conn, "HEARTBEAT", 5, lambda m: m.base_mode & 128)
    assert command(conn, ARM, 1) == 0  # already armed
    assert command(conn, ARM, 0) == 0
    wait_for(conn, "HEARTBEAT", 5, lambda m: not m.base_mode & 128)
    assert command(conn, ARM, 7) == 3


def test_arming_refused_in_rtl_and_auto_without_mission(sim: SimProcess) -> None:
    """RTL is not armable; AUTO cannot be entered without a mission; both explain themselves."""
    conn = sim.connect()
    assert set_mode(conn, RTL) == 0
    result, texts = command_texts(conn, ARM, 1)
    assert result == 4 and "PreArm: Mode not armable" in texts
    result, texts = command_texts(conn, DO_SET_MODE, 1, AUTO)
    assert result == 4 and "No Mission. Can't set AUTO." in texts
    assert command(conn, MISSION_START) == 4  # MISSION_START also needs a mission
    assert wait_for(conn, "HEARTBEAT", 5, lambda m: m.custom_mode == RTL and not m.base_mode & 128)
    assert set_mode(conn, MANUAL) == 0


def test_requests_and_intervals(sim: SimProcess) -> None:
    """REQUEST_MESSAGE (AUTOPILOT_VERSION, HOME_POSITION), SET_MESSAGE_INTERVAL and unknown commands."""
    conn = sim.connect()
    assert command(conn, REQUEST_MESSAGE, 148) == 0
    version = wait_for(conn, "AUTOPILOT_VERSION", 5)
    assert version.capabilities & 4  # MISSION_INT
    assert command(conn, REQUEST_MESSAGE, 242) == 0
    home = wait_for(conn, "HOME_POSITION", 5)
    assert abs(home.latitude - (-353632610)) <= 1
    assert command(conn, SET_MESSAGE_INTERVAL, 30, 20000) == 0  # ATTITUDE at 50 Hz
    first = wait_for(conn, "ATTITUDE", 5)
    n, last = 0, first
    while last.time_boot_ms - first.time_boot_ms < 2000:
        last = wait_for(conn, "ATTITUDE", 5)
        n += 1
    assert 90 <= n <= 110
    assert command(conn, SET_MESSAGE_INTERVAL, 30, -1) == 0
    assert command(conn, SET_MESSAGE_INTERVAL, 9999, 1000) == 4
    assert command(conn, 31337) == 3
    assert command(conn, SET_MESSAGE_INTERVAL, 30, 0) == 0


def test_cli_bad_flags_one_line(tmp_path: Path) -> None:
    """Bad flags and bad values: exactly one line on stderr, exit status 2, no traceback."""
    bad_parm = tmp_path / "bad.parm"
    bad_parm.write_text("WP_SPEED\n")
    for args in (
        ["--bogus"],
        ["--speedup", "x"],
        ["--tcp", "70000"],
        ["--home", "1,2"],
        ["--waves", "huge"],
        ["--params", str(tmp_path / "missing.parm")],
        ["--params", str(bad_parm)],
        ["--out", "tcp:1:2"],
        ["--sea", "10,35,6,0"],
        ["--current", "1"],
    ):
        run = subprocess.run(
            [sys.executable, "-m", "sim_vehicle.cli", *args, "--params-store", str(tmp_path / "p.json")],
            capture_output=True,
            text=True,
            timeout=30,
        )
        assert run.returncode == 2, args
        assert len(run.stderr.strip().splitlines()) == 1, (args, run.stderr)
        assert "Traceback" not in run.stderr


def test_hostile_values_get_ardupilot_answers(sim: SimProcess) -> None:
    """NaN command parameters fail cleanly, PWM 5000 saturates, a NaN attitude target is dropped."""
    conn = sim.connect()
    nan = float("nan")
    assert command(conn, DO_SET_MODE, 1, nan) == 4
    assert command(conn, ARM, nan) == 3
    assert command(conn, SET_MESSAGE_INTERVAL, nan, 1000) == 4
    assert command(conn, DO_CHANGE_SPEED, 0, nan) == 4
    assert set_mode(conn, MANUAL) == 0 and command(conn, ARM, 1) == 0
    assert command(conn, SET_MESSAGE_INTERVAL, 36, 100000) == 0
    conn.mav.rc_channels_override_send(1, 1, 1500, 65535, 5000, 65535, 65535, 65535, 65535, 65535)
    wait_for(conn, "RC_CHANNELS", 5, lambda m: m.chan3_raw == 5000)
    wait_for(conn, "SERVO_OUTPUT_RAW", 10, lambda m: m.servo1_raw == 1900 and m.servo3_raw == 1900)
    conn.mav.rc_channels_override_send(1, 1, 0, 65535, 0, 65535, 65535, 65535, 65535, 65535)
    assert command(conn, ARM, 0) == 0
    assert set_mode(conn, GUIDED) == 0
    conn.mav.set_attitude_target_send(0, 1, 1, 7, [nan, 0, 0, 0], 0, 0, nan, nan)
    wait_mode(conn, GUIDED)
    assert set_mode(conn, MANUAL) == 0
