"""The companion's parts: one run-log schema and metrics function, output paths, mission tracking, wave source."""

from __future__ import annotations

import csv
import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from mavbridge.companion import Companion, CompanionConfig, build_nmpc, schedule, wave_step
from mavbridge.experiment import run_scenario
from mavbridge.link import mavlink
from mavbridge.mission_tracker import MissionTracker
from mavbridge.nmpc.controller import NmpcResult
from mavbridge.output_paths import MODE_GUIDED, MODE_MANUAL, AttitudeTarget, DryRun, RcOverride, make_output
from mavbridge.outputs import RcSetup
from mavbridge.preflight.rules import Context
from mavbridge.runlog import LOG_COLUMNS, STATE_COLUMNS, RunRecorder, run_metrics
from mavbridge.scenario import Scenario, scenario_from_mapping
from mavbridge.seasource import SCENARIO_TRUTH, ScenarioTruth, WaveEstimate
from mavbridge.state import StateEstimate
from vessel import NX_RIGID, STATE_NAMES, CalmWater, otter_parameters

CTX = Context(system_id=255, output="rc_override", period_s=0.1, acceptance_m=2.0)
TINY = {"name": "tiny", "sea": {"height_m": 1.0, "length_m": 30.0, "period_s": 5.0, "travel_dir_deg": -90.0},
        "start": {"heading_deg": 90.0, "surge_mps": 1.0}, "waypoint": {"north_m": 0.0, "east_m": 30.0},
        "t_max_s": 1.0, "controller": {"q": 5, "r": 500, "s": 2, "horizon": 5}}


def _result(tau: tuple[float, float], horizon: int = 6, success: bool = True) -> NmpcResult:
    states = np.zeros((horizon + 1, 12))
    states[:, 5] = 0.4  # heading, rad
    states[:, 6] = 1.5  # surge, m/s
    return NmpcResult(np.array(tau), states, np.zeros((horizon, 2)), 0.004, 3, "ok", success)


def test_the_schema_is_built_from_the_state_names_with_units() -> None:
    assert len(STATE_COLUMNS) == NX_RIGID
    assert STATE_COLUMNS[:6] == ("north_m", "east_m", "down_m", "roll_rad", "pitch_rad", "yaw_rad")
    assert all(c.endswith(("_m", "_rad", "_m_s", "_rad_s")) for c in STATE_COLUMNS)
    assert [c.split("_")[0] for c in STATE_COLUMNS[6:]] == list(STATE_NAMES[6:NX_RIGID])
    estimate = WaveEstimate(1.0, 5.0, 30.0, 0.0, 0.0)
    assert set(estimate.row()) <= set(LOG_COLUMNS)  # the wave source's columns are part of the one schema
    with pytest.raises(KeyError, match="no column 'north'"):
        RunRecorder(0.1).state(0.0, np.zeros(12), north=1.0)


def test_one_metrics_function_reads_the_experiment_csv_by_column_name(tmp_path: Path) -> None:
    """metrics.json of an experiment equals run_metrics over the rows read back from its CSV by name."""
    result = run_scenario(scenario_from_mapping(TINY, "test"), tmp_path / "run", plots=False)
    with (tmp_path / "run" / "timeseries.csv").open() as handle:
        rows = list(csv.DictReader(handle))
    assert tuple(rows[0]) == LOG_COLUMNS
    roll = np.array([float(r["roll_rad"]) for r in rows])
    assert result.metrics["avg_roll_deg"] == pytest.approx(math.degrees(np.mean(np.abs(roll))), rel=1e-7)
    assert result.metrics["steps"] == sum(r["solve_ms"] != "" for r in rows) == 10
    assert result.metrics["wave_source"] == SCENARIO_TRUTH and rows[0]["wave_height_m"] == "1"
    record = RunRecorder(0.1)
    for r in rows:
        record.state(float(r["t_s"]), [float(r[c]) for c in STATE_COLUMNS])
    assert run_metrics(record, None)["max_roll_deg"] == pytest.approx(result.metrics["max_roll_deg"], rel=1e-7)


def test_recorder_counts_failures_and_late_answers() -> None:
    record = RunRecorder(0.1)
    record.step(0.0, np.zeros(12), _result((10.0, 0.0), success=False))
    late = dataclasses.replace(_result((10.0, 0.0)), fallback="late: 120 ms", fallback_source="previous_plan",
                               wall_time_s=0.12)
    record.step(0.1, np.zeros(12), late)
    metrics = run_metrics(record, None)
    assert (metrics["failures"], metrics["late"], metrics["overruns"], metrics["steps"]) == (1, 1, 1, 2)
    assert record.rows[1]["fallback"] == "previous_plan" and record.rows[1]["fallback_reason"].startswith("late")


