"""The window estimator (the companion's default): fast, true at its first confident answer, quiet without a sea.

Issue 29 asks for a confident estimate within 15 s of valid motion, and at that first answer period ±3 %,
direction ±10°, wavelength ±10 %, height ±15 %, on the paper's sea and on other regular seas from other
directions. Here: a kinematic point riding the sea (exact following, default sensor noise and lags) and the
realistic in-process plant (the hull heaving with the sea, sensors at 20 Hz), every sea's phase hidden and the
autopilot clock started at a random boot time.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from mavbridge.lab.sensed_plant import SensedPlant
from mavbridge.waves import EstimatorSettings, WindowEstimator, make_estimator
from mavbridge.waves.inloop import calibrated_settings, estimate_metrics, sensor_model
from mavbridge.waves.kinematic import KinematicBoat, estimate_errors, motion_samples
from mavbridge.waves.window_buffer import _last_in_blocks
from mavbridge.waves.window_fit import (
    _apply,
    _stack,
    refine,
    refine_stages,
    run_stages,
    with_encounter_smoothing,
)
from mavbridge.waves.window_model import HullResponse, WaveParams, Window, channel_models
from vessel import CalmWater, RegularWaves, otter_parameters
from vessel.dynamics import OceanCurrent

# (height m, length m, period s, travel direction deg): the paper's, and three others (issue 29's examples)
SEAS = {"paper": (1.75, 35.0, 6.0, -90.0), "short": (1.0, 25.0, 4.5, 30.0), "medium": (1.5, 30.0, 5.5, 150.0),
        "long": (2.0, 45.0, 7.0, -160.0)}
BOUNDS = {"period_pct": 3.0, "direction_deg": 10.0, "length_pct": 10.0, "height_pct": 15.0}


def _sea(name: str, seed: int) -> RegularWaves:
    height, length, period, direction = SEAS[name]
    phase = float(np.random.default_rng(seed).uniform(-math.pi, math.pi))
    return RegularWaves(height, length, period, math.radians(direction), phase_rad=phase)


def _first_confident_kinematic(sea: RegularWaves, speed: float, heading_deg: float, seed: int,
                               seconds: float = 25.0) -> tuple[float | None, object | None]:
    """(seconds to the first confident estimate, its errors) for a point riding ``sea``."""
    t0 = 500.0 + 100 * seed
    psi = math.radians(heading_deg)
    boat = KinematicBoat(sea, speed, lambda t: psi)
    est = WindowEstimator()
    for sample in motion_samples(boat, seconds, seed=seed, t0=t0):
        est.observe(sample)
        answer = est.estimate(sample.t_s)
        if answer is not None:
            north, east = sample.position_ned[0:2]
            return sample.t_s - t0, estimate_errors(answer, sea, sample.t_s, north, east, t0)
    return None, None


@pytest.mark.parametrize("sea_name", list(SEAS))
@pytest.mark.parametrize(("speed", "heading_deg"), [(0.0, 0.0), (1.5, 45.0)], ids=["drifting", "under-way"])
def test_kinematic_first_confident_estimate_is_fast_and_true(sea_name: str, speed: float,
                                                             heading_deg: float) -> None:
    for seed in (1, 2):
        first, errors = _first_confident_kinematic(_sea(sea_name, seed), speed, heading_deg, seed)
        assert first is not None and first <= 15.0, f"seed {seed}: first confident at {first}"
        for name, bound in BOUNDS.items():
            assert abs(getattr(errors, name)) <= bound, f"seed {seed}: {name} {getattr(errors, name):+.1f}"


def _plant_run(sea_name: str, seed: int, surge_n: float, heading_deg: float, *, phase_seed: object = None,
               hold_heading: bool = False) -> tuple[float | None, dict]:
    """The realistic in-process plant: floated 30 s unwatched, then watched (drifting, or from t = 0 speeding up
    under a constant surge force, its heading held by a PD yaw moment when ``hold_heading``); (seconds to the
    first confident estimate, its errors). The sea's phase is drawn from ``phase_seed`` (default ``seed``)."""
    params = otter_parameters()
    sea = _sea(sea_name, seed if phase_seed is None else phase_seed)
    est = WindowEstimator(calibrated_settings(params, True, 1.0))
    x0 = np.zeros(12)
    x0[5] = psi_ref = math.radians(heading_deg)

    class Unwatched:
        def observe(self, sample: object) -> None:
            """Nobody watches while the hull settles."""

    plant = SensedPlant(params, sea, OceanCurrent(), x0, 0.1, 0.01, True, sensor_model("default", seed),
                           Unwatched())
    t = -30.0
    while t < 0:
        plant.advance(t, np.zeros(2), (0.0, 0.0))
        t += 0.1
    plant.source = est
    while t < 25.0:
        plant.sense(t)
        answer = est.estimate(t)
        if answer is not None:
            return t, estimate_metrics(answer, sea, t, plant.rigid_state, 0.0)
        x = plant.rigid_state
        yaw = -60.0 * math.remainder(x[5] - psi_ref, 2 * math.pi) - 40.0 * x[11] if hold_heading else 0.0
        plant.advance(t, np.array([surge_n, float(np.clip(yaw, -73.6, 73.6))]), (0.0, 0.0))
        t += 0.1
    return None, {}


