"""An autopilot reboot 30 s into a run: the companion notices (heartbeat gap, time_boot_ms back to zero), stops
commanding, asks for its streams again, and flies again only once the pilot re-engages (arms in the mode)."""

from __future__ import annotations

from pathlib import Path

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim_vehicle.harness import SimProcess
from tests.rover import ACCEPTED, ARM
from tests.sim_vehicle.test_sim_reboot import FORCE, REBOOT, reconnect
from tests.system.test_companion_sitl import HOME, Companion
from tests.system.test_link_faults import received_commands
from tests.waits import WaitTimeoutError, command, sim_seconds, wait_for

pytestmark = [pytest.mark.slow, pytest.mark.integration]


def wait_line(companion: Companion, text: str, timeout_s: float) -> None:
    """Block until the companion printed ``text``; WaitTimeoutError with its last lines otherwise."""
    if not companion.wait_line(text, timeout_s):
        raise WaitTimeoutError(f"the companion never printed {text!r} within {timeout_s:g} s:\n"
                               + "\n".join(companion.lines[-15:]))


def test_reboot_mid_run_releases_and_waits_for_the_pilot(tmp_path: Path) -> None:
    with SimProcess(tmp_path / "sim", speedup=5.0, waves="paper", extra=[HOME, "--wipe"], udp_outs=1) as sim:
        companion = Companion(sim.udp_ports[0], tmp_path / "companion")
        try:
            conn = sim.connect()
            wait_line(companion, "phase: engaged", 120)
            engaged_s = sim_seconds(conn)
            while sim_seconds(conn) < engaged_s + 30.0:
                pass
            assert command(conn, REBOOT, 1, 0, 0, 0, 0, FORCE) == ACCEPTED
            wait_line(companion, "autopilot rebooted", 60)
            conn = reconnect(sim)
            start_s = sim_seconds(conn)
            while (now := sim_seconds(conn)) < start_s + 10.0:  # 10 s of the new boot: nobody drives
                rc = wait_for(conn, "RC_CHANNELS", 5)
                assert rc.chan3_raw < 1550, f"throttle {rc.chan3_raw} at t = {now:.1f} s after the reboot"
            heartbeat = wait_for(conn, "HEARTBEAT", 5)
            assert not heartbeat.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED
            since = companion.lines[_index(companion, "autopilot rebooted"):]
            assert not any("phase: engaged" in line for line in since), "\n".join(since)
            assert command(conn, ARM, 1) == ACCEPTED  # the pilot engages again (armed, in MANUAL)
            assert companion.wait(300) == 0, "\n".join(companion.lines[-20:])
        finally:
            companion.stop()
        metrics = companion.metrics()
        assert metrics["phase"] == "ARRIVED" and metrics["link"]["reboots"] == 1, metrics
        after = companion.lines[_index(companion, "autopilot rebooted"):]
        assert any("phase: engaged" in line for line in after), "\n".join(after)
        attitude_requests = [m for m in received_commands(sim) if m.command == mavlink.MAV_CMD_SET_MESSAGE_INTERVAL
                             and m.param1 == mavlink.MAVLINK_MSG_ID_ATTITUDE and m.param2 > 0]
        assert len(attitude_requests) >= 2, "ATTITUDE's rate must be asked for again after the reboot"
        print("\n" + "\n".join(after[:6]))



def _index(companion: Companion, text: str) -> int:
    """Index of the first line containing ``text``."""
    return next(i for i, line in enumerate(companion.lines) if text in line)
