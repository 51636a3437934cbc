"""Wave spectra, spreading, sea states and dispersion against closed forms and their defining equations."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vessel.sea.spectra import (
    NATO_SEA_STATES,
    cos2s_spreading,
    jonswap,
    nato_sea_state,
    pierson_moskowitz,
    sample_cos2s,
    spectral_moment,
    wavenumber,
)

OMEGA = np.linspace(0.05, 60.0, 300_001)  # rad/s; covers every spectrum here to < 1e-7 of m0


@pytest.mark.parametrize(("hs", "tp"), [(1.75, 6.0), (0.5, 3.0), (6.0, 12.0)])
def test_pierson_moskowitz_has_the_closed_form_m0(hs: float, tp: float) -> None:
    m0 = spectral_moment(OMEGA, pierson_moskowitz(OMEGA, hs, tp))
    assert m0 == pytest.approx(hs**2 / 16, rel=1e-5)


def test_pierson_moskowitz_is_the_bretschneider_formula() -> None:
    hs, tp = 1.75, 6.0
    wp = 2 * math.pi / tp
    w = np.random.default_rng(3).uniform(0.3, 5.0, 50)
    written_out = 5 / 16 * hs**2 * wp**4 / w**5 * np.exp(-1.25 * (wp / w) ** 4)
    np.testing.assert_allclose(pierson_moskowitz(w, hs, tp), written_out, rtol=1e-12)


@pytest.mark.parametrize("gamma", [1.0, 2.0, 3.3, 5.0, 7.0, 10.0])
def test_jonswap_m0_is_hs_squared_over_16_for_every_gamma(gamma: float) -> None:
    m0 = spectral_moment(OMEGA, jonswap(OMEGA, 1.75, 6.0, gamma))
    assert 4 * math.sqrt(m0) == pytest.approx(1.75, rel=1e-5)


@pytest.mark.parametrize("gamma", [2.0, 3.3, 5.0])
def test_jonswap_shape_is_the_peak_enhanced_pm_with_the_usual_normalisation(gamma: float) -> None:
    """Away from normalisation, S_J / S_PM is γ^r with σ 0.07 below and 0.09 above the peak."""
    tp = 6.0
    wp = 2 * math.pi / tp
    w = np.array([0.8, 0.93, 1.0, 1.07, 1.2, 1.6]) * wp
    ratio = jonswap(w, 1.75, tp, gamma) / pierson_moskowitz(w, 1.75, tp)
    sigma = np.where(w <= wp, 0.07, 0.09)
    r = gamma ** np.exp(-((w - wp) ** 2) / (2 * sigma**2 * wp**2))
    scale = ratio / r
    np.testing.assert_allclose(scale, scale[0], rtol=1e-12)  # one constant factor
    assert scale[0] == pytest.approx(1 - 0.287 * math.log(gamma), rel=0.005)  # ≈ the textbook factor


def test_jonswap_peaks_at_the_peak_frequency() -> None:
    for tp in (3.0, 6.0, 14.0):
        w = np.linspace(0.2, 4.0, 200_001) * 2 * math.pi / tp
        assert 2 * math.pi / w[np.argmax(jonswap(w, 1.0, tp))] == pytest.approx(tp, rel=1e-4)


@pytest.mark.parametrize("s", [1.0, 5.0, 20.0, 75.0])
def test_cos2s_spreading_integrates_to_one(s: float) -> None:
    theta = np.linspace(-math.pi, math.pi, 200_001) + 0.3
    assert spectral_moment(theta, cos2s_spreading(theta, 0.3, s)) == pytest.approx(1.0, rel=1e-6)


@pytest.mark.parametrize("s", [2.0, 10.0])
def test_sampled_directions_follow_the_spreading(s: float) -> None:
    theta0 = -math.pi / 2
    draws = sample_cos2s(np.random.default_rng(11), 20_000, theta0, s)
    grid = np.linspace(-math.pi, math.pi, 100_001)
    expected_cos = spectral_moment(grid, np.cos(grid) * cos2s_spreading(grid, 0.0, s))
    spread = np.cos(draws - theta0)
    assert abs(spread.mean() - expected_cos) < 4 * spread.std() / math.sqrt(draws.size)
    assert abs(np.sin(draws - theta0).mean()) < 4 / math.sqrt(draws.size)  # symmetric about θ0


def test_nato_sea_states_use_mid_band_height_and_most_probable_period() -> None:
    for number, (low, high, period) in NATO_SEA_STATES.items():
        hs, tp = nato_sea_state(number)
        assert hs == pytest.approx(0.5 * (low + high))
        assert tp == period
    assert nato_sea_state(4) == (pytest.approx(1.875), 9.0)  # the paper's sea state: 1.25–2.5 m, 9 s
    with pytest.raises(ValueError, match=r"\[0, 8\]"):
        nato_sea_state(9)


def test_deep_water_dispersion() -> None:
    w = np.array([0.5, 1.047, 3.0])
    np.testing.assert_allclose(wavenumber(w), w**2 / 9.81)


@pytest.mark.parametrize("depth", [0.5, 4.1, 20.0, 500.0])
def test_finite_depth_wavenumber_solves_the_dispersion_relation(depth: float) -> None:
    w = np.linspace(0.1, 8.0, 60)
    k = wavenumber(w, depth)
    np.testing.assert_allclose(9.81 * k * np.tanh(k * depth), w**2, rtol=1e-12)


def test_the_papers_wave_is_a_4_m_deep_water_wave() -> None:
    """Reference §0: T = 6 s, λ = 35 m fits the dispersion relation only at a depth of about 4.1 m."""
    k = wavenumber(np.array([2 * math.pi / 6.0]), 4.1)[0]
    assert 2 * math.pi / k == pytest.approx(35.0, rel=0.01)
    assert 2 * math.pi / wavenumber(np.array([2 * math.pi / 6.0]))[0] == pytest.approx(56.2, abs=0.1)