@pytest.mark.parametrize(("sea_name", "surge_n", "heading_deg"),
                         [("paper", 0.0, 0.0), ("paper", 150.0, 0.0), ("medium", 150.0, 90.0), ("long", 0.0, 0.0)])
def test_the_real_hull_is_read_within_15_s_and_within_bounds(sea_name: str, surge_n: float,
                                                               heading_deg: float) -> None:
    first, errors = _plant_run(sea_name, 1, surge_n, heading_deg)
    assert first is not None and first <= 15.0, f"first confident at {first}"
    for name, bound in (("period_err_pct", 3.0), ("direction_err_deg", 10.0), ("length_err_pct", 10.0),
                        ("height_err_pct", 15.0)):
        assert abs(errors[name]) <= bound, f"{name} {errors[name]:+.1f}"


@pytest.mark.parametrize(("sea_name", "heading_deg", "seed"), [("short", 0.0, 2), ("paper", 90.0, 3)],
                         ids=["quartering-following", "head"])
def test_a_hull_speeding_up_within_the_window_heaves_at_its_local_encounter_frequency(
        sea_name: str, heading_deg: float, seed: int) -> None:
    """The two runs of ``bench/wave_estimation.py`` that missed issue 29's bounds (16.5 s with the wavelength
    −10.3 %; 15.4 s), the boat speeding up from drifting as the window fills. The quartering case is the heave's
    encounter frequency: with the window's mean velocity its early heave came at another one than the model's (with
    the velocity averaged over one encounter period around each sample, 12.3 s; without, 15.4 s). The head case
    needs either that or the second harmonics (``_stack``); without both it is read at 15.4 s."""
    first, errors = _plant_run(sea_name, seed, 120.0, heading_deg, phase_seed=[31, seed], hold_heading=True)
    assert first is not None and first <= 15.0, f"first confident at {first}"
    for name, bound in (("period_err_pct", 3.0), ("direction_err_deg", 10.0), ("length_err_pct", 10.0),
                        ("height_err_pct", 15.0)):
        assert abs(errors[name]) <= bound, f"{name} {errors[name]:+.1f}"


def test_calm_water_and_attitude_noise_alone_never_give_a_wave() -> None:
    boat = KinematicBoat(CalmWater(), 1.0, lambda t: 0.3)  # noise of the default sensors only
    est = WindowEstimator()
    for sample in motion_samples(boat, 60.0, seed=5, t0=1000.0):
        est.observe(sample)
        assert est.estimate(sample.t_s) is None
    assert est.spread(False) is None  # no sea's statistics either: the slope is below the noise floor


def test_the_fit_in_stages_is_the_fit_whole_and_no_sample_carries_more_than_one_stage() -> None:
    sea = _sea("paper", 3)
    est = WindowEstimator()
    stages_per_sample = []
    for sample in motion_samples(KinematicBoat(sea, 1.0, lambda t: 0.5), 40.0, seed=3, t0=200.0):
        before = est._job
        est.observe(sample)
        stages_per_sample.append(est._job is not None or before is not None)
    assert est.fits >= 20 and est.estimate(sample.t_s) is not None
    built = est._motion.window(sample.t_s)
    assert built is not None
    window = built[0]
    start = est._fit.wave
    whole = refine(window, start, est.hull, 3, est._fit.noise)
    staged = refine_stages(window, start, est.hull, 3, est._fit.noise)
    count = 0
    for count in range(1, 50):  # noqa: B007
        try:
            next(staged)
        except StopIteration as end:
            assert end.value is not None and whole is not None
            assert end.value.wave == whole.wave
            break
    assert 2 <= count <= 10, count  # a warm fit is a handful of stages, each about one model evaluation
    assert run_stages(refine_stages(window, start, est.hull, 3, est._fit.noise)).wave == whole.wave


def test_every_gps_height_survives_the_thinning() -> None:
    values = np.array([np.nan, 1, np.nan, 2, 3, np.nan, np.nan, np.nan, 4, np.nan])
    kept = _last_in_blocks(values, 1, 2)  # samples 1, 3, 5, 7, 9 kept
    assert np.array_equal(kept[[0, 1, 2, 4]], [1.0, 2.0, 3.0, 4.0]) and np.isnan(kept[3])


