"""End-to-end failsafes (GCS heartbeat loss, RC loss without a receiver) and persistent parameters."""

from __future__ import annotations

from pathlib import Path

from sim_vehicle.harness import SimProcess
from tests.rover import ARM, GUIDED, HOLD, KEEP, MANUAL, SET_MESSAGE_INTERVAL
from tests.waits import command, latest_sim_seconds, run_for, set_mode, taken_by, wait_for, wait_mode

MAV_STATE_CRITICAL = 5


def _read(conn, name: str) -> float:
    conn.mav.param_request_read_send(1, 1, name.encode(), -1)
    return wait_for(conn, "PARAM_VALUE", 5, lambda m: m.param_id == name).param_value


def test_gcs_failsafe_holds_and_clears(tmp_path: Path) -> None:
    """FS_GCS_ENABLE=1: sysid 255 goes quiet -> "GCS Failsafe", HOLD, CRITICAL; it returns -> cleared."""
    parm = tmp_path / "fs.parm"
    parm.write_text("FS_GCS_ENABLE 1\nFS_GCS_TIMEOUT,2\n")
    with SimProcess(tmp_path, speedup=10, extra=["--params", str(parm)]) as sim:
        conn = sim.connect()
        assert set_mode(conn, GUIDED) == 0 and command(conn, ARM, 1) == 0
        run_for(conn, 2.0, lambda: conn.mav.heartbeat_send(6, 8, 0, 0, 0), period_s=0.5)
        wait_for(conn, "STATUSTEXT", 10, lambda m: m.text == "GCS Failsafe")
        assert wait_mode(conn, HOLD).system_status == MAV_STATE_CRITICAL
        conn.mav.heartbeat_send(6, 8, 0, 0, 0)
        wait_for(conn, "STATUSTEXT", 5, lambda m: m.text == "GCS Failsafe Cleared")
        assert command(conn, ARM, 0) == 0


def test_rc_failsafe_without_receiver_stops_before_override_expiry(tmp_path: Path) -> None:
    """No receiver: overrides stop -> Radio Failsafe after 0.5 + 1.5 s, overrides cleared, HOLD.

    Times are read from the messages (simulated time), and the simulator runs at 2x so that the test's
    override cadence (every 0.2 simulated s, against Rover's 0.5 s frame timeout) has wall-clock room on
    a busy machine. Without a receiver the failsafe triggers at boot; while it stays triggered the boat is
    put in MANUAL and armed, so no pause between commands can trigger it a second time.
    """
    with SimProcess(tmp_path, speedup=2, extra=["--no-rc-receiver", "--wipe"]) as sim:
        conn = sim.connect()
        assert command(conn, SET_MESSAGE_INTERVAL, 36, 100000) == 0
        wait_for(conn, "HEARTBEAT", 10, lambda m: m.system_status == MAV_STATE_CRITICAL)  # boot failsafe
        assert set_mode(conn, MANUAL) == 0 and command(conn, ARM, 1) == 0
        full = lambda: conn.mav.rc_channels_override_send(1, 1, 1500, KEEP, 1900, *[KEEP] * 5)  # noqa: E731
        run_for(conn, 3.0, full, period_s=0.2)  # clears the failsafe; 1 s of throttle slew to full
        t_before = latest_sim_seconds(conn)
        full()  # the last override: the simulator takes it between t_before and t_taken
        t_taken = taken_by(conn)
        held = wait_for(conn, "SERVO_OUTPUT_RAW", 10, lambda m: m.time_usec / 1e6 >= t_taken)
        assert held.servo1_raw == 1900
        wait_for(conn, "STATUSTEXT", 10, lambda m: m.text == "Radio Failsafe")
        wait_mode(conn, HOLD)
        stopped = wait_for(conn, "SERVO_OUTPUT_RAW", 10, lambda m: m.servo1_raw == 1500)
        # 0.5 s without frames + FS_TIMEOUT 1.5 s, then 1 s of throttle slew; expiry would be 3 s + slew
        assert stopped.time_usec / 1e6 - t_before >= 2.0 and stopped.time_usec / 1e6 - t_taken < 3.5


def _mission_count(conn) -> int:
    conn.mav.mission_request_list_send(1, 1, 0)
    return wait_for(conn, "MISSION_COUNT", 5).count


def test_parameters_and_mission_persist_across_restarts(tmp_path: Path) -> None:
    """PARAM_SET and an uploaded mission survive a restart; --wipe forgets both; --params sets defaults."""
    with SimProcess(tmp_path, speedup=10) as sim:
        conn = sim.connect()
        conn.mav.param_set_send(1, 1, b"WP_SPEED", 3.25, 9)
        assert wait_for(conn, "PARAM_VALUE", 5, lambda m: m.param_id == "WP_SPEED").param_value == 3.25
        conn.mav.mission_count_send(1, 1, 2, 0)
        for seq in (0, 1):
            assert wait_for(conn, "MISSION_REQUEST", 5).seq == seq
            lon = 1491652300 + seq
            conn.mav.mission_item_int_send(1, 1, seq, 3, 16, 0, 1, 0, 0, 0, 0, -353632610, lon, 0, 0)
        assert wait_for(conn, "MISSION_ACK", 5).type == 0
    with SimProcess(tmp_path, speedup=10) as sim:
        conn = sim.connect()
        assert _read(conn, "WP_SPEED") == 3.25
        assert _mission_count(conn) == 2
    parm = tmp_path / "defaults.parm"
    parm.write_text("# defaults\nWP_SPEED 1.5\nNOT_A_PARAM 3\n")
    with SimProcess(tmp_path, speedup=10, extra=["--wipe", "--params", str(parm)]) as sim:
        conn = sim.connect()
        assert _read(conn, "WP_SPEED") == 1.5
        assert _mission_count(conn) == 1
        err = sim.stop()
    assert "ignoring unknown parameter NOT_A_PARAM" in err
