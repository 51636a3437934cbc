"""The irregular wave field: numeric and CasADi evaluations agree, seeds reproduce, the 2-D slope and force
generalise the regular wave, and the hull averaging is the mean of a plane wave over a disc."""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from vessel import Plant, RegularWaves, otter_parameters
from vessel.sea.irregular import IrregularWaves, bessel_j1, hull_averaging_factor
from vessel.sea.irregular_sea import IrregularSea

LONG = IrregularSea(hs_m=1.75, tp_s=6.0, seed=3)
SHORT = IrregularSea(hs_m=1.75, tp_s=6.0, seed=3, spreading_s=4.0)


def _evaluations(waves: IrregularWaves, n: object, e: object, t: object) -> list[object]:
    return [waves.elevation(n, e, t), *waves.slope_angles(n, e, t), *waves.force_per_weight(n, e, t)]


@pytest.mark.parametrize("sea", [LONG, SHORT], ids=["long-crested", "short-crested"])
@pytest.mark.parametrize("hull", [False, True], ids=["point", "hull-averaged"])
def test_casadi_and_numeric_evaluations_agree(sea: IrregularSea, hull: bool) -> None:
    waves = sea.wave_field(otter_parameters() if hull else None)
    x = ca.SX.sym("x", 3)
    symbolic = ca.Function("sea", [x], _evaluations(waves, x[0], x[1], x[2]))
    points = np.random.default_rng(5).uniform([-300, -300, 0], [300, 300, 2000], (200, 3))
    numeric = np.array(_evaluations(waves, points[:, 0], points[:, 1], points[:, 2])).T
    from_casadi = np.array([[float(v) for v in symbolic(p)] for p in points])
    assert np.max(np.abs(numeric)) > 0.01  # a real sea, not zeros
    print(f"max |CasADi - numeric| over 200 points: {np.max(np.abs(from_casadi - numeric)):.1e}")
    np.testing.assert_allclose(from_casadi, numeric, rtol=0, atol=1e-9)
    scalar = _evaluations(waves, float(points[0, 0]), float(points[0, 1]), float(points[0, 2]))
    np.testing.assert_allclose(np.array(scalar, float), numeric[0], rtol=0, atol=1e-12)


def test_same_seed_same_field_other_seed_other_field() -> None:
    t = np.linspace(0, 300, 3001)
    a = IrregularSea(seed=42).wave_field().elevation(10.0, -5.0, t)
    b = IrregularSea(seed=42).wave_field().elevation(10.0, -5.0, t)
    c = IrregularSea(seed=43).wave_field().elevation(10.0, -5.0, t)
    np.testing.assert_array_equal(a, b)
    assert np.corrcoef(a, c)[0, 1] < 0.5


def test_long_and_short_crested_seas_of_one_seed_share_frequencies_and_phases() -> None:
    long, short = LONG.wave_field(), SHORT.wave_field()
    np.testing.assert_array_equal(long.frequency_rad_s, short.frequency_rad_s)
    np.testing.assert_array_equal(long.phase_rad, short.phase_rad)
    assert np.all(long.direction_rad == math.radians(-90))
    assert np.std(short.direction_rad) > 0.2
    bins = np.linspace(0.5, 4.0, long.n_components + 1) * 2 * math.pi / 6.0
    inside = (long.frequency_rad_s >= bins[:-1]) & (long.frequency_rad_s < bins[1:])
    assert inside.all()  # one random frequency inside each bin
    assert len(np.unique(np.round(np.diff(long.frequency_rad_s), 9))) > long.n_components // 2


def test_one_component_is_the_regular_wave() -> None:
    """A single component reproduces RegularWaves: elevation, slope vector and force, any direction."""
    for chi in (-math.pi / 2, 0.7, 2.5):
        regular = RegularWaves(height_m=1.75, length_m=35.0, period_s=6.0, travel_dir_rad=chi)
        single = IrregularWaves(np.array([0.875]), np.array([regular.frequency]), np.array([regular.wavenumber]),
                                np.array([chi]), np.array([-math.pi / 2]), roll_sign=regular.roll_sign)
        pts = np.random.default_rng(1).uniform([-50, -50, 0], [50, 50, 60], (100, 3)).T
        np.testing.assert_allclose(_evaluations(single, *pts), _evaluations(regular, *pts), rtol=0, atol=1e-12)