def test_a_clock_going_back_forgets_the_window_and_bad_samples_never_raise() -> None:
    sea = _sea("paper", 4)
    est = make_estimator(EstimatorSettings())
    samples = list(motion_samples(KinematicBoat(sea, 1.0, lambda t: 1.0), 30.0, seed=4, t0=800.0))
    for sample in samples:
        est.observe(sample)
    assert est.estimate(samples[-1].t_s) is not None
    rebooted = [type(s)(s.t_s - 790.0, s.attitude, s.rates, s.position_ned, s.velocity_ned, s.accel_body)
                for s in samples[:40]]
    for sample in rebooted:  # the autopilot rebooted: its clock restarts near 0
        est.observe(sample)
    assert est.estimate(rebooted[-1].t_s) is None and est.latest(rebooted[-1].t_s) is None
    broken = type(samples[0])(float("nan"), np.full(3, np.nan), np.zeros(3), np.full(3, np.nan), np.zeros(3), None)
    est.observe(broken)
    assert est.estimate(rebooted[-1].t_s) is None


@pytest.mark.parametrize("method", ["window", "recursive"])
def test_after_a_reboot_the_estimator_is_not_blind_until_the_new_clock_passes_the_old(method: str) -> None:
    """The autopilot rebooted after 40 s: its clock restarts at 10 s, far behind the old one. The estimator starts
    again on the new clock (an estimate within 40 s of it), not only once the new clock has passed the old."""
    sea = _sea("paper", 6)
    est = make_estimator(EstimatorSettings(method=method))
    samples = list(motion_samples(KinematicBoat(sea, 1.0, lambda t: 1.0), 80.0, seed=6, t0=900.0))
    for sample in samples[:800]:
        est.observe(sample)
    assert est.estimate(samples[799].t_s) is not None
    confident_after_s = None
    for i, sample in enumerate(samples[800:]):
        t = sample.t_s - 930.0  # 10 s after the reboot at the first of these
        est.observe(type(sample)(t, sample.attitude, sample.rates, sample.position_ned, sample.velocity_ned,
                                 sample.accel_body))
        if i == 0:
            assert est.estimate(t) is None  # the wave it knew was on the old clock: forgotten
        if confident_after_s is None and est.estimate(t) is not None:
            confident_after_s = t - 10.0
    assert confident_after_s is not None and confident_after_s < 40.0, confident_after_s


def _synthetic_window(wave: WaveParams, hull: HullResponse, harmonic_mps2: float, seed: int) -> Window:
    """20 s at 20 Hz of a boat heading East at 1.6 m/s into ``wave``: pitch, roll and the heave's acceleration
    as the fit's model has them, plus a second harmonic of the wave's phase on the acceleration and white noise
    (0.003 rad, 0.03 m/s²)."""
    rng = np.random.default_rng(seed)
    t = np.arange(-20.0, 0.0001, 0.05)
    east = 1.6 * t
    zeros, nan = np.zeros_like(t), np.full_like(t, np.nan)
    bare = Window(t, zeros, east, zeros, np.full_like(t, 1.6), np.full_like(t, math.pi / 2), zeros, zeros, zeros, nan)
    models = channel_models(bare, wave, hull)
    phase = wave.omega * t - wave.k * east * math.sin(wave.chi)
    accel = models["accel"][0] + harmonic_mps2 * np.sin(2 * phase + 0.4) + rng.normal(0, 0.03, t.size)
    along = models["along"][0] + rng.normal(0, 0.003, t.size)
    across = models["across"][0] + rng.normal(0, 0.003, t.size)
    return Window(t, zeros, east, zeros, np.full_like(t, 1.6), np.full_like(t, math.pi / 2), along, across, accel,
                  nan)


def test_a_second_harmonic_in_the_heave_is_fitted_not_counted_as_noise() -> None:
    """A hull under way in a head sea heaves with a second harmonic of the wave's phase (its speed swings within
    each wave): 0.2 m/s² of it, most of what the heave's acceleration left unexplained in the paper's sea at
    1.6 m/s. The fit takes it as a nuisance term: the wave is found as without it, and the channel's noise, which
    sets the standard errors and so how soon the estimate is confident, is the sensor's."""
    wave = WaveParams(2 * math.pi / 6.0, 2 * math.pi / 35.0, -math.pi / 2 + 0.2, 0.6, -0.6)
    hull = HullResponse(1.0, 0.0, 0.9, -0.23)
    clean = refine(_synthetic_window(wave, hull, 0.0, 5), wave, hull)
    with_harmonic = refine(_synthetic_window(wave, hull, 0.2, 5), wave, hull)
    assert clean is not None and with_harmonic is not None
    for name, relative in (("omega", 0.002), ("k", 0.01), ("amplitude", 0.01)):
        got, true = getattr(with_harmonic.wave, name), getattr(wave, name)
        assert abs(got / true - 1) < relative, f"{name}: {got:.4f} against {true:.4f}"
    assert abs(with_harmonic.wave.chi - wave.chi) < math.radians(0.5)
    assert with_harmonic.noise["accel"] < 0.04, with_harmonic.noise
    assert with_harmonic.rel_sigma_k < 1.2 * clean.rel_sigma_k


