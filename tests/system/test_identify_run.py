"""`mavbridge run --identify` against the simulator: the run's consent rules (nothing sent without --arm /
--set-mode), the range limit around where the sequence started (stands down, exit 1), the time limit
(--max-time; the run folder then holds what `mavbridge identify` reads), and the paths it refuses in one line."""

from __future__ import annotations

import signal
import socket
import subprocess
import sys
from pathlib import Path

import pytest
from pymavlink import mavutil

from sim_vehicle.harness import SimProcess, free_port
from tests.system.processes import collecting, wait_for_line
from tests.waits import wait_sim_time

pytestmark = pytest.mark.integration
RUN = [sys.executable, "-m", "mavbridge.cli", "run", "--identify"]


def _messages(tlog: Path) -> dict[str, list]:
    """The companion's tlog by message type."""
    log = mavutil.mavlink_connection(str(tlog))
    found: dict[str, list] = {}
    while (msg := log.recv_match()) is not None:
        found.setdefault(msg.get_type(), []).append(msg)
    return found


def _commanding(overrides: list) -> list:
    """RC_CHANNELS_OVERRIDE messages that held the throttle or steering (not released, not at trim)."""
    return [m for m in overrides if m.chan3_raw not in (0, 1500, 65535) or m.chan1_raw not in (0, 1500, 65535)]


@pytest.mark.parametrize("flags", [["--output", "attitude_target"], ["--waypoint", "10,10"]])
def test_identify_refuses_what_it_cannot_fly_in_one_line(tmp_path: Path, flags: list[str]) -> None:
    done = subprocess.run([*RUN, "--connect", f"udpin:127.0.0.1:{free_port(socket.SOCK_DGRAM)}", *flags,
                           "--out", str(tmp_path / "run")], capture_output=True, text=True, timeout=120)
    assert done.returncode == 2, done.stdout + done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "--identify" in lines[0] and "Traceback" not in done.stderr, done.stderr


def test_identify_stands_down_beyond_its_range_from_where_it_started(tmp_path: Path) -> None:
    with SimProcess(tmp_path / "sim", speedup=10, udp_outs=1) as sim:
        done = subprocess.run([*RUN, "--connect", f"udpin:127.0.0.1:{sim.udp_ports[0]}", "--arm", "--set-mode",
                               "--max-range", "4", "--out", str(tmp_path / "run")], capture_output=True, text=True,
                              timeout=300)
    text = done.stdout + done.stderr
    assert done.returncode == 1, text[-3000:]
    assert "farther than --max-range 4 m: standing down" in text, text[-3000:]
    overrides = _messages(tmp_path / "run" / "companion.tlog")["RC_CHANNELS_OVERRIDE"]
    assert _commanding(overrides), "it flew before the limit"
    assert overrides[-1].chan3_raw == 0 and overrides[-1].chan1_raw == 0  # released at the end


def test_identify_ends_at_max_time_with_what_identify_reads(tmp_path: Path) -> None:
    with SimProcess(tmp_path / "sim", speedup=10, udp_outs=1) as sim:
        done = subprocess.run([*RUN, "--connect", f"udpin:127.0.0.1:{sim.udp_ports[0]}", "--arm", "--set-mode",
                               "--max-time", "12", "--out", str(tmp_path / "run")], capture_output=True, text=True,
                              timeout=300)
    text = done.stdout + done.stderr
    assert done.returncode == 0 and "max_time_s reached" in text, text[-3000:]
    assert "identification: throttle 0.3" in text  # the second leg began (the first is 5 s at rest)
    got = _messages(tmp_path / "run" / "companion.tlog")
    assert got.get("SERVO_OUTPUT_RAW") and got.get("GLOBAL_POSITION_INT") and got.get("ATTITUDE")
    assert _commanding(got["RC_CHANNELS_OVERRIDE"]) and got["RC_CHANNELS_OVERRIDE"][-1].chan3_raw == 0
    assert (tmp_path / "run" / "companion.csv").exists() and (tmp_path / "run" / "metrics.json").exists()


def test_identify_without_consent_sends_nothing(tmp_path: Path) -> None:
    with SimProcess(tmp_path / "sim", speedup=10, udp_outs=1) as sim:
        conn = sim.connect()
        argv = [*RUN, "--connect", f"udpin:127.0.0.1:{sim.udp_ports[0]}", "--out", str(tmp_path / "run")]
        with collecting(argv) as (proc, lines):
            wait_for_line(proc, lines, "rates per autopilot second", timeout_s=120)
            start = wait_sim_time(conn, 0.0).time_boot_ms / 1000.0
            wait_sim_time(conn, start + 20.0, timeout=60.0)  # 20 s of the autopilot's time, waiting for the pilot
            proc.send_signal(signal.SIGTERM)
            code = proc.wait(timeout=30)
    text = "".join(lines)
    assert code == 0, text[-3000:]
    assert "identification: flying" not in text
    assert not _commanding(_messages(tmp_path / "run" / "companion.tlog").get("RC_CHANNELS_OVERRIDE", []))
