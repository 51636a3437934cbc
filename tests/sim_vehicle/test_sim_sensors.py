"""Honest sensors: ATTITUDE noise against the true state, ideal sensors exact, GPS rate and lag from timestamps.

The truth is the simulator's own state.csv (every physics step); the configured values are read from
the simulator's parameter table over MAVLink, so the tests follow the defaults rather than repeat them.
"""

from __future__ import annotations

import csv
import math
import time
from pathlib import Path
from typing import Any

import numpy as np

from sim_vehicle.harness import SimProcess
from tests.rover import SET_MESSAGE_INTERVAL
from tests.waits import command, wait_for
from vessel.geo import Home

GPS_RAW_INT, ATTITUDE = 24, 30


def _param(conn: Any, name: str) -> float:
    """A parameter's value, read over MAVLink."""
    conn.mav.param_request_read_send(1, 1, name.encode(), -1)
    return float(wait_for(conn, "PARAM_VALUE", 5, lambda m: m.param_id == name).param_value)


def _truth(sim: SimProcess) -> dict[int, dict[str, str]]:
    """The true-state rows by simulated time in ms."""
    with (sim.log_dir / "state.csv").open() as f:
        return {round(float(r["t_s"]) * 1000): r for r in csv.DictReader(f)}


def _attitudes(sim: SimProcess, seconds: float) -> tuple[list[Any], Any]:
    """ATTITUDE at 10 Hz over ``seconds`` of simulated time, and the connection."""
    conn = sim.connect()
    assert command(conn, SET_MESSAGE_INTERVAL, ATTITUDE, 100000) == 0
    first = wait_for(conn, "ATTITUDE", 10)
    msgs = [first]
    deadline = time.monotonic() + 60
    while msgs[-1].time_boot_ms - first.time_boot_ms < seconds * 1000:
        if time.monotonic() > deadline:
            raise TimeoutError(f"{seconds} simulated s of ATTITUDE did not arrive within 60 s")
        msgs.append(wait_for(conn, "ATTITUDE", 10))
    return msgs, conn


def _roll_errors(sim: SimProcess, msgs: list[Any]) -> np.ndarray:
    """ATTITUDE roll minus the true roll at the same simulated time (rad)."""
    truth = _truth(sim)
    return np.array([m.roll - float(truth[m.time_boot_ms]["roll_rad"]) for m in msgs])


def test_attitude_noise_matches_the_configured_value(tmp_path: Path) -> None:
    """Defaults, calm water, at rest, 60 s: std(ATTITUDE roll − true roll) within 20 % of SIM_AHRS_NOISE."""
    with SimProcess(tmp_path, speedup=20, sensors="realistic", sea_phase="hidden") as sim:
        msgs, conn = _attitudes(sim, 60.0)
        configured = math.radians(_param(conn, "SIM_AHRS_NOISE"))
    assert configured > 0
    errors = _roll_errors(sim, msgs)
    assert len(errors) >= 550
    print(f"ATTITUDE roll - true roll: std {np.degrees(np.std(errors)):.4f} deg over {len(errors)} samples "
          f"(SIM_AHRS_NOISE {np.degrees(configured):g} deg)")
    assert abs(np.std(errors) / configured - 1.0) < 0.2, (np.std(errors), configured)


def test_ideal_sensors_report_the_true_state(tmp_path: Path) -> None:
    """--ideal-sensors: ATTITUDE roll equals the true roll (to float32) at every sample, even in waves."""
    with SimProcess(tmp_path, speedup=20, waves="paper", sensors="ideal") as sim:
        msgs, _ = _attitudes(sim, 5.0)
    errors = _roll_errors(sim, msgs)
    assert max(abs(m.roll) for m in msgs) > 0.01, "the waves should roll the boat"
    print(f"--ideal-sensors: max |ATTITUDE roll - true roll| {np.max(np.abs(errors)):.2e} rad")
    assert np.max(np.abs(errors)) < 1e-6


