"""The phase-resolved wave predictor (issue 33): it recovers known components, predicts an irregular sea ahead of the
boat better than persistence, keeps its phases through a turn (earth frame), says when it is not confident, and
skips bad input with a reason. Kinematic truth: the hull lies along the simulator's sea (``vessel.sea``)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mavbridge.waves.phase.bank import Samples, fit_bank, make_bank, slope_from_attitude, spectral_prior
from mavbridge.waves.phase.predictor import PhasePredictor, PredictorSettings
from vessel import otter_parameters
from vessel.sea.irregular import IrregularWaves
from vessel.sea.irregular_sea import IrregularSea

RATE_HZ = 20.0


def _feed(predictor: PhasePredictor, sea: IrregularWaves, psi_of_t: object, seconds: float, speed: float = 1.75,
          noise_rad: float = 0.0, seed: int = 0, t0: float = 1234.5) -> tuple[np.ndarray, ...]:
    """Run a boat along ``psi_of_t`` (rad NED of s), feeding the predictor for ``seconds``; (t on the clock, north,
    east, t of the sea) of the path, which goes on 5 s further (the truth ahead of the last fit)."""
    t = np.arange(0.0, seconds + 5.0, 1.0 / RATE_HZ)
    psi = np.asarray(psi_of_t(t), float) * np.ones(t.size)
    north = np.concatenate(([0.0], np.cumsum(speed * np.cos(psi[:-1]) / RATE_HZ)))
    east = np.concatenate(([0.0], np.cumsum(speed * np.sin(psi[:-1]) / RATE_HZ)))
    g_n, g_e = sea.gradient(north, east, t)
    rng = np.random.default_rng(seed)
    g_n, g_e = g_n + rng.normal(0, noise_rad, t.size), g_e + rng.normal(0, noise_rad, t.size)
    for i in range(np.count_nonzero(t < seconds)):
        predictor.observe(t0 + t[i], north[i], east[i], g_n[i], g_e[i])
    return t0 + t, north, east, t


def _correlation_ahead(predictor: PhasePredictor, sea: IrregularWaves, t_clock: np.ndarray, north: np.ndarray,
                       east: np.ndarray, t_sea: np.ndarray, lead_s: float) -> float:
    """r of predicted against true slope ``lead_s`` ahead along the path, from the predictor's last fit."""
    now = int(np.searchsorted(t_clock, predictor.fit_time_s))
    ahead = now + np.arange(1, round(lead_s * RATE_HZ) + 1)
    assert ahead[-1] < t_clock.size
    pn, pe, _, _ = predictor.predict(t_clock[ahead], north[ahead], east[ahead])
    tn, te = sea.gradient(north[ahead], east[ahead], t_sea[ahead])
    return float(np.corrcoef(np.concatenate([pn, pe]), np.concatenate([tn, te]))[0, 1])


def test_known_components_are_recovered_and_predicted_4_s_ahead() -> None:
    """Three components on the bank's grid (0.2 rad/s apart, resolved by the 40 s window), noiseless slopes from a
    moving boat: amplitudes within 5 %, and the slope 4 s ahead with r > 0.95."""
    bank = make_bank((0.6, 2.0), 8, [0.3])
    chosen = np.array([1, 4, 6])
    amp = np.zeros(bank.size)
    amp[chosen] = [0.3, 0.6, 0.2]
    phase = np.random.default_rng(4).uniform(-math.pi, math.pi, bank.size)
    sea = IrregularWaves(amp, bank.omega, bank.k, bank.direction, phase)
    t = np.arange(0.0, 44.0, 0.1)
    north, east = 1.5 * t * math.cos(2.0), 1.5 * t * math.sin(2.0)
    g_n, g_e = sea.gradient(north, east, t)
    fit_part = t <= 40.0
    nan = np.full(t.size, np.nan)
    samples = Samples(t, north, east, g_n, g_e, nan, nan).subset(fit_part)
    fit = fit_bank(bank, samples, ridge=1e-9, noise={"slope_n": 1e-3, "slope_e": 1e-3})
    assert fit is not None
    assert np.allclose(fit.waves.amplitude_m[chosen], amp[chosen], rtol=0.05)
    later = ~fit_part
    pn, pe, _ = fit.predict(t[later], north[later], east[later])
    r = np.corrcoef(np.concatenate([pn, pe]), np.concatenate([g_n[later], g_e[later]]))[0, 1]
    assert r > 0.95


