"""MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN: refused while armed (unless forced), then a restart like SITL's —
clock from zero, disarmed, links reopened — with the stored parameters kept."""

from __future__ import annotations

import time
from pathlib import Path

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim_vehicle.harness import SimProcess
from tests.rover import ACCEPTED, ARM, FAILED
from tests.waits import WaitTimeoutError, command, sim_seconds, wait_for

pytestmark = pytest.mark.integration
REBOOT = mavlink.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN
FORCE = mavlink.REBOOT_SHUTDOWN_CONDITIONS_FORCE


def reconnect(sim: SimProcess, timeout_s: float = 30.0):
    """A new TCP client once the rebooted simulator listens again."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        try:
            return sim.connect()
        except (OSError, TimeoutError):
            time.sleep(0.2)
    raise WaitTimeoutError(f"the simulator did not accept a TCP client within {timeout_s:g} s of its reboot")


def test_reboot_is_refused_armed_and_restarts_the_clock_when_forced(tmp_path: Path) -> None:
    with SimProcess(tmp_path / "sim", speedup=5.0, extra=["--wipe"]) as sim:
        conn = sim.connect()
        conn.mav.param_set_send(1, 1, b"CRUISE_SPEED", 1.7, mavlink.MAV_PARAM_TYPE_REAL32)
        wait_for(conn, "PARAM_VALUE", 5, lambda m: m.param_id == "CRUISE_SPEED")
        assert command(conn, ARM, 1, 2989) == ACCEPTED
        while sim_seconds(conn) < 8.0:
            pass
        assert command(conn, REBOOT, 1) == FAILED  # armed: ArduPilot refuses
        assert command(conn, REBOOT, 1, 0, 0, 0, 0, FORCE) == ACCEPTED
        conn = reconnect(sim)
        assert sim_seconds(conn) < 5.0  # time_boot_ms started again
        heartbeat = wait_for(conn, "HEARTBEAT", 5)
        assert not heartbeat.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED
        conn.mav.param_request_read_send(1, 1, b"CRUISE_SPEED", -1)
        value = wait_for(conn, "PARAM_VALUE", 5, lambda m: m.param_id == "CRUISE_SPEED")
        assert value.param_value == pytest.approx(1.7)
