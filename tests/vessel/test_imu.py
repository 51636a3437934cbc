"""The ideal IMU: specific force from the model's ν̇ and body rates, checked against independent physics."""

from __future__ import annotations

import numpy as np
import pytest

from vessel import CalmWater, OceanCurrent, Plant, RegularWaves, otter_parameters
from vessel.dynamics import rotation_body_to_ned
from vessel.imu import ImuModel, gravity_body, specific_force, specific_force_body


def _rotation(x: np.ndarray) -> np.ndarray:
    """Body-to-NED rotation of the state's Euler angles, as numbers."""
    return np.asarray(rotation_body_to_ned(x[3], x[4], x[5]), float)


def _ned_velocity(x: np.ndarray) -> np.ndarray:
    return _rotation(x) @ x[6:9]


def test_level_at_rest_in_calm_water_reads_minus_g() -> None:
    """The corrected Otter floats level at x = 0: the accelerometer reads (0, 0, −g), the gyro zero."""
    params = otter_parameters("corrected")
    imu = ImuModel(params, CalmWater())
    accel, gyro = imu.measure(np.zeros(14), 0.0)
    np.testing.assert_allclose(accel, [0.0, 0.0, -9.81], atol=1e-6)
    np.testing.assert_allclose(gyro, 0.0, atol=0.0)
    np.testing.assert_allclose(specific_force_body(params, np.zeros(14)), accel, atol=1e-12)


def test_published_trim_reads_gravity_in_the_pitched_body() -> None:
    """Fossen's published set settles nose-down (payload term): at rest the IMU sees only tilted gravity."""
    params = otter_parameters("published")
    plant = Plant(params, CalmWater(), dt=0.01)
    plant.advance((0.0, 0.0), 20_000)
    x = plant.state
    assert abs(x[4]) > 0.01  # a real trim, or this test would repeat the level one
    accel, _ = ImuModel.for_plant(plant).measure(x, plant.time)
    expected = -np.array(gravity_body(x[3], x[4], params.g))
    np.testing.assert_allclose(accel, expected, atol=1e-6)
    assert np.linalg.norm(accel) == pytest.approx(params.g, abs=1e-6)


def test_steady_turn_gives_the_centripetal_term_in_sway() -> None:
    """70 % / 30 % thrust for 120 s: a steady turn where f_y + g_y is the centripetal u·r (ν̇ ≈ 0).

    The −p·w part of (ω × v)_y is second order in the trim pitch (p = −sin θ·ψ̇, w ≈ u·tan θ) and kept.
    """
    params = otter_parameters("published")
    n_max = params.matrices().n_max
    plant = Plant(params, CalmWater(), dt=0.01)
    command = (0.7 * n_max, 0.3 * n_max)
    plant.advance(command, 12_000)
    before = plant.state
    plant.step(command)
    x = plant.state
    assert np.max(np.abs(x[6:12] - before[6:12])) < 1e-7  # steady
    accel, gyro = ImuModel.for_plant(plant).measure(x, plant.time)
    u, w, p, r = x[6], x[8], x[9], x[11]
    assert abs(u * r) > 0.05  # a real turn, not a drift
    assert abs(p * w) < 1e-3 * abs(u * r)
    g_y = gravity_body(x[3], x[4], params.g)[1]
    assert accel[1] + g_y == pytest.approx(u * r - p * w, rel=1e-5)
    np.testing.assert_array_equal(gyro, x[9:12])


@pytest.mark.parametrize(
    "waves, current",
    [(CalmWater(), OceanCurrent()), (RegularWaves(), OceanCurrent(0.5, 1.0))],
    ids=["calm", "paper-waves-and-current"],
)
def test_specific_force_matches_finite_differences_of_ned_velocity(waves: object, current: OceanCurrent) -> None:
    """Independent check: f = Rᵀ(dv_NED/dt − g_NED), with dv/dt a central difference of the plant's motion."""
    params = otter_parameters("published")
    n_max = params.matrices().n_max
    dt = 1e-3
    plant = Plant(params, waves, current, dt=dt)  # type: ignore[arg-type]
    command = (0.8 * n_max, 0.2 * n_max)
    plant.advance(command, 5_000)  # turning through the waves, rolling and pitching
    imu = ImuModel.for_plant(plant)
    errors = []
    for _ in range(20):
        x_prev = plant.state
        plant.step(command)
        x, t = plant.state, plant.time
        plant.step(command)
        x_next = plant.state
        a_ned = (_ned_velocity(x_next) - _ned_velocity(x_prev)) / (2 * dt)
        expected = _rotation(x).T @ (a_ned - np.array([0.0, 0.0, params.g]))
        accel, _ = imu.measure(x, t)
        errors.append(np.max(np.abs(accel - expected)))
        plant.advance(command, 50)
    assert max(errors) < 1e-4


def test_gyro_equals_body_rates_in_the_paper_waves() -> None:
    """In the paper's sea the boat rolls and pitches; the gyro reports the plant's p, q, r exactly."""
    params = otter_parameters("published")
    plant = Plant(params, RegularWaves(), dt=0.01)
    imu = ImuModel.for_plant(plant)
    command = (0.7 * params.matrices().n_max,) * 2
    peak = 0.0
    for _ in range(1_000):
        x = plant.step(command)
        _, gyro = imu.measure(x, plant.time)
        np.testing.assert_array_equal(gyro, x[9:12])
        peak = max(peak, abs(x[9]))
    assert peak > 0.05  # the waves really do roll the boat


def test_symbolic_and_numeric_formula_agree() -> None:
    """The one formula serves numpy and CasADi: same numbers both ways."""
    import casadi as ca

    nu = np.array([1.2, -0.3, 0.05, 0.1, -0.02, 0.3])
    nu_dot = np.array([0.4, 0.1, -0.2, 0.0, 0.0, 0.0])
    numeric = specific_force(nu, nu_dot, 0.1, -0.05, 9.81)
    symbolic = ca.Function("f", [], [specific_force(ca.DM(nu), ca.DM(nu_dot), ca.DM(0.1), ca.DM(-0.05), 9.81)])
    np.testing.assert_allclose(np.asarray(symbolic()["o0"], float).ravel(), numeric, atol=1e-15)
