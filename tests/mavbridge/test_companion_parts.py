"""The companion's parts: one run-log schema and metrics function, output paths, mission tracking, wave source."""

from __future__ import annotations

import csv
import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from mavbridge.companion.flight import Companion, CompanionConfig, build_nmpc, schedule, wave_step
from mavbridge.companion.mission_tracker import MissionTracker
from mavbridge.companion.output_paths import MODE_GUIDED, MODE_MANUAL, AttitudeTarget, DryRun, RcOverride, make_output
from mavbridge.companion.outputs import RcSetup
from mavbridge.companion.start import choose_imu
from mavbridge.companion.state import StateEstimate
from mavbridge.companion.wave_gate import WaveGate, make_wave_source
from mavbridge.lab.experiment import run_scenario
from mavbridge.lab.runlog import LOG_COLUMNS, STATE_COLUMNS, RunRecorder, run_metrics
from mavbridge.lab.scenario import Scenario, scenario_from_mapping
from mavbridge.link.connection import mavlink
from mavbridge.nmpc.controller import NmpcResult
from mavbridge.preflight.rules import Context
from mavbridge.waves.kinematic import KinematicBoat, motion_samples, paper_sea
from mavbridge.waves.source import SCENARIO_TRUTH, MotionSample, ScenarioTruth, WaveEstimate
from tests.mavbridge.wave_sources import ToldSource
from vessel import NX_RIGID, STATE_NAMES, CalmWater, otter_parameters
from vessel.geo import latlon_from_ned

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
    guided = make_output("attitude_target", True, otter_parameters(), CTX, 3, print, "rate")
    assert isinstance(guided, DryRun) and isinstance(guided.inner, AttitudeTarget)
    guided.inner.wp_speed_mps = 2.0  # what prepare() reads (WP_SPEED); never assumed before
    assert guided.required_mode == MODE_GUIDED
    columns = guided.command(None, result, 1000)
    assert columns == {"yaw_target_rad": pytest.approx(0.4), "thrust_frac": pytest.approx(0.75),
                       "yaw_rate_target_rad_s": 0.0}  # the rate form: the plan's r (0 here)
    assert make_output("attitude_target", True, otter_parameters(), CTX, 3, print).inner.form == "tau"  # default
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
    assert schedule(5050, None, 100) == (False, 5100, 0)  # the grid is whole periods of the autopilot clock
    assert schedule(350, 5500, 100) == (False, 400, 0)  # also after a reboot (what sim-vehicle --lockstep holds at)


# ------------------------------------------------------------------ the IMU and the estimated wave, end to end
def test_imu_messages_become_body_specific_force_on_the_autopilot_clock() -> None:
    """SCALED_IMU (mG, FRD): level at rest reads z ≈ −1000 mG = −g; RAW_IMU is stamped by time_usec."""
    state = StateEstimate()
    state.set_home(-35.0, 149.0)
    state.on_message(mavlink.MAVLink_global_position_int_message(1000, -350000000, 1490000000, 0, 0, 0, 0, 0, 0))
    state.on_message(mavlink.MAVLink_attitude_message(1000, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))
    assert state.motion_sample().accel_body is None  # nothing streamed yet
    state.on_message(mavlink.MAVLink_scaled_imu_message(990, 12, -30, -1000, 0, 0, 0, 0, 0, 0))
    np.testing.assert_allclose(state.motion_sample().accel_body, np.array([12, -30, -1000]) * 9.80665e-3)
    assert state.imu_kind == "SCALED_IMU"
    state.on_message(mavlink.MAVLink_raw_imu_message(995_000, 0, 0, -500, 0, 0, 0, 0, 0, 0))
    assert state.imu_ms == 990  # the first kind that arrived is the one used
    state.on_message(mavlink.MAVLink_attitude_message(1070, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))
    assert state.motion_sample().accel_body is None  # 80 ms old: not handed on as if current
    other = StateEstimate()
    other.on_message(mavlink.MAVLink_raw_imu_message(2_500_000, 0, 0, 0, 0, 0, 0, 0, 0, 0))
    assert other.imu_ms is None and other.rejected == 1  # all zeros: no IMU behind it
    other.on_message(mavlink.MAVLink_raw_imu_message(2_500_000, 0, 0, -1000, 0, 0, 0, 0, 0, 0))
    assert other.imu_ms == 2500 and other.imu_kind == "RAW_IMU"


