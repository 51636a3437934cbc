"""The wave estimator against a known sea: kinematic truth, the real plant, bad input, other headings.

Every run hides the sea's phase and starts the autopilot clock at a random boot time, so nothing but
the motion can tell the estimator where the crests are. Sensors are the defaults of vessel.sensors.
"""

from __future__ import annotations

import cmath
import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass

import numpy as np
import pytest

from mavbridge.waves import EstimatorSettings, WaveEstimator
from mavbridge.waves.calibration import hull_response, record_plant, settings_for
from mavbridge.waves.kinematic import KinematicBoat, estimate_errors, motion_samples, paper_sea, to_motion_sample
from mavbridge.waves.source import MotionSample, WaveEstimate
from vessel import Plant, otter_parameters
from vessel.config import ConfigError
from vessel.imu import ImuModel
from vessel.sensors import SensorModel, SensorParams

HORIZON_S = 4.0  # the NMPC's horizon end (P = 40 at T = 0.1 s)
REST = np.array([0.0, 0.0, -9.81])  # specific force at rest, level


@dataclass
class Run:
    """One estimator run: the estimate at every control step (10 Hz) and the sea it should find."""

    estimator: WaveEstimator
    sea: object
    t0: float
    steps: list[tuple[float, WaveEstimate | None, MotionSample]]

    def first_confident(self) -> float | None:
        """Seconds after the start until estimate() first answered."""
        return next((t - self.t0 for t, est, _ in self.steps if est is not None), None)

    def errors_at(self, index: int, speed: float, heading: Callable[[float], float]):
        """Errors of the step's estimate, the phase checked at the boat's position HORIZON_S ahead."""
        t, est, s = self.steps[index]
        assert est is not None, f"no confident estimate at {t - self.t0:.1f} s"
        psi = heading(t - self.t0)
        north = s.position_ned[0] + speed * HORIZON_S * math.cos(psi)
        east = s.position_ned[1] + speed * HORIZON_S * math.sin(psi)
        return estimate_errors(est, self.sea, t + HORIZON_S, north, east, self.t0)


def _constant(value: float) -> Callable[[float], float]:
    return lambda t: value


def run_kinematic(heading_deg: float | Callable[[float], float], speed: float = 1.5, seconds: float = 30.0,
                  seed: int = 1, heave: bool = True, with_imu: bool = True,
                  settings: EstimatorSettings | None = None,
                  edit: Callable[[Iterable[MotionSample]], Iterable[MotionSample]] | None = None) -> Run:
    """The paper's sea with a hidden phase, a point riding it, the default sensors, 20 Hz in, 10 Hz out."""
    rng = np.random.default_rng(100 + seed)
    sea = paper_sea(float(rng.uniform(-math.pi, math.pi)))
    t0 = float(rng.uniform(50.0, 5000.0))  # autopilot boot clock, unrelated to the sea's time origin
    heading = heading_deg if callable(heading_deg) else _constant(math.radians(heading_deg))
    boat = KinematicBoat(sea, speed, heading, heave=heave)
    est = WaveEstimator(settings)
    stream = motion_samples(boat, seconds, seed=seed, t0=t0, with_imu=with_imu)
    steps = []
    for i, sample in enumerate(edit(stream) if edit else stream):
        est.observe(sample)
        if i % 2 == 1:
            steps.append((sample.t_s, est.estimate(sample.t_s), sample))
    return Run(est, sea, t0, steps)


def _assert_finite(est: WaveEstimate | None) -> None:
    if est is not None:
        values = [est.height_m, est.period_s, est.length_m, est.travel_dir_rad, est.phase_rad, est.confidence]
        assert all(math.isfinite(v) for v in values), est


# ---------------------------------------------------------------- (a) the paper's case, kinematic truth
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_paper_sea_heading_east_confident_and_accurate_within_30_s(seed: int) -> None:
    run = run_kinematic(90.0, seed=seed)
    first = run.first_confident()
    assert first is not None and first <= 30.0, f"not confident within 30 s (first: {first})"
    heading = lambda t: math.pi / 2  # noqa: E731
    first_index = next(i for i, (_, est, _) in enumerate(run.steps) if est is not None)
    for index in (first_index, len(run.steps) - 1):
        err = run.errors_at(index, 1.5, heading)
        assert err.within(), f"at {run.steps[index][0] - run.t0:.1f} s: {err}"


