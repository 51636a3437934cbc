"""The sea's slope statistics and the NMPC's expected-roll term: measured from the hull's motion, factored
for the solvers, and steering the plan away from beam seas only when R > 0."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from mavbridge.nmpc import NmpcConfig, RollAwareNmpc
from mavbridge.nmpc.sea_spread import slope_factor
from mavbridge.waves import WaveEstimator
from mavbridge.waves.kinematic import KinematicBoat, motion_samples, paper_sea
from mavbridge.waves.source import MotionSample, spread_line
from mavbridge.waves.spread import SPREAD_MIN_S, SlopeSpread
from vessel import otter_parameters

BEAM_SPREAD = np.array([[0.0, 0.0], [0.0, 0.0085]])  # slope along East-West only (waves travelling West)


@pytest.mark.parametrize("cov", [BEAM_SPREAD, np.array([[0.004, 0.001], [0.001, 0.003]]),
                                 np.array([[0.002, -0.002], [-0.002, 0.002]])])
def test_slope_factor_reproduces_the_covariance(cov: np.ndarray) -> None:
    l_nn, l_en, l_ee = slope_factor(cov)
    lower = np.array([[l_nn, 0.0], [l_en, l_ee]])
    np.testing.assert_allclose(lower @ lower.T, cov, atol=1e-15)


def test_slope_factor_of_none_is_zero_and_bad_covariances_are_refused() -> None:
    np.testing.assert_array_equal(slope_factor(None), np.zeros(3))
    for bad, why in ((np.array([[np.nan, 0], [0, 1.0]]), "finite"), (np.array([[1.0, 0.2], [0.1, 1.0]]), "symmetric"),
                     (np.array([[1.0, 2.0], [2.0, 1.0]]), "semi-definite"), (np.eye(3), "2x2")):
        with pytest.raises(ValueError, match=why):
            slope_factor(bad)


def test_slope_spread_is_offered_after_its_observation_time_and_turns_do_not_reset_it() -> None:
    spread, dt, amp, omega = SlopeSpread(), 0.05, 0.1, 1.2
    t = 0.0
    while t < SPREAD_MIN_S - 1.0:
        # heading North, the slope across the hull: an East-West slope in NED
        spread.update(amp * math.sin(omega * t), 0.0, 0.0, dt)
        t += dt
    assert spread.covariance(0.004) is None  # not yet observed long enough
    while t < 90.0:
        psi = 0.0 if t < 60.0 else math.pi / 2  # a 90° turn: the same East-West slope is now along the hull
        across, along = (amp * math.sin(omega * t), 0.0) if psi == 0.0 else (0.0, amp * math.sin(omega * t))
        spread.update(across, along, psi, dt)
        t += dt
    cov = spread.covariance(0.004)
    assert cov is not None
    assert cov[1, 1] == pytest.approx(amp**2 / 2, rel=0.1)  # East-West: the sinusoid's variance
    # (the running means leak a part-cycle's mean of the sinusoid across the turn: a thousandth of its variance)
    assert abs(cov[0, 0]) < 1e-3 * amp**2 and abs(cov[0, 1]) < 1e-3 * amp**2
    assert spread.covariance(0.2) is None  # below the smallest slope that counts
    assert "along 90 deg" in spread_line(cov)


def test_the_hulls_trim_and_list_are_not_a_sea() -> None:
    """A hull sitting 1.5° bow-down and listing 1° (a trim under way, a load) makes no wave: the covariance is the
    slope's alone, whatever the heading it was measured at (the raw attitude put trim² into it)."""
    dt, amp, omega = 0.05, 0.05, 1.1
    plain, trimmed = SlopeSpread(), SlopeSpread()
    for i in range(round(90.0 / dt)):
        t, psi = i * dt, math.radians(30.0)
        across, along = 0.3 * amp * math.sin(omega * t), amp * math.sin(omega * t + 0.4)
        plain.update(across, along, psi, dt)
        trimmed.update(across + math.radians(1.0), along - math.radians(1.5), psi, dt)
    without, with_trim = plain.covariance(0.004), trimmed.covariance(0.004)
    assert without is not None and with_trim is not None
    np.testing.assert_allclose(with_trim, without, atol=0.02 * np.trace(without))
    assert abs(np.trace(with_trim) - amp**2 * 1.09 / 2) < 0.05 * amp**2  # the slope's variance, no trim²