def test_the_fastest_imu_stream_is_used_not_the_first_to_arrive() -> None:
    """Rover's default RAW_IMU (1-2 Hz) often arrives before the SCALED_IMU the companion asked for at 20 Hz:
    once the rates are measured the state takes SCALED_IMU only, and forgets the slow stream's sample."""
    state = StateEstimate()
    state.set_home(*HOME_LL)
    state.on_message(mavlink.MAVLink_raw_imu_message(1_000_000, 0, 0, -1000, 0, 0, 0, 0, 0, 0))
    assert state.imu_kind == "RAW_IMU"
    state.use_imu("SCALED_IMU")
    assert state.imu_ms is None and state.accel_body is None  # the slow stream's sample is not kept
    state.on_message(mavlink.MAVLink_raw_imu_message(1_050_000, 0, 0, -900, 0, 0, 0, 0, 0, 0))
    assert state.imu_ms is None  # the slow stream is ignored now
    state.on_message(mavlink.MAVLink_scaled_imu_message(1050, 0, 0, -1010, 0, 0, 0, 0, 0, 0))
    state.on_message(mavlink.MAVLink_global_position_int_message(1050, -350000000, 1490000000, 0, 0, 0, 0, 0, 0))
    state.on_message(mavlink.MAVLink_attitude_message(1050, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))
    np.testing.assert_allclose(state.motion_sample().accel_body, np.array([0, 0, -1010]) * 9.80665e-3)
    state.use_imu(None)  # no IMU stream measured: the first kind that arrives again
    assert state.imu_kind is None and state.motion_sample().accel_body is None


def test_a_silent_imu_stream_gives_way_to_another_kind() -> None:
    """The pinned SCALED_IMU stops (not requested again after a reboot, a rate changed): after 1 s of autopilot
    time without it, the RAW_IMU that still arrives is taken rather than no IMU at all."""
    state = StateEstimate()
    state.set_home(*HOME_LL)
    state.on_message(mavlink.MAVLink_attitude_message(1000, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))
    state.use_imu("SCALED_IMU")
    state.on_message(mavlink.MAVLink_scaled_imu_message(1000, 0, 0, -1000, 0, 0, 0, 0, 0, 0))
    state.on_message(mavlink.MAVLink_attitude_message(1900, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))
    state.on_message(mavlink.MAVLink_raw_imu_message(1_900_000, 0, 0, -900, 0, 0, 0, 0, 0, 0))
    assert state.imu_kind == "SCALED_IMU" and state.imu_ms == 1000  # 0.9 s: still the stream in use
    state.on_message(mavlink.MAVLink_attitude_message(2100, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))
    state.on_message(mavlink.MAVLink_raw_imu_message(2_100_000, 0, 0, -950, 0, 0, 0, 0, 0, 0))
    assert state.imu_kind == "RAW_IMU" and state.imu_ms == 2100  # 1.1 s silent: the other kind is taken
    rebooted = StateEstimate()  # pinned before any IMU came, then nothing of that kind: the wait starts
    rebooted.on_message(mavlink.MAVLink_attitude_message(500, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))
    rebooted.use_imu("SCALED_IMU")
    rebooted.on_message(mavlink.MAVLink_raw_imu_message(600_000, 0, 0, -1000, 0, 0, 0, 0, 0, 0))
    assert rebooted.imu_ms is None
    rebooted.on_message(mavlink.MAVLink_attitude_message(1600, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))
    rebooted.on_message(mavlink.MAVLink_raw_imu_message(1_600_000, 0, 0, -1000, 0, 0, 0, 0, 0, 0))
    assert rebooted.imu_kind == "RAW_IMU" and rebooted.imu_ms == 1600


def test_the_imu_asked_for_stays_preferred_unless_another_streams_faster() -> None:
    """At start the companion asks for SCALED_IMU at 20 Hz: measured silent in the first two seconds, it stays the
    preferred kind (the 1 Hz RAW_IMU only meanwhile, taken back when SCALED_IMU streams); measured slower than
    another kind, the faster one is taken; nothing asked for (the RAW_SENS group): the fastest measured."""
    state = StateEstimate()
    state.on_message(mavlink.MAVLink_attitude_message(1000, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))
    state.use_imu("SCALED_IMU")
    said = choose_imu(state, "SCALED_IMU", {"ATTITUDE": 20.0, "RAW_IMU": 1.0})
    assert state.imu_preferred == "SCALED_IMU" and "SCALED_IMU asked for, not streaming yet" in said
    assert "RAW_IMU at 1 Hz meanwhile" in said
    said = choose_imu(state, "SCALED_IMU", {"SCALED_IMU": 20.0, "RAW_IMU": 1.0})
    assert state.imu_preferred == "SCALED_IMU" and said == "IMU: SCALED_IMU at 20 Hz to the wave estimator"
    said = choose_imu(state, "SCALED_IMU", {"SCALED_IMU": 5.0, "SCALED_IMU2": 20.0})
    assert state.imu_preferred == "SCALED_IMU2" and said == "IMU: SCALED_IMU2 at 20 Hz to the wave estimator"
    said = choose_imu(state, "RAW_SENS", {"RAW_IMU": 10.0})
    assert state.imu_preferred == "RAW_IMU" and said == "IMU: RAW_IMU at 10 Hz to the wave estimator"
    assert "GPS height" in choose_imu(StateEstimate(), "RAW_SENS", {})