# ---------------------------------------------------------------- (d) every heading relative to the waves
# Heading 90° meets the paper's waves (travelling West) head on; 270° runs with them. In following seas
# the encounter period is long (8 s at 1.5 m/s against 4.8 s head on), so 30 s hold fewer than four
# encounters and the estimator is not always confident yet: those headings get 60 s (a known limit).
FOLLOWING_SEAS = {240, 270, 300}


@pytest.mark.parametrize("heading_deg", range(0, 360, 30))
def test_other_headings_within_bounds(heading_deg: int) -> None:
    budget = 60.0 if heading_deg in FOLLOWING_SEAS else 30.0
    run = run_kinematic(float(heading_deg), seed=4, seconds=budget)
    assert run.first_confident() is not None, f"heading {heading_deg}°: never confident within {budget:.0f} s"
    err = run.errors_at(len(run.steps) - 1, 1.5, lambda t: math.radians(heading_deg))
    assert err.within(), f"heading {heading_deg}°: {err}"


# ---------------------------------------------------------------- (c) bad input
def _replace_attitude(start: float, stop: float, value: Callable[[MotionSample], np.ndarray]):
    def edit(stream: Iterable[MotionSample]) -> Iterable[MotionSample]:
        t_first = None
        for s in stream:
            t_first = s.t_s if t_first is None else t_first
            if start <= s.t_s - t_first < stop:
                s = MotionSample(s.t_s, value(s), s.rates, s.position_ned, s.velocity_ned, s.accel_body)
            yield s
    return edit


def test_nan_attitude_gives_no_estimate_then_recovers() -> None:
    nan = _replace_attitude(30.0, 35.0, lambda s: np.full(3, np.nan))
    run = run_kinematic(90.0, seconds=70.0, edit=nan)
    by_time = [(t - run.t0, est) for t, est, _ in run.steps]
    assert any(est is not None for t, est in by_time if t < 30.0), "never confident before the dropout"
    assert all(est is None for t, est in by_time if 30.6 <= t < 35.0), "confident on NaN attitude"
    for _, est in by_time:
        _assert_finite(est)
    assert by_time[-1][1] is not None, "did not recover 35 s after the dropout"


def test_frozen_attitude_gives_no_estimate() -> None:
    frozen: dict[str, np.ndarray] = {}

    def value(s: MotionSample) -> np.ndarray:
        return frozen.setdefault("att", s.attitude.copy())

    run = run_kinematic(90.0, seconds=45.0, edit=_replace_attitude(30.0, 45.0, value))
    late = [est for t, est, _ in run.steps if t - run.t0 >= 31.0]
    assert late and all(est is None for est in late), "confident on a frozen attitude stream"


def test_missing_imu_stream_falls_back_to_gps_height() -> None:
    settings = EstimatorSettings(position_lag_s=0.2)  # the default sensors: 0.1 s lag + 5 Hz hold
    run = run_kinematic(90.0, seconds=45.0, with_imu=False, settings=settings)
    assert run.first_confident() is not None, "no estimate from GPS height alone"
    final = run.steps[-1][1]
    assert final is not None and final.extras["heave_source"] == 2.0
    err = run.errors_at(len(run.steps) - 1, 1.5, lambda t: math.pi / 2)
    assert err.within(), err


def test_imu_dropping_out_mid_run_keeps_estimates_finite() -> None:
    def edit(stream: Iterable[MotionSample]) -> Iterable[MotionSample]:
        for i, s in enumerate(stream):
            if 400 <= i < 800:
                s = MotionSample(s.t_s, s.attitude, s.rates, s.position_ned, s.velocity_ned, None)
            yield s

    run = run_kinematic(90.0, seconds=60.0, edit=edit)
    for _, est, _ in run.steps:
        _assert_finite(est)
    assert run.steps[-1][1] is not None


def test_sharp_turn_drops_confidence_and_it_recovers() -> None:
    def heading(t: float) -> float:  # East, then a 90° turn to North in 3 s at t = 30 s
        return math.pi / 2 * (1 - min(1.0, max(0.0, (t - 30.0) / 3.0)))

    run = run_kinematic(heading, seconds=75.0)
    by_time = [(t - run.t0, est) for t, est, _ in run.steps]
    assert any(est is not None for t, est in by_time if t < 30.0)
    assert all(est is None for t, est in by_time if 31.0 <= t < 36.0), "stayed confident through the turn"
    recovered = next((t for t, est in by_time if t > 33.0 and est is not None), None)
    assert recovered is not None and recovered < 33.0 + 30.0, f"no confident estimate after the turn: {recovered}"
    err = run.errors_at(len(run.steps) - 1, 1.5, heading)
    assert err.within(), err