def test_trim_is_taken_off_across_a_turn_and_a_restart_starts_its_mean_again() -> None:
    """The trim is body-fixed: after a 90° turn it is still not a sea. After a silence (``restart``) the trim
    mean starts again, so a new trim (the boat stopped, say) does not pass for a slope."""
    dt, amp, omega = 0.05, 0.05, 1.1
    spread = SlopeSpread()
    for i in range(round(120.0 / dt)):
        t = i * dt
        psi = 0.0 if t < 60.0 else math.pi / 2
        slope = amp * math.sin(omega * t)  # an East-West sea: across the hull heading North, along it heading East
        across, along = (slope, 0.0) if psi == 0.0 else (0.0, slope)
        spread.update(across + math.radians(1.0), along - math.radians(1.5), psi, dt)
    cov = spread.covariance(0.004)
    assert cov is not None and abs(cov[1, 1] - amp**2 / 2) < 0.05 * amp**2 and abs(cov[0, 0]) < 0.01 * amp**2
    spread.restart()
    for i in range(round(60.0 / dt)):  # the boat stopped: the trim is gone, the sea the same
        spread.update(amp * math.sin(omega * i * dt), 0.0, 0.0, dt)
    cov = spread.covariance(0.004)
    assert cov is not None and abs(np.trace(cov) - amp**2 / 2) < 0.05 * amp**2


def _estimator_in_paper_sea(seconds: float) -> WaveEstimator:
    boat = KinematicBoat(paper_sea(0.7), 1.5, lambda t: math.radians(45.0))
    est = WaveEstimator()
    for sample in motion_samples(boat, seconds, seed=3, t0=100.0):
        est.observe(sample)
    return est


def test_in_a_regular_sea_a_confident_wave_explains_nearly_all_of_the_spread() -> None:
    est = _estimator_in_paper_sea(60.0)
    total, rest = est.spread(explained=False), est.spread(explained=True)
    assert total is not None and rest is not None
    # the paper's wave travels West: its slope is East-West, RMS = (H/2)·k/√2 ≈ 0.11 rad
    assert math.sqrt(total[1, 1]) == pytest.approx(0.875 * 2 * math.pi / 35.0 / math.sqrt(2), rel=0.25)
    assert total[0, 0] < 0.2 * total[1, 1]
    assert np.trace(rest) < 0.2 * np.trace(total)


def test_calm_water_seen_through_noisy_sensors_is_no_sea() -> None:
    """The default attitude noise (0.2°) alone never passes for a sea's slope statistics."""
    boat = KinematicBoat(dataclasses.replace(paper_sea(0.0), height_m=0.0), 1.0, lambda t: 0.3)
    est = WaveEstimator()
    for sample in motion_samples(boat, 60.0, seed=5, t0=10.0):
        est.observe(sample)
    assert est.spread(explained=False) is None


def test_nan_and_frozen_attitudes_do_not_count_as_observation() -> None:
    est = WaveEstimator()
    for i in range(2 * int(SPREAD_MIN_S / 0.05)):
        att = np.array([np.nan, 0.0, 0.0]) if i % 2 else np.array([0.05, 0.0, 0.0])  # half NaN, half frozen
        est.observe(MotionSample(0.05 * i, att, np.zeros(3), np.zeros(3), np.zeros(3), None))
    assert est.spread(explained=False) is None


def _plan_headings(r: float, spread: np.ndarray | None) -> np.ndarray:
    """Headings (rad) of the planned states from a boat heading 20° East of North at 1 m/s to a waypoint
    60 m North (exactly North would be a stationary point of the symmetric problem)."""
    cfg = NmpcConfig(horizon=40, solver="ipopt", r=r)
    with RollAwareNmpc(cfg, otter_parameters()) as nmpc:
        nmpc.set_wave(None)
        nmpc.set_sea_spread(spread)
        x = np.zeros(12)
        x[5], x[6] = math.radians(20.0), 1.0
        result = nmpc.prepare(x, 0.0, (60.0, 0.0))
        assert result.success, result.status
        return np.asarray(result.states)[:, 5]


def test_expected_roll_turns_the_plan_out_of_beam_seas_only_with_r() -> None:
    plain = _plan_headings(1550.0, None)
    spread = _plan_headings(1550.0, BEAM_SPREAD)
    direct = _plan_headings(0.0, BEAM_SPREAD)
    assert plain[-1] < math.radians(15.0)  # no sea known: turning back onto the waypoint's bearing
    assert spread[-1] > plain[-1] + math.radians(5.0)  # beam seas expected: it stays turned towards head seas
    np.testing.assert_array_equal(direct, _plan_headings(0.0, None))  # R = 0: the term is nothing