def test_slope_angle_is_the_arctangent_of_the_gradient_uphill() -> None:
    waves = SHORT.wave_field()
    n, e, t, h = 12.0, -7.0, 33.0, 1e-5
    g_n = (waves.elevation(n + h, e, t) - waves.elevation(n - h, e, t)) / (2 * h)
    g_e = (waves.elevation(n, e + h, t) - waves.elevation(n, e - h, t)) / (2 * h)
    a_n, a_e = waves.slope_angles(n, e, t)
    assert math.hypot(a_n, a_e) == pytest.approx(math.atan(math.hypot(g_n, g_e)), rel=1e-6)
    assert math.atan2(a_e, a_n) == pytest.approx(math.atan2(g_e, g_n), abs=1e-6)
    f_n, f_e = waves.force_per_weight(n, e, t)
    assert f_n * g_n + f_e * g_e < 0  # pushed downhill
    assert math.hypot(f_n, f_e) == pytest.approx(0.5 * math.sin(2 * math.hypot(a_n, a_e)), rel=1e-9)


def test_flat_water_has_finite_slope_and_force() -> None:
    flat = IrregularWaves(np.array([0.0]), np.array([1.0]), np.array([0.1]), np.array([0.0]), np.array([0.0]))
    x = ca.SX.sym("x", 3)
    jac = ca.Function("j", [x], [ca.jacobian(ca.vertcat(*_evaluations(flat, x[0], x[1], x[2])), x)])
    assert np.all(np.isfinite(np.array(jac([1.0, 2.0, 3.0]))))
    assert _evaluations(flat, 1.0, 2.0, 3.0)[1:] == [0.0, 0.0, 0.0, 0.0]


def test_bessel_j1_and_the_disc_average() -> None:
    x = np.array([0.1, 1.0, 3.8317059702, 7.0155866698])
    series = x / 2 - x**3 / 16 + x**5 / 384 - x**7 / 18432 + x**9 / 1474560 - x**11 / 176947200
    assert bessel_j1(x[:2]) == pytest.approx(series[:2], abs=1e-9)
    assert bessel_j1(x[2:]) == pytest.approx([0.0, 0.0], abs=1e-9)  # the first two zeros of J1
    length, beam = 2.0, 1.08
    radius = math.sqrt(length * beam / math.pi)
    rng = np.random.default_rng(2)
    r, phi = radius * np.sqrt(rng.uniform(0, 1, 400_000)), rng.uniform(0, 2 * math.pi, 400_000)
    for k in (0.2, 1.5, 3.0):
        mean_cos = np.mean(np.cos(k * r * np.cos(phi)))  # a plane wave averaged over the disc
        assert hull_averaging_factor(np.array([k]), length, beam)[0] == pytest.approx(mean_cos, abs=5e-3)


def test_hull_averaging_uses_the_vessel_dimensions() -> None:
    params = otter_parameters()
    point, hull = LONG.wave_field(), LONG.wave_field(params)
    factor = hull.amplitude_m / point.amplitude_m
    long_wave = point.wavenumber_rad_m < 0.15
    assert np.all(factor[long_wave] > 0.99) and factor[-1] < 0.8  # long waves kept, short ones damped
    bigger = LONG.wave_field(params.replace(length=4.0))
    assert np.all(bigger.amplitude_m[1:] < hull.amplitude_m[1:])


def test_plant_runs_in_an_irregular_sea_with_surface_heave() -> None:
    """The plant (compiled or not, whichever this machine does) heaves with the hull-averaged surface."""
    params = otter_parameters()
    waves = IrregularSea(hs_m=1.75, tp_s=9.0, n_components=60, seed=1).wave_field(params)
    plant = Plant(params, waves, dt=0.02, surface_heave=True, compile_step=False)
    zs, zetas = [], []
    for _ in range(1500):
        x = plant.step((0.0, 0.0))
        zs.append(x[2])
        zetas.append(waves.elevation(x[0], x[1], plant.time))
    z, zeta = np.array(zs[500:]), np.array(zetas[500:])
    assert np.corrcoef(-z, zeta)[0, 1] > 0.98
    assert np.std(z) == pytest.approx(np.std(zeta), rel=0.1)


@pytest.mark.parametrize("sea", [LONG, SHORT], ids=["long-crested", "short-crested"])
def test_a_later_start_meets_the_waves_the_sea_shows_later(sea: IrregularSea) -> None:
    """``start_s`` (and ``advanced``) move the sea's clock: at t the moved sea shows what the first shows at
    t + start_s, everywhere, in elevation and slope; a zero shift is the same sea."""
    import dataclasses

    first, later = sea.wave_field(otter_parameters()), dataclasses.replace(sea, start_s=1234.5).wave_field(
        otter_parameters())
    points = np.random.default_rng(9).uniform([-200, -200, -50], [200, 200, 300], (100, 3))
    n, e, t = points.T
    assert np.max(np.abs(later.elevation(n, e, t) - first.elevation(n, e, t))) > 0.1  # really another stretch
    np.testing.assert_allclose(later.elevation(n, e, t), first.elevation(n, e, t + 1234.5), atol=1e-9)
    np.testing.assert_allclose(np.array(later.slope_angles(n, e, t)), np.array(first.slope_angles(n, e, t + 1234.5)),
                               atol=1e-9)
    assert first.advanced(0.0) is first
