"""The companion flies on the estimated wave, never on the simulator's sea: real processes over UDP loopback.

`sim-vehicle` runs a sea that differs from the companion's scenario (another direction, period and
length); `mavbridge run` with its default ``--wave-source estimated`` must fly to the waypoint, and whatever it
estimated (companion.csv) must be the simulator's sea, not the scenario's. On a simulator with ideal
sensors and a hull that does not heave (the paper's plant) the estimator has only the slopes and the
Doppler shift, so a confident estimate is not guaranteed: every confident row must match the simulator's
sea. Once the simulator streams an IMU and heaves the hull (`SCALED_IMU` arrives), a confident estimate
that matches is required: the companion watches the drifting boat until autopilot time 80 s (``--start-at``)
as it would until a pilot engages. The run is in lockstep (each tick waits for the companion's command), so
what it flies does not depend on the machine's load: paced, a busy machine skipped ticks and the boat circled
the waypoint for half an hour of autopilot time in one run.
"""

from __future__ import annotations

import csv
import io
import json
import math
import subprocess
import sys
from contextlib import redirect_stdout
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from mavbridge.cli import main
from mavbridge.lab.scenario import Scenario
from mavbridge.link.connection import mavlink
from mavbridge.preflight.report import PASS, WARN
from sim_vehicle.harness import SimProcess
from tests.system.lockstep import assert_lockstep_run

HOME = "--home=-35.363261,149.165230,584,90"
ROOT = Path(__file__).resolve().parents[2]
# The simulator's sea: towards north (0°), 5 s, 25 m; the scenario's (the paper's): towards -90°, 6 s, 35 m.
# 1 m high: at 1.5 m (slope 11°) the paper's weights make even the truth-fed Balanced circle the waypoint for
# 266 s in-process (390 s on the estimate), so the run's length was luck; at 1 m it arrives in about 70 s.
SIM_SEA = {"height_m": 1.0, "length_m": 25.0, "period_s": 5.0, "travel_dir_deg": 0.0}
START_AT_S = 80.0  # 16 s wall at speedup 5 for the companion's startup (streams, mission, rates, cold solve)
SIM_LOCKSTEP = ["--lockstep", "--lockstep-timeout", "20", "--lockstep-start", f"{START_AT_S:g}"]
pytestmark = pytest.mark.slow


def _angle_deg(a: float, b: float) -> float:
    """|a - b| in degrees, wrapped to [0, 180]."""
    return abs(math.remainder(a - b, 360.0))


def _start_companion(port: int, out: Path, *extra: str) -> subprocess.Popen:
    """`mavbridge run` (default waves) to a waypoint 113 m away, listening on ``port`` (started before the
    simulator: its own start-up then does not eat into the wall time before the held lockstep start)."""
    cmd = [sys.executable, "-m", "mavbridge.cli", "run", "--connect", f"udpin:127.0.0.1:{port}", "--solver",
           "asrti", "--arm", "--set-mode", "--out", str(out), "--waypoint", "85,75", *extra]
    return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def _finish(companion: subprocess.Popen) -> tuple[int, str]:
    """(exit code, output) of the companion; it is stopped and the test fails if it runs past 420 s."""
    try:
        text, _ = companion.communicate(timeout=420)
    except subprocess.TimeoutExpired:
        companion.kill()
        text, _ = companion.communicate()
        raise AssertionError(f"mavbridge run did not finish within 420 s:\n{text[-3000:]}") from None
    return companion.returncode, text


def _rows(out: Path) -> list[dict[str, str]]:
    with (out / "companion.csv").open() as stream:
        return list(csv.DictReader(stream))


