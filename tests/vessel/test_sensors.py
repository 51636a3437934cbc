"""The SITL-style sensor model: noise levels, ideal readings, lags and the GPS rate as configured."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vessel.config import ConfigError
from vessel.sensors import (
    GRAVITY,
    SensorModel,
    SensorParams,
    body_velocity_from_ned,
    ned_velocity_from_body,
    rotation_body_to_ned,
    specific_force_from_acceleration,
)

DT = 0.05  # 20 Hz, the ATTITUDE rate the companion asks for


def _run_at_rest(params: SensorParams, seconds: float, seed: int = 3) -> list:
    """Readings of a boat at rest, level, heading 30°, at 20 Hz."""
    model = SensorModel(params, np.random.default_rng(seed))
    eta = np.array([1.0, 2.0, 0.0, 0.0, 0.0, math.radians(30)])
    nu = np.zeros(6)
    f = specific_force_from_acceleration(np.zeros(3), eta[3:6])
    return [model.sample(k * DT, eta, nu, f) for k in range(int(seconds / DT))]


def test_specific_force_at_rest_level_is_minus_g_down() -> None:
    f = specific_force_from_acceleration(np.zeros(3), np.array([0.0, 0.0, 1.2]))
    assert np.allclose(f, [0.0, 0.0, -GRAVITY])
    tilted = specific_force_from_acceleration(np.zeros(3), np.array([0.1, 0.0, 0.0]))
    assert tilted[1] == pytest.approx(-GRAVITY * math.sin(0.1))  # gravity leaks into y when rolled


def test_noise_std_matches_configuration_within_20_percent() -> None:
    params = SensorParams()
    readings = _run_at_rest(params, 60.0)
    roll = np.array([r.attitude[0] for r in readings])
    yaw = np.array([r.attitude[2] for r in readings]) - math.radians(30)
    gyro = np.array([r.rates for r in readings])
    accel = np.array([r.accel_body for r in readings]) - np.array([0.0, 0.0, -GRAVITY])
    fixes = [r for r in readings if r.gps_fresh]
    pos = np.array([r.position_ned for r in fixes]) - np.array([1.0, 2.0, 0.0])
    vel = np.array([r.velocity_ned for r in fixes])
    checks = {
        "roll": (np.std(roll), math.radians(params.att_noise_deg)),
        "yaw": (np.std(yaw), math.radians(params.att_noise_deg)),
        "gyro": (np.std(gyro), math.radians(params.gyro_noise_dps)),
        "accel": (np.std(accel), params.accel_noise_mps2),
        "gps north/east": (np.std(pos[:, 0:2]), params.gps_hpos_noise_m),
        "gps down": (np.std(pos[:, 2]), params.gps_vpos_noise_m),
        "gps velocity": (np.std(vel), params.gps_vel_noise_mps),
    }
    for name, (measured, configured) in checks.items():
        assert configured > 0, name
        assert abs(measured / configured - 1) < 0.2, f"{name}: std {measured:.4g} vs configured {configured:.4g}"


def test_ideal_sensors_give_exact_values() -> None:
    model = SensorModel(SensorParams.ideal(), np.random.default_rng(1))
    rng = np.random.default_rng(2)
    for k in range(50):
        eta = rng.normal(0, 0.3, 6)
        nu = rng.normal(0, 0.5, 6)
        f = rng.normal(0, 3, 3)
        r = model.sample(k * 0.01, eta, nu, f)
        assert np.array_equal(r.attitude[0:2], eta[3:5])
        assert r.attitude[2] == pytest.approx(eta[5], abs=1e-15)
        assert np.array_equal(r.rates, nu[3:6])
        assert np.array_equal(r.position_ned, eta[0:3])
        R = rotation_body_to_ned(*eta[3:6])
        assert np.allclose(r.velocity_ned, R @ nu[0:3], atol=1e-14)
        assert np.array_equal(r.accel_body, f)
        assert r.gps_fresh


def test_gps_rate_and_lag_as_configured() -> None:
    params = SensorParams.ideal().with_(gps_hz=5.0, gps_lag_ms=150.0, att_lag_ms=40.0)
    model = SensorModel(params, np.random.default_rng(0))
    speed = 2.0  # m/s north, and a roll ramp of 0.1 rad/s, so lags show as offsets
    readings = []
    for k in range(int(10.0 / 0.01)):
        t = k * 0.01
        eta = np.array([speed * t, 0.0, 0.0, 0.1 * t, 0.0, 0.0])
        nu = np.array([speed, 0.0, 0.0, 0.1, 0.0, 0.0])
        readings.append(model.sample(t, eta, nu, None))
    fresh = [r for r in readings if r.gps_fresh]
    assert len(fresh) == pytest.approx(10.0 * params.gps_hz, abs=1)
    gaps = np.diff([r.t_s for r in fresh])
    assert np.allclose(gaps, 1 / params.gps_hz, atol=0.011)
    late = [r for r in readings if r.t_s > 1.0]
    for r in late:
        assert r.t_s - r.gps_fix_time_s >= params.gps_lag_ms / 1000 - 1e-9
        assert r.position_ned[0] == pytest.approx(speed * r.gps_fix_time_s, abs=1e-9)
        assert r.attitude[0] == pytest.approx(0.1 * (r.t_s - params.att_lag_ms / 1000), abs=1e-9)
        assert r.accel_body is None
    held = [r.t_s - r.gps_fix_time_s for r in late]
    assert max(held) == pytest.approx(params.gps_lag_ms / 1000 + 1 / params.gps_hz - 0.01, abs=0.011)


def test_bad_parameter_names_the_field() -> None:
    with pytest.raises(ConfigError, match="gps_hz"):
        SensorParams(gps_hz=-1.0)


def test_the_float_rotations_are_the_matrix_and_its_transpose() -> None:
    """The control step's plain-float rotations (state vector, the hull on its mean surface) against the matrix."""
    rng = np.random.default_rng(11)
    for _ in range(200):
        phi, theta, psi = rng.uniform(-math.pi, math.pi, 3)
        vec = rng.normal(0.0, 3.0, 3)
        R = rotation_body_to_ned(phi, theta, psi)
        assert np.allclose(ned_velocity_from_body(phi, theta, psi, *vec), R @ vec, rtol=0.0, atol=1e-12)
        assert np.allclose(body_velocity_from_ned(phi, theta, psi, *vec), R.T @ vec, rtol=0.0, atol=1e-12)
