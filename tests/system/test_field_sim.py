"""`mavbridge report` and `replay` on real ground stations' logs (issue 30): the simulator's own tlog and
MAVProxy's, of one trial driven in the paper's waves (MANUAL on RC overrides, then HOLD), read back and checked
against what pymavlink itself reads from the same files."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest
from pymavlink import mavutil

from mavbridge.cli import main
from sim_vehicle.harness import SimProcess
from tests.rover import ARM, HOLD, KEEP, MANUAL, SET_MESSAGE_INTERVAL
from tests.system.test_mavproxy import MAVPROXY, Console
from tests.waits import command, run_for, set_mode, sim_seconds, upload_waypoint, wait_for
from vessel.geo import ned_from_latlon

pytestmark = [pytest.mark.slow, pytest.mark.integration]
WAYPOINT = (60.0, -40.0)
STEERING, THROTTLE = 1600, 1800  # a gentle right turn at most of full throttle
ARMED = mavutil.mavlink.MAV_MODE_FLAG_SAFETY_ARMED


def _attitudes(tlog: Path) -> list[tuple[int, float]]:
    """(time_boot_ms, roll) of every ATTITUDE of system 1 component 1, as pymavlink reads the file."""
    log = mavutil.mavlink_connection(str(tlog), dialect="ardupilotmega")
    found = []
    while (msg := log.recv_match(type="ATTITUDE")) is not None:
        if (msg.get_srcSystem(), msg.get_srcComponent()) == (1, 1):
            found.append((msg.time_boot_ms, msg.roll))
    return found


def _drive(sim: SimProcess) -> tuple[float, float]:
    """Download every parameter (as a ground station does at connection: they are in the logs then), upload the
    waypoint, drive 40 s in MANUAL on overrides, then HOLD; (armed in MANUAL at, HOLD at) s."""
    conn = sim.connect()
    conn.mav.param_request_list_send(1, 1)
    first = wait_for(conn, "PARAM_VALUE", 10)
    seen = {first.param_index}
    while len(seen) < first.param_count:
        seen.add(wait_for(conn, "PARAM_VALUE", 10).param_index)
    for message_id, hz in ((30, 20), (36, 5), (65, 5)):  # ATTITUDE, SERVO_OUTPUT_RAW, RC_CHANNELS
        assert command(conn, SET_MESSAGE_INTERVAL, message_id, 1e6 / hz) == 0
    upload_waypoint(conn, *WAYPOINT)
    assert set_mode(conn, MANUAL) == 0 and command(conn, ARM, 1) == 0
    wait_for(conn, "HEARTBEAT", 5, lambda m: m.custom_mode == MANUAL and m.base_mode & ARMED)
    start = sim_seconds(conn)
    end = run_for(conn, 40.0, lambda: conn.mav.rc_channels_override_send(
        1, 1, STEERING, KEEP, THROTTLE, KEEP, KEEP, KEEP, KEEP, KEEP), period_s=0.2, wall_timeout=90)
    assert set_mode(conn, HOLD) == 0
    run_for(conn, 5.0)
    return start, end


@pytest.mark.skipif(not Path(MAVPROXY).exists(), reason="MAVProxy is not installed (pip install '.[test]')")
def test_report_and_replay_read_the_simulators_and_mavproxys_tlogs(tmp_path: Path,
                                                                    capsys: pytest.CaptureFixture[str]) -> None:
    proxy_log = tmp_path / "mavproxy" / "mav.tlog"
    proxy_log.parent.mkdir()
    with SimProcess(tmp_path / "sim", speedup=10, waves="paper") as sim:
        console = Console([MAVPROXY, "--master", f"tcp:127.0.0.1:{sim.tcp_port}", "--state-basedir",
                           str(proxy_log.parent), "--logfile", str(proxy_log), "--default-modules", "mode",
                           "--non-interactive"])
        try:
            console.expect("Mode ", timeout=60)  # MAVProxy sees the autopilot
            engaged, stopped = _drive(sim)
        finally:
            console.close()
    sim_log = sim.log_dir / "sim_vehicle.tlog"
    assert main(["report", str(sim_log), str(proxy_log), "--out", str(tmp_path / "report")]) == 0
    out = capsys.readouterr().out
    logs = json.loads((tmp_path / "report" / "report.json").read_text())["logs"]
    for entry, path in zip(logs, (sim_log, proxy_log), strict=True):
        rolls = _attitudes(path)
        assert entry["source"] == "autopilot 1/1 (ArduPilot, surface boat)"
        assert entry["attitude_samples"] == len(rolls)  # every ATTITUDE of the autopilot, no other sender's
        assert entry["avg_roll_deg"] == pytest.approx(np.degrees(np.mean(np.abs([r for _, r in rolls]))), abs=1e-4)
        manual = [m for m in entry["modes"] if m["label"] == "MANUAL (armed)"]
        assert manual and manual[0]["duration_s"] == pytest.approx(stopped - engaged, abs=1.5), entry["modes"]
        assert manual[0]["mean_speed_m_s"] > 1.0 and entry["modes"][-1]["label"] == "HOLD (armed)"
    home, point = logs[0]["home"], logs[0]["waypoints"][0]  # the upload is in the simulator's log (not MAVProxy's)
    assert ned_from_latlon(home["lat_deg"], home["lon_deg"], point["lat_deg"], point["lon_deg"]) == \
        pytest.approx(WAYPOINT, abs=0.2)
    assert any("255/230" in note for note in logs[1]["notes"])  # MAVProxy's own frames: not the autopilot's
    assert out.count("average roll (whole log) ") == 2

    assert main(["replay", str(sim_log), "--from", f"{engaged + 5:.1f}", "--to", f"{engaged + 15:.1f}",
                 "--out", str(tmp_path / "replay")]) == 0
    with (tmp_path / "replay" / "replay.csv").open() as handle:
        rows = list(csv.DictReader(handle))
    assert len(rows) == pytest.approx(100, abs=2) and {r["would_command"] for r in rows} == {"1"}
    rolls = dict(_attitudes(sim_log))
    for row in rows[::10]:  # the state is the log's own attitude at the step's time (the log's clock)
        assert float(row["roll_rad"]) == pytest.approx(rolls[round(float(row["t_s"]) * 1000)], abs=1e-6)
    # what the boat did: RC 1600/1800 through Rover's skid mix and back: steering 0.19, throttle 0.73
    throttle = np.nanmedian([float(r["boat_throttle"]) for r in rows])
    steering = np.nanmedian([float(r["boat_steering"]) for r in rows])
    assert throttle == pytest.approx((THROTTLE - 1530) / 370, abs=0.06)
    assert steering == pytest.approx((STEERING - 1530) / 370, abs=0.06)
    assert {r["boat_throttle_pwm_us"] for r in rows} == {f"{THROTTLE}"}
    assert all(math.isfinite(float(r["cmd_steering"])) for r in rows)