def test_dry_run_is_the_null_output_of_the_path_it_wraps() -> None:
    rc = RcOverride(otter_parameters(), CTX, print)
    rc.setup = RcSetup()  # what prepare() reads from the autopilot; ArduPilot's defaults here
    dry = DryRun(rc)
    result = _result((80.0, 20.0))
    assert dry.command(None, result, 1000) == rc.compute(result, 1000).columns  # link unused: nothing is sent
    assert not dry.sends and rc.sends and dry.required_mode == MODE_MANUAL
    assert rc.compute(result, 1000).columns["steering_pwm_us"] > 1500  # more left thrust: steer to starboard
    guided = make_output("attitude_target", True, otter_parameters(), CTX, 3, print)
    assert isinstance(guided, DryRun) and isinstance(guided.inner, AttitudeTarget)
    assert guided.required_mode == MODE_GUIDED
    columns = guided.command(None, result, 1000)
    assert columns == {"yaw_target_rad": pytest.approx(0.4), "thrust_frac": pytest.approx(0.75)}
    bad = _result((0.0, 0.0))
    bad.states[:, 5] = math.nan
    with pytest.raises(ValueError, match="non-finite"):
        guided.command(None, bad, 1000)


def test_mission_tracker_flies_waypoints_in_turn_and_notices_a_new_mission() -> None:
    tracker = MissionTracker(acceptance_m=2.0, waypoints=[(10.0, 0.0), (10.0, 10.0)])
    assert tracker.target(0.0, 0.0) == (10.0, 0.0)
    assert tracker.target(9.0, 0.5) == (10.0, 10.0)  # the first is reached: on to the second
    assert tracker.target(10.0, 8.5) is None  # the last is reached
    tracker.on_message(mavlink.MAVLink_mission_current_message(1, 2))
    assert not tracker.changed  # the first total seen is the mission we hold
    tracker.on_message(mavlink.MAVLink_mission_current_message(1, 3))
    assert tracker.changed
    tracker.changed = False
    tracker.on_message(mavlink.MAVLink_statustext_message(6, b"Flight plan received"))
    assert tracker.changed


def test_motion_samples_come_from_the_state_estimate() -> None:
    state = StateEstimate()
    state.set_home(-35.0, 149.0)
    state.on_message(mavlink.MAVLink_global_position_int_message(1000, -350000000 + 900, 1490000000, 0, 0,
                                                                 100, -50, 0, 0))
    state.on_message(mavlink.MAVLink_attitude_message(1050, 0.05, -0.02, 1.0, 0.1, 0.0, -0.2))
    sample = state.motion_sample()
    assert sample.t_s == pytest.approx(1.05)
    np.testing.assert_allclose(sample.attitude, [0.05, -0.02, 1.0])
    np.testing.assert_allclose(sample.rates, [0.1, 0.0, -0.2])
    assert sample.position_ned[0] == pytest.approx(10.0, abs=0.05)  # 900e-7 deg of latitude ≈ 10 m north
    np.testing.assert_allclose(sample.velocity_ned, [1.0, -0.5, 0.0])
    assert sample.accel_body is None


def test_the_wave_source_reaches_the_log_and_the_nmpc_reads_it_if_it_can() -> None:
    scenario = Scenario(name="balanced")
    truth = ScenarioTruth(scenario.sea.waves())
    nmpc = build_nmpc(dataclasses.replace(scenario, controller=scenario.controller.replace(horizon=5)), truth)
    assert nmpc.waves == scenario.sea.waves()  # the NMPC's sea is the one the wave source gave it
    columns = wave_step(truth, nmpc, 12.0)
    assert columns["wave_height_m"] == scenario.sea.waves().height_m and columns["wave_confidence"] == 1.0
    assert wave_step(ScenarioTruth(CalmWater()), nmpc, 12.0) == {}  # nothing to mitigate: no columns


def test_companion_metrics_need_no_log_writing(tmp_path: Path) -> None:
    """metrics() works on a fresh companion (nothing set only by writing the logs) and names the wave source."""
    base = Scenario(name="balanced")
    scenario = dataclasses.replace(base, controller=base.controller.replace(horizon=5))
    truth = ScenarioTruth(scenario.sea.waves())
    companion = Companion(CompanionConfig(), scenario, tmp_path, build_nmpc(scenario, truth), truth, dry_run=True,
                          log=lambda line: None)
    metrics = companion.metrics()
    assert metrics["wave_source"] == SCENARIO_TRUTH and metrics["phase"] == "WAITING"
    assert metrics["steps"] == 0 and metrics["avg_roll_deg"] is None and metrics["link"] == {}
    assert not (tmp_path / "metrics.json").exists()


def test_control_steps_keep_to_the_autopilot_clock() -> None:
    """One step per period of time_boot_ms; late samples count the periods missed; a reboot restarts it."""
    due, tick, missed = schedule(5000, None, 100)
    assert (due, tick, missed) == (True, 5100, 0)
    assert schedule(5050, tick, 100) == (False, 5100, 0)
    assert schedule(5120, tick, 100) == (True, 5200, 0)
    assert schedule(5430, 5200, 100) == (True, 5500, 2)  # 5200 and 5300 were missed, 5400 runs late
    assert schedule(300, 5500, 100) == (True, 400, 0)  # the autopilot rebooted: its clock starts again