def test_the_companion_estimates_the_simulators_sea_not_the_scenarios(tmp_path: Path) -> None:
    scenario_sea = Scenario(name="balanced").sea.waves()
    assert abs(scenario_sea.period_s - SIM_SEA["period_s"]) > 0.5  # the two seas really differ
    sea = ",".join(f"{SIM_SEA[k]:g}" for k in ("height_m", "length_m", "period_s", "travel_dir_deg"))
    # the hull heaves with the sea (its IMU then carries the wave) and the phase is hidden, as at sea
    sim = SimProcess(tmp_path / "sim", speedup=5, waves=None, sea_phase="hidden",
                     extra=[HOME, "--wipe", "--sea", sea, "--heave", "surface", *SIM_LOCKSTEP], udp_outs=1)
    # the estimator watches the drifting boat until autopilot time 80 s, as a companion does from its
    # connection until the pilot engages: then it flies on a confident estimate of the simulator's sea
    companion = _start_companion(sim.udp_ports[0], tmp_path / "run", "--lockstep", "--start-at", f"{START_AT_S:g}",
                                 "--max-time", "400")
    try:
        with sim:
            code, text = _finish(companion)
            assert code == 0, text[-3000:]
            metrics = json.loads((tmp_path / "run" / "metrics.json").read_text())
            assert_lockstep_run(metrics, sim, START_AT_S)
    finally:
        if companion.poll() is None:
            companion.kill()
    assert metrics["phase"] == "ARRIVED" and metrics["wave_source"] == "estimated", text[-2000:]
    # the estimator watches the drifting boat from the first ATTITUDE: the companion says what it has seen of the
    # sea before it engages, and the first step flies with the roll term on
    lines = [line for line in text.splitlines() if "waves (estimated)" in line]
    watched = next((line for line in lines if "before engaging" in line), None)
    assert watched is not None and "the roll term acts from the first step" in watched, text[-2000:]
    assert "roll term on" in next(line for line in lines if "before engaging" not in line), text[-2000:]
    waves = metrics["waves"]
    assert waves["first_confident_at_s"] - waves["first_sample_at_s"] <= 15.0, waves  # issue 29: 15 s of motion
    rows = _rows(tmp_path / "run")
    for row in rows:  # never a NaN command
        assert all(math.isfinite(float(row[c])) for c in ("tau_x_n", "tau_n_nm", "steering_pwm_us", "throttle_pwm_us"))
    confident = [r for r in rows if r["wave_confidence"] and float(r["wave_confidence"]) >= 0.5]
    waves = metrics["waves"]
    assert waves["roll_term_fraction"] == pytest.approx(len(confident) / len(rows), abs=1e-3)
    for row in rows:
        if row["wave_period_s"]:
            assert all(math.isfinite(float(row[c])) for c in ("wave_period_s", "wave_length_m", "wave_dir_deg",
                                                              "wave_height_m", "wave_phase_rad"))
    for row in confident:  # whatever it was confident about is the simulator's sea (5 s), not the scenario's
        # (6 s, +20 %): confident periods were seen up to 10.4 % off in this heaving hull over MAVLink (issue 12)
        assert float(row["wave_period_s"]) == pytest.approx(SIM_SEA["period_s"], rel=0.15), row
        assert _angle_deg(float(row["wave_dir_deg"]), SIM_SEA["travel_dir_deg"]) < 20.0, row
    imu = metrics["rates_hz"].get("SCALED_IMU", 0.0) + metrics["rates_hz"].get("RAW_IMU", 0.0)
    print(f"\nsim sea {SIM_SEA}; IMU {imu} Hz; waves summary {waves}; confident steps {len(confident)}/{len(rows)}")
    if imu > 0:  # after watching 60 s with a heaving hull and an IMU, it starts on a confident estimate
        assert waves["time_to_confident_s"] is not None and confident, waves
    if imu > 0:  # the fastest IMU stream (SCALED_IMU at 20 Hz) reaches the estimator with nearly every
        # ATTITUDE, not the 1 Hz RAW_IMU that happens to arrive first (once a quarter of the samples: issue 12)
        assert waves["imu_sample_share"] > 0.8, waves  # (the samples before the rates are measured have none)
    if imu > 0:  # a heaving hull and an IMU: the estimate is the simulator's sea (period 5 s, towards 0°),
        # not the scenario's (6 s, towards -90°). Its confidence still flips on and off in a heaving hull
        # (issue 12), so the median of the second half's estimates is checked, confident or not.
        late = [r for r in rows[len(rows) // 2:] if r["wave_period_s"]]
        assert late, f"no estimate in the second half of the run: {waves}"
        period = float(np.median([float(r["wave_period_s"]) for r in late]))
        direction = float(np.median([math.remainder(float(r["wave_dir_deg"]), 360.0) for r in late]))
        assert period == pytest.approx(SIM_SEA["period_s"], rel=0.15), (period, waves)
        assert _angle_deg(direction, SIM_SEA["travel_dir_deg"]) < 20.0, (direction, waves)


def _streams(conn: Any, name: str) -> bool:
    """Ask the simulator directly (SET_MESSAGE_INTERVAL, 20 Hz) for ``name``; True if it is accepted and arrives."""
    conn.mav.command_long_send(1, 1, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0,
                               getattr(mavlink, f"MAVLINK_MSG_ID_{name}"), 50_000, 0, 0, 0, 0, 0)
    ack = conn.recv_match(type="COMMAND_ACK", blocking=True, timeout=10)
    return ack is not None and ack.result == mavlink.MAV_RESULT_ACCEPTED and \
        conn.recv_match(type=name, blocking=True, timeout=5) is not None


def test_check_reports_whether_the_imu_stream_arrives(tmp_path: Path) -> None:
    """`mavbridge check`: PASS with the rate when SCALED_IMU/RAW_IMU arrives after the request, else WARN."""
    with SimProcess(tmp_path / "sim", speedup=5, waves="paper", extra=[HOME, "--wipe"], udp_outs=1) as sim:
        probe = sim.connect()
        streamed = any(_streams(probe, name) for name in ("SCALED_IMU", "RAW_IMU"))
        out = io.StringIO()
        with redirect_stdout(out):
            main(["check", "--config", str(ROOT / "deploy" / "companion-sim.yaml"),
                  "--connect", f"udpin:127.0.0.1:{sim.udp_ports[0]}", "--timeout", "10", "--waypoint", "85,75",
                  "--solves", "0"])
    lines = [line for line in out.getvalue().splitlines() if "IMU stream after request" in line]
    assert len(lines) == 1, out.getvalue()
    if streamed:
        assert lines[0].startswith(PASS) and "Hz" in lines[0], lines[0]
    else:
        assert lines[0].startswith(WARN) and "none arrives" in lines[0] and "GPS height" in lines[0], lines[0]
