"""Details a ground station or companion relies on, checked against ArduPilot Rover's documented behaviour."""

from __future__ import annotations

from pathlib import Path

from sim_vehicle.harness import SimProcess, command, run_for, set_mode, wait_for

MAV_CMD_REQUEST_MESSAGE = 512
CAP_SET_ATTITUDE_TARGET, CAP_TERRAIN = 64, 512
MODE_HOLD, MODE_GUIDED = 4, 15


def test_capabilities_advertise_attitude_targets_and_no_terrain(tmp_path: Path) -> None:
    with SimProcess(tmp_path, speedup=10, extra=["--wipe"]) as sim:
        conn = sim.connect()
        assert command(conn, MAV_CMD_REQUEST_MESSAGE, 148) == 0
        version = wait_for(conn, "AUTOPILOT_VERSION", 10)
        assert version is not None
        assert version.capabilities & CAP_SET_ATTITUDE_TARGET and not version.capabilities & CAP_TERRAIN


def test_no_failsafe_in_hold_but_it_acts_when_hold_is_left(tmp_path: Path) -> None:
    """Rover skips its failsafes in HOLD (FS_OPTIONS bit 0 clear); the timer runs on meanwhile."""
    with SimProcess(tmp_path, speedup=10, extra=["--wipe", "--no-rc-receiver"]) as sim:
        conn = sim.connect(source_system=250)  # not the GCS sysid: sends no overrides
        assert set_mode(conn, MODE_HOLD) == 0
        texts: list[str] = []
        statuses: list[int] = []

        def collect() -> None:
            while (msg := conn.recv_match(type=["STATUSTEXT", "HEARTBEAT"], blocking=False)) is not None:
                (texts.append(msg.text) if msg.get_type() == "STATUSTEXT" else statuses.append(msg.system_status))

        run_for(conn, 5.0, collect, period_s=0.2)
        assert not any("Failsafe" in t for t in texts) and 5 not in statuses  # 5 = MAV_STATE_CRITICAL
        assert set_mode(conn, MODE_GUIDED) == 0
        failsafe = wait_for(conn, "STATUSTEXT", 10, lambda m: "Failsafe" in m.text)
        assert failsafe is not None  # the condition had lasted long enough: it acts at once