def test_heading_jump_drops_confidence() -> None:
    def jump(s: MotionSample) -> np.ndarray:
        att = s.attitude.copy()
        att[2] = math.remainder(att[2] + math.pi / 2, 2 * math.pi)
        return att

    run = run_kinematic(90.0, seconds=40.0, edit=_replace_attitude(30.0, 40.0, jump))
    just_after = [est for t, est, _ in run.steps if 30.1 <= t - run.t0 < 34.0]
    assert just_after and all(est is None for est in just_after)


def test_boat_at_rest_with_heave_sees_the_true_period() -> None:
    run = run_kinematic(90.0, speed=0.0, seconds=40.0)
    final = run.steps[-1][1]
    assert final is not None
    err = run.errors_at(len(run.steps) - 1, 0.0, lambda t: math.pi / 2)
    assert err.within(), err


def test_boat_at_rest_without_heave_is_not_confident() -> None:
    run = run_kinematic(90.0, speed=0.0, seconds=60.0, heave=False)
    assert all(est is None for _, est, _ in run.steps), "a hull without heave, at rest, cannot know k"
    latest = run.estimator.latest(run.steps[-1][0])
    assert latest is None or latest.confidence < 0.5
    seen = run.estimator.diagnostics()  # what it does see: the wave's axis and frequency
    assert min(abs(seen["axis_deg"] - 90), abs(seen["axis_deg"] + 90)) < 10, seen
    assert seen["encounter_freq_rad_s"] == pytest.approx(run.sea.frequency, rel=0.03)


def test_garbage_samples_never_raise_or_give_nan() -> None:
    est = WaveEstimator()
    rng = np.random.default_rng(0)
    t = 100.0
    for i in range(2000):
        t += float(rng.choice([0.05, 0.05, 0.05, -0.5, 0.0, 3.0]))
        bad = rng.integers(0, 6)
        att = rng.normal(0, 0.1, 3) if bad != 0 else np.array([np.nan, 0.0, np.inf])
        pos = rng.normal(0, 1, 3) if bad != 1 else np.array([np.nan] * 3)
        vel = rng.normal(0, 1, 3) if bad != 2 else np.array([1e308, -np.inf, 0.0])
        acc = None if bad == 3 else np.array([0.0, np.nan]) if bad == 4 else rng.normal(0, 1, 3) + REST
        sample = MotionSample(t if bad != 5 else float("nan"), att, rng.normal(0, 0.1, 3), pos, vel, acc)
        est.observe(sample)
        if i % 2:
            _assert_finite(est.latest(t))
            _assert_finite(est.estimate(t))


# ---------------------------------------------------------------- (b) the real plant (paper's hull: no heave)
def test_plant_heading_east_tracks_encounter_frequency_and_wave_axis() -> None:
    """vessel.Plant in the paper's sea, equal shaft speeds for ≈ 1.5 m/s East, the default sensors.

    The paper's hull does not heave with the waves, so only the slopes are seen: the estimator must
    find the encounter frequency and the wave's axis, and must not claim a wavelength on a steady course.
    """
    sea = paper_sea(0.8)
    x0 = np.zeros(14)
    x0[5] = math.pi / 2
    plant = Plant(otter_parameters(), sea, dt=0.01, x0=x0)
    imu = ImuModel.for_plant(plant)
    sensors = SensorModel(SensorParams(), np.random.default_rng(4))
    est = WaveEstimator()
    true_phase, answers = [], []
    for k in range(int(60.0 / 0.05)):
        x, t = plant.state, 700.0 + plant.time  # the autopilot booted 700 s before the run
        est.observe(to_motion_sample(sensors.sample(t, x[0:6], x[6:12], imu.measure(x, plant.time)[0])))
        true_phase.append(sea.frequency * plant.time - sea.wavenumber * (x[0] * math.cos(sea.travel_dir_rad)
                                                                          + x[1] * math.sin(sea.travel_dir_rad)))
        if k % 2:
            answers.append(est.estimate(t))
        plant.advance((70.0, 70.0), 5)
    mean_speed = plant.state[1] / plant.time
    assert 1.2 < mean_speed < 1.8, f"mean eastward speed {mean_speed:.2f} m/s"
    omega_e_true = (true_phase[-1] - true_phase[-401]) / 20.0  # mean encounter frequency, last 20 s
    seen = est.diagnostics()
    assert seen["encounter_freq_rad_s"] == pytest.approx(omega_e_true, rel=0.03), (seen, omega_e_true)
    axis_error = math.remainder(math.radians(seen["axis_deg"]) - sea.travel_dir_rad, math.pi)
    assert abs(math.degrees(axis_error)) < 10, seen
    assert seen["lock"] > 0.5, seen
    assert all(a is None for a in answers), "claimed a wavelength without heave or a speed change"