def test_jonswap_one_second_ahead_beats_persistence() -> None:
    """JONSWAP γ 3.3 (Hs 1.75 m, Tp 6 s) in quartering seas at 1.75 m/s, 0.5° of slope noise: the slope 1 s ahead
    correlates above 0.8 with the truth, and better than the slope measured now (persistence)."""
    sea = IrregularSea(hs_m=1.75, tp_s=6.0, gamma=3.3, travel_dir_deg=0.0, seed=3).wave_field(otter_parameters())
    predictor = PhasePredictor()
    t_clock, north, east, t_sea = _feed(predictor, sea, lambda t: math.radians(45.0), 70.0,
                                        noise_rad=math.radians(0.5), seed=3)
    r = _correlation_ahead(predictor, sea, t_clock, north, east, t_sea, 1.0)
    # persistence over the scored run: the slope now against the slope 1 s later along the same path
    tn, te = sea.gradient(north, east, t_sea)
    lag = round(RATE_HZ)
    persistence = np.corrcoef(np.concatenate([tn[:-lag], te[:-lag]]), np.concatenate([tn[lag:], te[lag:]]))[0, 1]
    assert r > 0.8 and r > persistence + 0.3, (r, persistence)


def test_predictions_stay_valid_after_a_90_degree_turn() -> None:
    """A following-sea boat turns 90° (to beam seas) at 9°/s; 15 s after the turn the 1 s prediction still
    correlates above 0.8 with the truth: the fit is in the earth frame, the turn is inside its phases."""
    sea = IrregularSea(hs_m=1.75, tp_s=6.0, gamma=5.0, travel_dir_deg=30.0, seed=5).wave_field(otter_parameters())
    predictor = PhasePredictor()
    turn = lambda t: np.radians(30.0 + np.clip((t - 45.0) * 9.0, 0.0, 90.0))  # noqa: E731
    t_clock, north, east, t_sea = _feed(predictor, sea, turn, 70.0, noise_rad=math.radians(0.3), seed=5)
    assert _correlation_ahead(predictor, sea, t_clock, north, east, t_sea, 1.0) > 0.8


def test_calm_water_and_pure_noise_are_not_confident() -> None:
    """Flat water with 0.5° of attitude noise: never confident, and the reason names the missing sea or skill."""
    calm = IrregularWaves(np.zeros(3), np.array([0.8, 1.0, 1.2]), np.array([0.07, 0.1, 0.15]), np.zeros(3),
                          np.zeros(3))
    predictor = PhasePredictor()
    _feed(predictor, calm, lambda t: 0.0, 40.0, noise_rad=math.radians(0.5))
    assert predictor.fits > 10
    for lead in (0.5, 1.0, 2.0, 4.0):
        assert not predictor.confident(lead)
        reason = predictor.not_confident_because(lead)
        assert reason is not None and "no sea" in reason, reason  # the noise is taken off the slope first
    assert not predictor.predict(np.array([predictor.fit_time_s + 1.0]), np.zeros(1), np.zeros(1))[3].any()


def test_a_confident_sea_says_so_within_the_scored_horizon_only() -> None:
    """Following seas (easy): confident 1 s ahead after a minute; never beyond the scored horizon."""
    sea = IrregularSea(hs_m=1.75, tp_s=6.0, gamma=3.3, travel_dir_deg=0.0, seed=2).wave_field(otter_parameters())
    predictor = PhasePredictor()
    _feed(predictor, sea, lambda t: 0.0, 60.0, noise_rad=math.radians(0.5), seed=2)
    assert predictor.confident(1.0), predictor.not_confident_because(1.0)
    assert "beyond" in (predictor.not_confident_because(predictor.s.horizon_s + 1.0) or "")
    leads = np.array([0.5, predictor.s.horizon_s - 0.5, predictor.s.horizon_s + 0.5, predictor.s.horizon_s + 0.99])
    flags = predictor.predict(predictor.fit_time_s + leads, np.zeros(4), np.zeros(4))[3]
    assert flags[0] and not flags[2] and not flags[3], flags  # past the horizon, even inside its last bin
    arrays = predictor.bank_arrays(20)
    assert all(v.shape == (20,) for v in arrays.values()) and np.all(arrays["amplitude_m"] > 0)


def test_bad_input_is_skipped_with_a_reason() -> None:
    """NaN and a repeated or earlier time are skipped, named and counted; a clock 10 s back restarts the window."""
    predictor = PhasePredictor()
    assert predictor.observe(10.0, 0.0, 0.0, 0.01, 0.0) is None
    assert predictor.observe(10.05, math.nan, 0.0, 0.01, 0.0) == "non-finite time, position or slope"
    assert predictor.observe(10.0, 0.0, 0.0, 0.01, 0.0) == "time not increasing"
    assert predictor.observe(9.0, 0.0, 0.0, 0.01, 0.0) == "time not increasing"
    assert predictor.skipped == {"non-finite time, position or slope": 1, "time not increasing": 2}



