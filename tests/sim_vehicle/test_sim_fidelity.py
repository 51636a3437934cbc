"""Details a ground station or companion relies on, checked against ArduPilot Rover's documented behaviour."""

from __future__ import annotations

from collections.abc import Callable

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim_vehicle.harness import SimProcess
from tests.rover import GUIDED, HOLD, REQUEST_MESSAGE
from tests.waits import command, run_for, set_mode, wait_for

CAP_SET_ATTITUDE_TARGET = mavlink.MAV_PROTOCOL_CAPABILITY_SET_ATTITUDE_TARGET
CAP_TERRAIN = mavlink.MAV_PROTOCOL_CAPABILITY_TERRAIN


def test_capabilities_advertise_attitude_targets_and_no_terrain(start_sim: Callable[..., SimProcess]) -> None:
    conn = start_sim(extra=["--wipe"]).connect()
    assert command(conn, REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION) == 0
    version = wait_for(conn, "AUTOPILOT_VERSION", 10)
    assert version.capabilities & CAP_SET_ATTITUDE_TARGET and not version.capabilities & CAP_TERRAIN


def test_no_failsafe_in_hold_but_it_acts_when_hold_is_left(start_sim: Callable[..., SimProcess]) -> None:
    """Rover skips its failsafes in HOLD (FS_OPTIONS bit 0 clear); the timer runs on meanwhile."""
    sim = start_sim(extra=["--wipe", "--no-rc-receiver"])
    conn = sim.connect(source_system=250)  # not the GCS sysid: sends no overrides
    assert set_mode(conn, HOLD) == 0
    texts: list[str] = []
    statuses: list[int] = []

    def collect() -> None:
        while (msg := conn.recv_match(type=["STATUSTEXT", "HEARTBEAT"], blocking=False)) is not None:
            (texts.append(msg.text) if msg.get_type() == "STATUSTEXT" else statuses.append(msg.system_status))

    run_for(conn, 5.0, collect, period_s=0.2)
    assert not any("Failsafe" in t for t in texts) and 5 not in statuses  # 5 = MAV_STATE_CRITICAL
    assert set_mode(conn, GUIDED) == 0
    wait_for(conn, "STATUSTEXT", 10, lambda m: "Failsafe" in m.text)  # it had lasted long enough: acts at once