def test_bad_settings_name_the_field() -> None:
    with pytest.raises(ConfigError, match="fit_tau_s"):
        EstimatorSettings(fit_tau_s=0.0)
    with pytest.raises(ConfigError, match="roll_sign"):
        EstimatorSettings(roll_sign=0.5)
    with pytest.raises(ConfigError, match="tracker"):
        EstimatorSettings(tracker="fft")


# ---------------------------------------------------------------- the paper's hull: no heave, only slopes
def test_without_heave_a_steady_course_gives_no_wavelength() -> None:
    run = run_kinematic(90.0, seconds=60.0, heave=False)
    assert all(est is None for _, est, _ in run.steps), "k cannot be known without heave or a speed change"


def test_without_heave_speed_changes_reveal_k_and_direction_by_doppler() -> None:
    def speed(t: float) -> float:  # 1.5 m/s and 0.5 m/s, 30 s each (shorter legs give too few steady points)
        return 1.5 if (t // 30.0) % 2 == 0 else 0.5

    rng = np.random.default_rng(7)
    sea = paper_sea(float(rng.uniform(-math.pi, math.pi)))
    t0 = 321.0
    boat = KinematicBoat(sea, speed, _constant(math.pi / 2), heave=False)
    est = WaveEstimator()
    confident = []
    for i, s in enumerate(motion_samples(boat, 150.0, seed=7, t0=t0)):
        est.observe(s)
        if i % 2 == 1 and (e := est.estimate(s.t_s)) is not None:
            ahead = s.position_ned[1] + speed(s.t_s - t0) * HORIZON_S
            confident.append((s.t_s - t0, e, estimate_errors(e, sea, s.t_s + HORIZON_S, s.position_ned[0], ahead,
                                                             t0)))
    assert confident, "the Doppler line never became confident"
    assert confident[0][0] > 30.0, "confident before the speed ever changed"
    assert all(e.extras["mode"] == 2.0 for _, e, _ in confident)
    bad = [(t, err) for t, _, err in confident if not err.within()]
    assert not bad, f"confident but wrong: {bad[:3]}"


# ---------------------------------------------------------------- calibration of the hull's response
def test_hull_response_recovers_a_known_gain_and_lag() -> None:
    t = np.arange(0.0, 10 * 2 * math.pi / 1.3, 0.05)
    phase = 1.3 * t + 0.4
    along, across = 0.15 * np.cos(phase + 0.2), 0.05 * np.cos(phase - 1.0)
    pitch, roll = 1.1 * 0.15 * np.cos(phase + 0.2 - 0.3), 0.9 * 0.05 * np.cos(phase - 1.0 + 0.1)
    h_roll, h_pitch = hull_response(roll, pitch, across, along, phase)
    assert h_pitch == pytest.approx(cmath.rect(1.1, -0.3), abs=0.01)
    assert h_roll == pytest.approx(cmath.rect(0.9, 0.1), abs=0.01)
    s = settings_for(h_roll, h_pitch)
    assert s.pitch_gain == pytest.approx(1.1, abs=0.01) and s.pitch_phase_deg == pytest.approx(-17.2, abs=0.6)


def test_plant_pitch_lags_the_slope_and_calibration_measures_it() -> None:
    sea = paper_sea(0.8)
    x0 = np.zeros(14)
    x0[5] = math.radians(45)
    plant = Plant(otter_parameters(), sea, dt=0.01, x0=x0)
    h_roll, h_pitch = hull_response(*record_plant(plant, sea, (70.0, 70.0), 80.0))
    assert h_roll is not None and h_pitch is not None
    assert 0.8 < abs(h_pitch) < 1.3 and -40 < math.degrees(cmath.phase(h_pitch)) < -5, h_pitch
    assert 0.8 < abs(h_roll) < 1.3 and abs(math.degrees(cmath.phase(h_roll))) < 10, h_roll
