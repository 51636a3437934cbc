"""Behaviour of the vessel package: published figures, physics sanity, waves, allocation, plant step."""

from __future__ import annotations

import itertools
import math

import casadi as ca
import numpy as np
import pytest

from tests.vessel.otter_oracle import oracle_xdot
from vessel import (
    CalmWater,
    OceanCurrent,
    Plant,
    RegularWaves,
    otter_parameters,
    plant_ode,
    shaft_speeds_to_tau,
    tau_limits,
    tau_to_shaft_speeds,
)
from vessel.maneuver import PRESETS, Maneuver, maneuver_figures, run_maneuver
from vessel.plant import rk4_step
from vessel.sea.waves import surface_relative_attitude

PUBLISHED = otter_parameters("published")
CORRECTED = otter_parameters("corrected")


def _figures(preset: str, **changes: float) -> dict[str, float]:
    return maneuver_figures(run_maneuver(Maneuver(**{**PRESETS[preset], **changes})))


def test_straight_run_at_70_percent_settles_at_published_speed() -> None:
    figures = _figures("straight")
    assert figures["surge_speed_mps"] == pytest.approx(1.608, rel=0.01)


def test_turning_circle_70_30_settles_at_published_yaw_rate() -> None:
    figures = _figures("turning-circle")
    assert figures["yaw_rate_rad_s"] == pytest.approx(0.172, rel=0.02)
    assert figures["turning_radius_m"] == pytest.approx(5.6, abs=0.2)


def test_free_roll_decay_period_and_decrement() -> None:
    figures = _figures("roll-decay")
    assert figures["roll_damped_period_s"] == pytest.approx(1.0, rel=0.03)
    assert figures["roll_log_decrement"] == pytest.approx(1.5, abs=0.1)


def test_swapping_left_and_right_mirrors_the_turn() -> None:
    a = run_maneuver(Maneuver(left_pct=70, right_pct=30, duration_s=20, roll_deg=3))
    b = run_maneuver(Maneuver(left_pct=30, right_pct=70, duration_s=20, roll_deg=-3))
    mirrored = np.array([1, -1, 1, -1, 1, -1, 1, -1, 1, -1, 1, -1])
    np.testing.assert_allclose(b.x[:, :12], a.x[:, :12] * mirrored, atol=1e-9)
    np.testing.assert_allclose(b.x[:, 12:], a.x[:, 12:][:, ::-1], atol=1e-9)
    assert a.column("r")[-1] > 0.1  # more thrust on the left turns the bow to starboard


def _energy(x: np.ndarray) -> float:
    """Kinetic energy of ν with the full mass matrix plus the hydrostatic potential ½ ηᵀ G η."""
    mats = CORRECTED.matrices()
    eta, nu = x[0:6], x[6:12]
    return 0.5 * nu @ mats.M @ nu + 0.5 * eta @ mats.G @ eta


def test_energy_decays_with_propellers_off_in_calm_water() -> None:
    x0 = np.zeros(14)
    x0[2:12] = [0.05, 0.15, -0.1, 0.3, 1.0, 0.3, 0.2, 0.2, 0.1, 0.2]
    plant = Plant(CORRECTED, x0=x0)
    energies = [_energy(plant.state)]
    for _ in range(20):
        energies.append(_energy(plant.advance((0.0, 0.0), 100)))
    assert energies[-1] < 1e-3 * energies[0]
    assert all(later <= earlier * 1.0001 for earlier, later in itertools.pairwise(energies))


@pytest.mark.parametrize("direction", [-math.pi / 2, 0.3, 2.5])
def test_wave_slope_is_the_derivative_of_the_elevation(direction: float) -> None:
    waves = RegularWaves(travel_dir_rad=direction)
    rng = np.random.default_rng(1)
    h = 1e-5
    for north, east, t in rng.uniform([-50, -50, 0], [50, 50, 100], size=(20, 3)):
        d_north = (waves.elevation(north + h, east, t) - waves.elevation(north - h, east, t)) / (2 * h)
        d_east = (waves.elevation(north, east + h, t) - waves.elevation(north, east - h, t)) / (2 * h)
        alpha_n, alpha_e = waves.slope_angles(north, east, t)
        alpha = waves.slope_along_travel(north, east, t)
        assert math.tan(alpha) == pytest.approx(d_north * math.cos(direction) + d_east * math.sin(direction),
                                                abs=1e-8)
        assert alpha_n == pytest.approx(alpha * math.cos(direction), abs=1e-12)
        assert alpha_e == pytest.approx(alpha * math.sin(direction), abs=1e-12)