def test_the_fits_jacobian_with_nuisance_terms_is_the_residuals_derivative() -> None:
    """``_stack``'s Jacobian, second harmonics and offsets nonzero, on a surging, speeding-up track, against
    central differences of its residuals in every parameter (the wave's five, then each channel's nuisance
    terms)."""
    wave = WaveParams(2 * math.pi / 6.0, 2 * math.pi / 35.0, -math.pi / 2 + 0.2, 0.6, -0.6)
    hull = HullResponse(1.0, 0.0, 0.9, -0.23)
    base = _synthetic_window(wave, hull, 0.2, 7)
    speed = 1.0 + 0.05 * (base.t - base.t[0]) + 0.3 * np.sin(1.3 * base.t)
    east = np.concatenate(([0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * np.diff(base.t))))
    w = with_encounter_smoothing(dataclasses.replace(base, east=east - east[-1], v_east=speed), wave)
    extras = np.array([[0.01, 0.02, -0.01], [0.0, -0.015, 0.01], [0.05, 0.1, -0.08], [0.0, 0.0, 0.0]])
    noise = {"along": 0.003, "across": 0.003, "accel": 0.03, "down": 0.15}
    _, jac, _, _ = _stack(w, wave, hull, extras, noise)
    active = list(w.channels)
    for column in range(jac.shape[1]):
        step = np.zeros(jac.shape[1])
        h = 1e-6 * (1.0 + abs(wave.vector()[column])) if column < 5 else 1e-6
        step[column] = h
        plus, minus = (_apply(w, wave, extras, sign * step, active) for sign in (1.0, -1.0))
        res_plus, res_minus = (_stack(w, moved[0], hull, moved[1], noise)[0] for moved in (plus, minus))
        numeric = -(res_plus - res_minus) / (2 * h)  # residuals are measured − model
        assert np.allclose(jac[:, column], numeric, rtol=1e-4, atol=1e-4 * np.max(np.abs(numeric)) + 1e-9), column


def test_a_channel_with_few_samples_fits_its_offset_only_and_the_wave_is_still_found() -> None:
    """An IMU that comes back at the window's end gives the heave channel a handful of samples: with a second
    harmonic and an offset of its own each, they would leave the fit undetermined (one sample: a singular normal
    matrix) or take the channel's information for themselves. Below ``HARMONIC_MIN_SAMPLES`` or one encounter
    period the channel fits its offset only, and the fit is the one without that channel, or better."""
    wave = WaveParams(2 * math.pi / 6.0, 2 * math.pi / 35.0, -math.pi / 2 + 0.2, 0.6, -0.6)
    hull = HullResponse(1.0, 0.0, 0.9, -0.23)
    full = _synthetic_window(wave, hull, 0.0, 5)
    without = refine(dataclasses.replace(full, accel=np.full_like(full.t, np.nan), down=without_down(full, wave)),
                     wave, hull)
    assert without is not None
    for count in (1, 2, 8, 30):
        accel = np.full_like(full.t, np.nan)
        accel[-count:] = full.accel[-count:]
        window = dataclasses.replace(full, accel=accel, down=without_down(full, wave))
        assert with_encounter_smoothing(window, wave).nuisance_columns("accel") == 1
        fit = refine(window, wave, hull)
        assert fit is not None, count
        assert fit.rel_sigma_k <= 1.05 * without.rel_sigma_k + 1e-9, (count, fit.rel_sigma_k, without.rel_sigma_k)


def without_down(w: Window, wave: WaveParams) -> np.ndarray:
    """A GPS height every 20th sample: −ζ at the boat with 0.3 m of noise (the channel a window without the IMU's
    heave uses)."""
    phase = wave.omega * w.t - wave.k * (w.north * math.cos(wave.chi) + w.east * math.sin(wave.chi))
    down = -(wave.alpha * np.sin(phase) + wave.beta * np.cos(phase)) + np.random.default_rng(3).normal(0, 0.3, w.t.size)
    return np.where(np.arange(w.t.size) % 20 == 0, down, np.nan)