def test_a_reboot_restarts_the_window_on_the_new_clock() -> None:
    """Fits on the old clock, then the clock starts again near 0 (the autopilot rebooted): the old fit is gone at
    once, and the next fit is made of new-clock samples only."""
    sea = IrregularSea(hs_m=1.75, tp_s=6.0, gamma=3.3, travel_dir_deg=0.0, seed=2).wave_field(otter_parameters())
    predictor = PhasePredictor()
    _feed(predictor, sea, lambda t: 0.0, 12.0, t0=100.0)
    assert predictor.fits > 0 and predictor.fit_time_s > 100.0
    assert predictor.observe(0.0, 0.0, 0.0, 0.01, 0.0) is None  # 112 s → 0 s: a reboot, the window restarts
    assert predictor.fit_time_s == -math.inf
    assert predictor.predict(np.zeros(1), np.zeros(1), np.zeros(1)) is None
    _feed(predictor, sea, lambda t: 0.0, 6.0, t0=0.05)
    assert 4.0 <= predictor.fit_time_s <= 6.1, predictor.fit_time_s


def test_a_slower_attitude_stream_keeps_the_fits_coming() -> None:
    """After 50 s at 20 Hz the stream drops to 4 Hz (ArduPilot's common telemetry rate): a 40 s window then has
    fewer samples than the bank has unknowns, and it is still fitted (the prior holds it), so the leads keep counting
    from a fresh fit and the 1 s prediction stays right; before, every fit failed and a minute-old fit was used."""
    sea = IrregularSea(hs_m=1.75, tp_s=6.0, gamma=3.3, travel_dir_deg=0.0, seed=2).wave_field(otter_parameters())
    predictor = PhasePredictor()
    t = np.arange(0.0, 100.0, 0.05)
    keep = (t < 50.0) | (np.round(t * 20).astype(int) % 5 == 0)
    north, east = 1.75 * t, np.zeros(t.size)
    g_n, g_e = sea.gradient(north, east, t)
    fed = keep & (t < 95.0)
    for i in np.flatnonzero(fed):
        predictor.observe(float(t[i]), float(north[i]), 0.0, float(g_n[i]), float(g_e[i]))
    assert predictor.fit_time_s >= 93.0, (predictor.fit_time_s, predictor.skipped)
    ahead = (t > predictor.fit_time_s) & (t <= predictor.fit_time_s + 1.0)
    pn, pe, _, _ = predictor.predict(t[ahead], north[ahead], east[ahead])
    r = np.corrcoef(np.concatenate([pn, pe]), np.concatenate([g_n[ahead], g_e[ahead]]))[0, 1]
    assert r > 0.8, r


def test_settings_out_of_range_name_the_field() -> None:
    """A setting outside its range is one ValueError naming it and the range (a zero rate would divide by zero)."""
    for bad in ({"rate_hz": 0.0}, {"horizon_s": 0.0}, {"window_s": -5.0}, {"band_rad_s": (2.0, 1.0)}):
        with pytest.raises(ValueError, match=f"PredictorSettings.{next(iter(bad))} = .*allowed"):
            PredictorSettings(**bad)


def test_slope_from_attitude_inverts_the_hull_lying_on_the_surface() -> None:
    """Roll/pitch of a hull along a known gradient, at several headings, give that gradient back (NED)."""
    g_n, g_e = 0.12, -0.05
    tilt = math.atan(math.hypot(g_n, g_e)) / math.hypot(g_n, g_e)
    for psi in np.radians([0.0, 70.0, 200.0, -135.0]):
        pitch = tilt * (g_n * math.cos(psi) + g_e * math.sin(psi))
        roll = -tilt * (g_e * math.cos(psi) - g_n * math.sin(psi))  # geometric roll sign (−1)
        s_n, s_e = slope_from_attitude(roll, pitch, psi)
        assert math.isclose(float(s_n), g_n, abs_tol=1e-12) and math.isclose(float(s_e), g_e, abs_tol=1e-12)


def test_the_prior_keeps_short_waves_small() -> None:
    """The spectral prior falls steeply above the peak (a short wave may not explain the slope)."""
    bank = make_bank((0.4, 4.5), 30, [0.0])
    prior = spectral_prior(bank, 1.0)
    assert prior[np.argmin(abs(bank.omega - 4.0))] < 0.01 * prior.max()