HOME_LL = (-35.0, 149.0)
T0_MS = 123_450  # the autopilot's boot clock, unrelated to the sea's time origin


def _messages(sample: MotionSample, with_imu: bool) -> list[Any]:
    """What an ArduPilot Rover streams for one motion sample: ATTITUDE, positions, SCALED_IMU (mG)."""
    ms = T0_MS + round(sample.t_s * 1000)
    lat, lon = latlon_from_ned(*HOME_LL, float(sample.position_ned[0]), float(sample.position_ned[1]))
    v, pos = sample.velocity_ned, sample.position_ned
    out = [mavlink.MAVLink_attitude_message(ms, *map(float, sample.attitude), *map(float, sample.rates)),
           mavlink.MAVLink_global_position_int_message(ms, round(lat * 1e7), round(lon * 1e7), 0,
                                                       round(-pos[2] * 1000), *(round(c * 100) for c in v), 0),
           mavlink.MAVLink_local_position_ned_message(ms, *map(float, pos), *map(float, v))]
    if with_imu and sample.accel_body is not None:
        out.append(mavlink.MAVLink_scaled_imu_message(ms, *(round(f / 9.80665e-3) for f in sample.accel_body),
                                                      0, 0, 0, 0, 0, 0))
    return out


@dataclass
class Flight:
    """What the companion's wave path did over one synthetic stream."""

    gate: WaveGate
    state: StateEstimate
    lines: list[str]
    confident: list[tuple[float, bool]]  # (autopilot s, roll term on) per control step
    samples_seen: int

    def confident_between(self, t_from: float, t_to: float) -> list[bool]:
        return [on for t, on in self.confident if t_from <= t - T0_MS / 1000 < t_to]


@pytest.fixture(scope="module")
def nmpc() -> Any:
    """One real NMPC (rti, short horizon) for the wave-path tests."""
    base = Scenario(name="balanced")
    scenario = dataclasses.replace(base, controller=base.controller.replace(horizon=8, solver="rti"))
    return build_nmpc(scenario, ScenarioTruth(CalmWater()))


def _fly(nmpc: Any, seconds: float, heading: Callable[[float], float] = lambda t: math.pi / 2,
         speed: float = 1.5, heave: bool = True, with_imu: bool = True,
         edit: Callable[[float, MotionSample], MotionSample] | None = None) -> Flight:
    """The companion's wave path on a kinematic boat in the paper's sea, through real MAVLink messages:
    StateEstimate → WaveGate(WaveEstimator) every ATTITUDE (20 Hz) → set_wave + a real solve at 10 Hz.
    Every solve's input must be finite (asserted here)."""
    boat = KinematicBoat(paper_sea(1.234), speed, heading, heave=heave)
    state, lines = StateEstimate(), []
    state.set_home(*HOME_LL)
    gate = WaveGate(make_wave_source("estimated", None), lines.append)
    nmpc.set_wave(None)
    confident, seen = [], 0
    for i, sample in enumerate(motion_samples(boat, seconds, seed=4)):
        sample = edit(sample.t_s, sample) if edit else sample
        for msg in _messages(sample, with_imu):
            state.on_message(msg)
        if state.ready():
            seen += 1
            gate.observe(state.motion_sample())
        if i % 2 == 1 and state.ready():
            t = (state.attitude_ms or 0) / 1000.0
            gate.step(nmpc, t)
            x = state.vector()
            assert np.all(np.isfinite(x)), f"a non-finite state at t = {t}"
            result = nmpc.solve(x, t, (200.0, 200.0))
            assert np.all(np.isfinite(result.tau)), f"a non-finite input at t = {t}: {result.status}"
            # the roll term acts on a confident wave, or on the sea's statistics alone
            assert result.roll_term_active == bool(gate.confident or gate.statistics_only)
            confident.append((t, bool(gate.confident)))
    return Flight(gate, state, lines, confident, seen)


def test_estimated_waves_switch_the_roll_term_on_once_confident_and_say_so(nmpc: Any) -> None:
    flight = _fly(nmpc, 40.0)
    assert flight.lines[0].startswith("waves (estimated): no confident estimate yet: flying without the roll term")
    assert flight.confident_between(0.0, 3.0) == [False] * len(flight.confident_between(0.0, 3.0))
    assert any(flight.confident_between(30.0, 40.0)), flight.gate.summary([])
    assert any("confident: towards 270 deg" in line for line in flight.lines), flight.lines
    summary = flight.gate.summary([1.0] * flight.gate.steps)
    assert 0 < summary["roll_term_fraction"] < 1 and 0 < summary["time_to_confident_s"] <= 30.0
    assert summary["final"]["wave_period_s"] == pytest.approx(6.0, rel=0.05)
    assert summary["estimator_ms_median"] > 0 and summary["step_ms_median"] > 1.0  # the estimator is in the step


