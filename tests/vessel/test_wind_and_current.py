"""Wind on the hull against forces computed by hand, gusts with the variance asked for, and waves on a current."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vessel import ConfigError, OceanCurrent, Plant, SeaState, otter_parameters
from vessel.dynamics import rigid_body_ode
from vessel.sea.irregular_sea import IrregularSea
from vessel.sea.wind import AIR_DENSITY, Wind, gust_components, wind_force


def test_wind_force_matches_the_hand_computed_loads() -> None:
    p = otter_parameters()
    cx, cy, cn = p.wind_coefficients
    wind = Wind(8.0, math.radians(90.0))  # from the East, 8 m/s: the air moves West
    # Heading North at rest: the air comes from starboard, a = (0, -8) in body axes.
    x, y, k, n = (float(v) for v in wind_force(p, wind, 0.0, 0.0, 0.0, 0.0))
    side = 0.5 * AIR_DENSITY * cy * p.wind_area_side * 8.0 * -8.0
    assert x == pytest.approx(0.0, abs=1e-6) and y == pytest.approx(side, rel=1e-6)
    assert k == pytest.approx(p.wind_pressure_height * side, rel=1e-6) and n == pytest.approx(0.0, abs=1e-6)
    # Heading East into it at 2 m/s: a = (-10, 0), a pure drag.
    x, y, _, n = (float(v) for v in wind_force(p, wind, math.pi / 2, 2.0, 0.0, 0.0))
    assert x == pytest.approx(-0.5 * AIR_DENSITY * cx * p.wind_area_front * 100.0, rel=1e-6)
    assert abs(y) < 1e-9 and abs(n) < 1e-9
    # From 45° off the starboard bow: Fossen's ½ρ C_N A_L L V² sin 2γ_rw with γ_rw = −atan2(v_rw, u_rw) = −45°, so
    # with C_N > 0 the bow turns away from the wind (to port, N < 0).
    _, _, _, n = (float(v) for v in wind_force(p, wind, math.radians(45.0), 0.0, 0.0, 0.0))
    gamma_rw = -math.atan2(8.0 / math.sqrt(2), 8.0 / math.sqrt(2))  # the boat's velocity relative to the air
    expected = 0.5 * AIR_DENSITY * cn * p.wind_area_side * p.length * 64.0 * math.sin(2 * gamma_rw)
    assert n == pytest.approx(expected, rel=1e-6) and n < 0


def test_gusts_have_the_standard_deviation_and_the_memory_asked_for_and_are_seeded() -> None:
    wind = Wind(6.0, 0.0, gust_std_mps=1.5, gust_time_s=5.0, seed=3)
    t = np.arange(0.0, 20000.0, 0.5)
    speed = np.asarray(wind.speed_at(t), float)
    assert speed.mean() == pytest.approx(6.0, abs=0.1) and speed.std() == pytest.approx(1.5, rel=0.05)
    gust = speed - speed.mean()
    lag = 10  # 5 s: a first-order process keeps e^-1 of itself one time constant later
    assert np.mean(gust[:-lag] * gust[lag:]) / np.var(gust) == pytest.approx(math.exp(-1), abs=0.08)
    assert np.min(np.asarray(Wind(0.0, 0.0, gust_std_mps=2.0).speed_at(t), float)) == 0.0  # lulls never reverse it
    assert np.array_equal(gust_components(1.5, 5.0, 3)[2], gust_components(1.5, 5.0, 3)[2])
    assert not np.array_equal(gust_components(1.5, 5.0, 3)[2], gust_components(1.5, 5.0, 4)[2])
    assert Wind().calm and SeaState().wind() is None


def test_a_beam_wind_drifts_and_heels_the_boat_in_the_plant() -> None:
    sea = SeaState(height_m=0.0, wind_speed_mps=10.0, wind_from_deg=90.0)  # from the East, boat heading North
    plant = Plant(otter_parameters(), sea.waves(), sea.current(), dt=0.01, wind=sea.wind())
    still = Plant(otter_parameters(), sea.waves(), sea.current(), dt=0.01)  # (the published hull creeps ahead
    plant.advance((0.0, 0.0), 500)  # as it trims at rest: compare with it) 5 s adrift; later the sway couples
    still.advance((0.0, 0.0), 500)  # into yaw and it turns down the wind
    north, east, phi = plant.state[[0, 1, 3]] - still.state[[0, 1, 3]]
    assert east < -0.3 and abs(north) < 0.05 * abs(east) and phi < 0  # pushed West, heeled to port (downwind)
    assert still.state[1] == 0.0 and still.state[3] == 0.0


def test_regular_waves_ride_on_the_current() -> None:
    still = SeaState()
    with_current = SeaState(current_speed_mps=0.5, current_dir_deg=-90.0)  # flowing with the waves (to the West)
    against = SeaState(current_speed_mps=0.5, current_dir_deg=90.0)
    k, omega = 2 * math.pi / 35.0, 2 * math.pi / 6.0
    assert with_current.waves().frequency == pytest.approx(omega + k * 0.5)
    assert against.waves().frequency == pytest.approx(omega - k * 0.5)
    assert with_current.waves().length_m == still.waves().length_m == 35.0
    across = SeaState(current_speed_mps=0.5, current_dir_deg=0.0)
    assert across.waves().frequency == pytest.approx(omega, abs=1e-12)
    # 35 m in 6 s: phase speed 5.8 m/s; against it a current of half that (2.9 m/s) blocks them, 2.8 m/s does not
    with pytest.raises(ConfigError, match=r"sea.current_speed_mps: the current blocks the waves"):
        SeaState(current_speed_mps=35.0 / 12.0, current_dir_deg=90.0).waves()
    assert SeaState(current_speed_mps=2.8, current_dir_deg=90.0).waves().period_s > 6.0


def test_irregular_waves_ride_on_the_current_component_by_component() -> None:
    spectrum = IrregularSea(hs_m=1.0, tp_s=5.0, travel_dir_deg=0.0, n_components=20)
    still = SeaState(spectrum=spectrum).waves()
    moving = SeaState(spectrum=spectrum, current_speed_mps=0.4, current_dir_deg=0.0).waves()
    shift = moving.frequency_rad_s - still.frequency_rad_s
    expected = 0.4 * still.wavenumber_rad_m * np.cos(still.direction_rad)
    assert np.allclose(shift, expected) and np.array_equal(moving.wavenumber_rad_m, still.wavenumber_rad_m)


def test_the_prediction_model_without_wind_is_the_papers() -> None:
    p = otter_parameters()
    x = np.zeros(12)
    x[6] = 1.0
    calm = np.asarray(rigid_body_ode(p, None, OceanCurrent())(x, [10.0, 1.0], 0.0)).ravel()
    still = np.asarray(rigid_body_ode(p, None, OceanCurrent(), wind=None)(x, [10.0, 1.0], 0.0)).ravel()
    windy = np.asarray(rigid_body_ode(p, None, OceanCurrent(), wind=Wind(5.0, 0.0))(x, [10.0, 1.0], 0.0)).ravel()
    assert np.array_equal(calm, still) and windy[6] < calm[6]  # a head wind slows the boat