def test_paper_waves_match_the_papers_formulas() -> None:
    """f = H/2 sin(2πy/λ + 2πt/T), α = atan(∂f/∂y), β = (φ − α cos ψ, θ − α sin ψ), F_y = −(mg/2) sin 2α."""
    waves = RegularWaves(1.75, 35.0, 6.0, -math.pi / 2)
    east, t, phi, theta, psi = 12.3, 4.2, 0.05, -0.02, 0.8
    phase = 2 * math.pi * east / 35.0 + 2 * math.pi * t / 6.0
    assert waves.elevation(0.0, east, t) == pytest.approx(0.875 * math.sin(phase), abs=1e-12)
    alpha = math.atan(1.75 * math.pi / 35.0 * math.cos(phase))
    _, alpha_e = waves.slope_angles(0.0, east, t)
    assert alpha_e == pytest.approx(alpha, abs=1e-12)
    alpha_n, alpha_e = waves.slope_angles(0.0, east, t)
    beta_phi, beta_theta = surface_relative_attitude(waves, phi, theta, psi, alpha_n, alpha_e)
    assert beta_phi == pytest.approx(phi - alpha * math.cos(psi), abs=1e-12)
    assert beta_theta == pytest.approx(theta - alpha * math.sin(psi), abs=1e-12)
    _, f_east = waves.force_per_weight(0.0, east, t)
    assert f_east == pytest.approx(-0.5 * math.sin(2 * alpha), abs=1e-12)


def test_calm_water_has_no_surface_attitude_and_no_wave_force() -> None:
    calm = CalmWater()
    alpha_n, alpha_e = calm.slope_angles(10.0, -3.0, 7.0)
    assert (alpha_n, alpha_e) == (0.0, 0.0)
    assert surface_relative_attitude(calm, 0.1, -0.2, 1.0, alpha_n, alpha_e) == (0.1, -0.2)
    assert calm.force_per_weight(10.0, -3.0, 7.0) == (0.0, 0.0)
    x = np.zeros(14)
    x[3] = 0.1
    calm_ode = plant_ode(PUBLISHED, CalmWater())
    flat_waves = plant_ode(PUBLISHED, RegularWaves(height_m=0.0))
    np.testing.assert_allclose(np.array(calm_ode(x, [0, 0], 3.0)), np.array(flat_waves(x, [0, 0], 3.0)),
                               atol=1e-12)


def test_allocation_round_trips_within_saturation() -> None:
    forward, reverse, yaw = tau_limits(PUBLISHED)
    assert forward == pytest.approx(2 * 119.68, rel=1e-3) and reverse == pytest.approx(2 * 66.71, rel=1e-3)
    rng = np.random.default_rng(2)
    mats = PUBLISHED.matrices()
    for n_left, n_right in rng.uniform(mats.n_min, mats.n_max, size=(200, 2)):
        tau_x, tau_n = shaft_speeds_to_tau(PUBLISHED, n_left, n_right)
        back = tau_to_shaft_speeds(PUBLISHED, float(tau_x), float(tau_n))
        np.testing.assert_allclose(back, (n_left, n_right), rtol=1e-9, atol=1e-9)
    # Beyond what the propellers can give, the allocation saturates instead of extrapolating.
    left, right = tau_to_shaft_speeds(PUBLISHED, 10 * forward, 0.0)
    assert left == pytest.approx(mats.n_max) and right == pytest.approx(mats.n_max)
    left, right = tau_to_shaft_speeds(PUBLISHED, 0.0, 10 * yaw)
    assert left == pytest.approx(mats.n_max) and right == pytest.approx(mats.n_min)