def test_gps_rate_and_lag(tmp_path: Path) -> None:
    """GPS_RAW_INT: new fixes every 1/SIM_GPS1_HZ s; each shows the true position SIM_GPS1_LAG_MS earlier.

    The boat drifts North in a 2 m/s current, position noise is off (SIM_GPS1_HNOISE 0) so the lag
    can be read from the position itself: the time at which the true track passed the fix.
    """
    parm = tmp_path / "quiet_gps.parm"
    parm.write_text("SIM_GPS1_HNOISE 0\nSIM_GPS1_VNOISE 0\nSIM_GPS1_VERR 0\n")
    with SimProcess(tmp_path / "sim", speedup=10, sensors="realistic", sea_phase="hidden",
                    extra=["--current", "2,0", "--params", str(parm)]) as sim:
        conn = sim.connect()
        rate_hz, lag_s = _param(conn, "SIM_GPS1_HZ"), _param(conn, "SIM_GPS1_LAG_MS") / 1000.0
        assert command(conn, SET_MESSAGE_INTERVAL, GPS_RAW_INT, 20000) == 0  # 50 Hz: every fix is seen
        wait_for(conn, "GPS_RAW_INT", 10, lambda m: m.time_usec > 5_000_000)  # drifting steadily by now
        fixes: dict[int, Any] = {}
        deadline = time.monotonic() + 30
        while len(fixes) < 30:
            if time.monotonic() > deadline:
                raise TimeoutError("30 GPS fixes did not arrive within 30 s")
            msg = wait_for(conn, "GPS_RAW_INT", 10)
            fixes.setdefault(msg.time_usec, msg)
    times = np.array(sorted(fixes)) / 1e6
    assert np.allclose(np.diff(times), 1.0 / rate_hz, atol=0.011), np.diff(times)
    truth = _truth(sim)
    t_true = np.array(sorted(truth)) / 1000.0
    north_true = np.array([float(truth[k]["north_m"]) for k in sorted(truth)])
    assert np.all(np.diff(north_true[t_true > 4.0]) > 0), "the boat is not drifting North"
    home = Home()
    lags = []
    for t_fix in times:
        north_fix, _ = home.to_ned(fixes[round(t_fix * 1e6)].lat / 1e7, fixes[round(t_fix * 1e6)].lon / 1e7)
        keep = t_true > 4.0
        lags.append(t_fix - float(np.interp(north_fix, north_true[keep], t_true[keep])))
    assert abs(np.mean(lags) - lag_s) < 0.2 * lag_s, (np.mean(lags), lag_s)
    print(f"GPS: fix interval {np.mean(np.diff(times)):.4f} s (configured {1 / rate_hz:g}), "
          f"lag {np.mean(lags) * 1000:.1f} ms (configured {lag_s * 1000:g})")


def _raw_imu_z(sim: SimProcess, seconds: float, after_s: float = 5.0) -> np.ndarray:
    """RAW_IMU zacc (mG) at 20 Hz over ``seconds`` of simulated time from ``after_s`` of simulated time on
    (the hull's start transient is over; on a loaded machine the test would otherwise see more of it)."""
    conn = sim.connect()
    assert command(conn, SET_MESSAGE_INTERVAL, 27, 50000) == 0
    first = wait_for(conn, "RAW_IMU", 60, lambda m: m.time_usec >= after_s * 1e6)
    values = [first.zacc]
    deadline = time.monotonic() + 60
    while True:
        msg = wait_for(conn, "RAW_IMU", 10)
        values.append(msg.zacc)
        if msg.time_usec - first.time_usec > seconds * 1e6:
            return np.array(values, float)
        if time.monotonic() > deadline:
            raise TimeoutError(f"{seconds} simulated s of RAW_IMU did not arrive within 60 s")


def test_raw_imu_carries_gravity_at_rest_and_heave_in_waves(tmp_path: Path) -> None:
    """RAW_IMU: about −1000 mG at rest in calm water; in the paper's waves with the default (surface)
    heave, the vertical specific force swings by about (H/2)·ω² ≈ 0.96 m/s² ≈ 98 mG."""
    with SimProcess(tmp_path / "calm", speedup=20, sensors="realistic", sea_phase="hidden") as sim:
        calm = _raw_imu_z(sim, 10.0)
    with SimProcess(tmp_path / "waves", speedup=20, waves="paper", sensors="realistic", sea_phase="hidden") as sim:
        wavy = _raw_imu_z(sim, 24.0)
    with SimProcess(tmp_path / "paper", speedup=20, waves="paper", sensors="realistic", sea_phase="hidden",
                    extra=["--heave", "paper"]) as sim:
        paper = _raw_imu_z(sim, 24.0)
    assert abs(np.mean(calm) + 1000.0 * 9.81 / 9.80665) < 10, np.mean(calm)
    assert np.std(calm) < 15
    swing = (np.percentile(wavy, 95) - np.percentile(wavy, 5)) / 2
    assert 0.8 * 97.8 < swing < 1.2 * 97.8, swing  # (1.75/2)·(2π/6)² m/s² = 97.8 mG
    paper_swing = (np.percentile(paper, 95) - np.percentile(paper, 5)) / 2
    assert paper_swing < 0.4 * swing, (paper_swing, swing)  # the paper's hull does not rise with the sea