def _nan_attitude(t: float, s: MotionSample) -> MotionSample:
    return dataclasses.replace(s, attitude=np.full(3, math.nan)) if 32.0 <= t < 36.0 else s


def _frozen_attitude(t: float, s: MotionSample) -> MotionSample:
    if 32.0 <= t:
        return dataclasses.replace(s, attitude=np.array([0.02, -0.01, math.pi / 2]), rates=np.zeros(3))
    return s


@pytest.mark.parametrize("edit", [_nan_attitude, _frozen_attitude], ids=["nan-attitude", "frozen-attitude"])
def test_bad_attitude_degrades_to_no_roll_term_and_never_a_nan_input(nmpc: Any, edit: Callable) -> None:
    """Blind (NaN or frozen attitude from 32 s): within STALE_S no roll term, and no sea statistics either. The
    sea does not change while a sensor is out, but the wave is trusted again only once a fit on data from after
    the fault (NaN until 36 s) has confirmed it; a frozen stream never gives it back."""
    flight = _fly(nmpc, 44.0, edit=edit)
    assert any(flight.confident_between(20.0, 32.0)), "not confident before the fault"
    assert not any(flight.confident_between(32.9, 36.1)), "still flying on the wave during the fault"
    assert any("estimate no longer confident" in line for line in flight.lines), flight.lines
    if edit is _nan_attitude:
        assert flight.state.rejected >= 70  # every NaN ATTITUDE was dropped before the estimator saw it
        assert any(flight.confident_between(37.0, 44.0)), "the wave never came back after the fault"
    else:
        assert not any(flight.confident_between(32.9, 44.0)) and not flight.gate.statistics_only


def test_a_sharp_turn_keeps_the_earth_frame_wave(nmpc: Any) -> None:
    """A 90° turn at 30 s changes the encounter frequency, not the sea: the wave fitted in the earth frame stays
    confident through it and still points the right way after it (the roll term acts through a tack)."""
    flight = _fly(nmpc, 50.0, heading=lambda t: math.pi / 2 if t < 30.0 else 0.0)
    assert all(flight.confident_between(20.0, 50.0)), "the turn cost the estimate"
    last = flight.gate.last
    assert last is not None and abs(math.degrees(last.travel_dir_rad) + 90.0) < 5.0, last


def test_a_missing_imu_stream_uses_the_gps_height(nmpc: Any) -> None:
    flight = _fly(nmpc, 40.0, with_imu=False)
    assert flight.state.imu_kind is None and flight.state.motion_sample().accel_body is None
    last = flight.gate.last
    assert last is not None and last.extras.get("heave_source") == 2.0  # the GPS height
    assert all(math.isfinite(v) for v in last.row().values())


def test_a_boat_at_rest_without_heave_never_gets_a_roll_term(nmpc: Any) -> None:
    """No heave and no speed: no Doppler, no wavenumber, so no wave to plan on; inputs finite. The sea's
    statistics need neither: after their 30 s the expected-roll term acts on them alone."""
    flight = _fly(nmpc, 40.0, speed=0.0, heave=False)
    assert flight.confident and not any(on for _, on in flight.confident)
    summary = flight.gate.summary([])
    assert summary["roll_term_fraction"] == 0.0 and flight.gate.changes == 0
    assert 0.0 < summary["sea_statistics_fraction"] < 0.4 and flight.gate.statistics_only
    assert flight.samples_seen >= 790


def test_a_confident_estimate_the_wave_model_refuses_means_no_roll_term_not_a_crash(nmpc: Any) -> None:
    lines: list[str] = []
    steep = WaveEstimate(6.0, 3.0, 20.0, 0.0, 0.0, 0.9)  # H/λ = 0.3: a breaking wave
    gate = WaveGate(ToldSource(steep), lines.append)
    for t in (1.0, 1.1, 1.2):
        gate.step(nmpc, t)
    assert not nmpc.roll_term_active and gate.roll_steps == 0
    assert sum("outside the wave model" in line for line in lines) == 1 and "height_m" in lines[0]
    gate.source = ToldSource(WaveEstimate(1.75, 6.0, 35.0, -math.pi / 2, 0.3, 0.9))
    gate.step(nmpc, 1.3)
    assert nmpc.roll_term_active and gate.changes == 1 and "roll term on" in lines[-1]