def test_allocation_uses_the_reverse_coefficient_for_negative_thrust() -> None:
    left, right = tau_to_shaft_speeds(PUBLISHED, -20.0, 0.0)
    assert left == right < 0
    assert float(shaft_speeds_to_tau(PUBLISHED, left, right)[0]) == pytest.approx(-20.0, rel=1e-12)
    with pytest.raises(ValueError, match="tau"):
        tau_to_shaft_speeds(PUBLISHED, math.nan, 0.0)


def _oracle_rk4(x: np.ndarray, n_cmd: np.ndarray, t: float, dt: float, **kwargs: object) -> np.ndarray:
    def f(xx: np.ndarray, tt: float) -> np.ndarray:
        return oracle_xdot(xx, n_cmd, tt, **kwargs)

    k1 = f(x, t)
    k2 = f(x + dt / 2 * k1, t + dt / 2)
    k3 = f(x + dt / 2 * k2, t + dt / 2)
    k4 = f(x + dt * k3, t + dt)
    return x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)


def test_numeric_plant_step_agrees_with_an_independent_rk4_of_the_oracle() -> None:
    rng = np.random.default_rng(3)
    waves = RegularWaves()
    current = OceanCurrent(speed_mps=0.3, direction_rad=0.7)
    plant = Plant(PUBLISHED, waves, current, dt=0.01)
    for _ in range(30):
        x = np.concatenate([rng.uniform(-20, 20, 2), rng.uniform(-0.1, 0.1, 3), rng.uniform(-3, 3, 1),
                            rng.uniform(-1, 2.5, 1), rng.uniform(-0.5, 0.5, 4), rng.uniform(-0.5, 0.5, 1),
                            rng.uniform(-90, 90, 2)])
        n_cmd = rng.uniform(-100, 100, 2)
        t = float(rng.uniform(0, 100))
        plant.reset(x, t)
        got = plant.step(n_cmd).copy()
        want = _oracle_rk4(x, n_cmd, t, 0.01, waves=(1.75, 35.0, 6.0, -math.pi / 2),
                           current_speed=0.3, current_dir=0.7)
        np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-9)
        assert plant.time == pytest.approx(t + 0.01)


def test_plant_step_equals_an_ordinary_call_of_the_symbolic_step() -> None:
    ode = plant_ode(PUBLISHED, RegularWaves())
    step = rk4_step(ode, 0.01)
    x = np.r_[0, 3, 0.01, 0.05, -0.02, 1.2, 1.0, 0.1, 0.0, 0.1, 0.0, 0.05, 50, 60]
    plant = Plant(PUBLISHED, RegularWaves(), x0=x, t0=2.0)
    np.testing.assert_allclose(plant.step((55, 45)), np.array(step(x, [55, 45], 2.0)).ravel(), atol=1e-12)
    assert isinstance(ode, ca.Function)


def test_a_diverging_integration_says_so_and_keeps_the_last_finite_state() -> None:
    plant = Plant(PUBLISHED, RegularWaves(), dt=0.4, integrator="euler")
    with pytest.raises(FloatingPointError, match="non-finite"):
        plant.advance((70.0, 70.0), 2000)
    assert np.all(np.isfinite(plant.state))  # the last finite state is kept


def test_semi_implicit_euler_at_small_step_matches_rk4() -> None:
    a = run_maneuver(Maneuver(left_pct=70, right_pct=30, duration_s=20, dt_s=0.005, integrator="euler"))
    b = run_maneuver(Maneuver(left_pct=70, right_pct=30, duration_s=20, dt_s=0.005, integrator="rk4"))
    np.testing.assert_allclose(a.x[-1, 6:12], b.x[-1, 6:12], atol=0.01)


def test_corrected_set_removes_the_drift_and_the_double_shift() -> None:
    plant = Plant(CORRECTED)
    state = plant.advance((0.0, 0.0), 3000)
    assert abs(state[6]) < 1e-6 and abs(state[2]) < 1e-6  # no payload-induced drift or sinkage
    drifting = Plant(PUBLISHED).advance((0.0, 0.0), 3000)
    assert drifting[6] == pytest.approx(0.083, abs=0.003)
    np.testing.assert_allclose(np.diag(CORRECTED.matrices().M_RB)[3:], [15.53, 21.28, 16.01], atol=0.01)
