"""The disturbance observer: it learns a current and a yaw moment the model is not told, from the boat's own motion
against the model's prediction, and the NMPC predicts with what it learnt."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mavbridge.nmpc import NmpcConfig, RollAwareNmpc
from mavbridge.nmpc.disturbance import DisturbanceObserver
from vessel import SeaState, World, otter_parameters
from vessel.closed_loop import PropellerPlant, TauPlant


def _fly(world: World, seconds: float, tau_x: float = 50.0, plant_class: type = TauPlant) -> DisturbanceObserver:
    """A slowly weaving boat (τ_X held, τ_N a slow sine) in ``world``, the observer on the published model."""
    plant = plant_class(world, 0.1, 0.01)
    nmpc = RollAwareNmpc(NmpcConfig(solver="rti"), otter_parameters())
    observer = DisturbanceObserver(nmpc)
    t = 0.0
    for _ in range(round(seconds / 0.1)):
        tau = np.array([tau_x, 3.0 * math.sin(0.05 * t)])
        observer.update(t, plant.rigid_state, tau, nmpc.model_wave())
        nmpc.set_disturbance(observer.estimate)
        from vessel import tau_to_shaft_speeds

        plant.advance(t, tau, tau_to_shaft_speeds(otter_parameters(), float(tau[0]), float(tau[1])))
        t = round(t + 0.1, 9)
    np.testing.assert_array_equal(nmpc.disturbance, observer.estimate)  # what it learnt is what the NMPC predicts with
    return observer


@pytest.mark.parametrize("direction_deg", [0.0, 135.0, -90.0])
def test_it_finds_a_current_it_is_not_told_in_calm_water(direction_deg: float) -> None:
    sea = SeaState(height_m=0.0, current_speed_mps=0.5, current_dir_deg=direction_deg)
    observer = _fly(World(sea=sea), 30.0)
    north, east = observer.estimate[0:2]
    truth = 0.5 * math.cos(math.radians(direction_deg)), 0.5 * math.sin(math.radians(direction_deg))
    assert north == pytest.approx(truth[0], abs=0.03) and east == pytest.approx(truth[1], abs=0.03)
    assert observer.settled_at_s is not None and observer.settled_at_s < 20.0
    assert abs(observer.estimate[3]) < 0.5  # no yaw moment where there is none


def test_it_finds_a_weaker_propeller_as_a_yaw_moment_and_stays_near_zero_without_one() -> None:
    calm = SeaState(height_m=0.0)
    weak = World({"base": "published", "propeller_scale": [1.0, 0.85]}, calm)
    observer = _fly(weak, 40.0, tau_x=80.0, plant_class=PropellerPlant)
    # the starboard propeller gives 15 % less of its ~40 N: the hull feels ≈ +0.15·40·0.395 = 2.4 N·m to starboard;
    # the filter, which also weighs a current, puts 60-80 % of it into the yaw moment (measured: 1.3-1.9 N·m)
    truth = 0.15 * 40.0 * 0.395
    assert 0.5 * truth < observer.estimate[3] < 1.5 * truth
    same = _fly(World(sea=calm), 40.0, tau_x=80.0, plant_class=PropellerPlant)
    assert abs(same.estimate[3]) < 0.3 and np.hypot(*same.estimate[0:2]) < 0.05


def test_it_ignores_a_period_it_cannot_compare_and_says_the_estimate() -> None:
    nmpc = RollAwareNmpc(NmpcConfig(solver="rti"), otter_parameters())
    observer = DisturbanceObserver(nmpc)
    x = np.zeros(12)
    observer.update(0.0, x, None, nmpc.model_wave())  # a pilot drives: the next period is not used
    observer.update(0.1, x, np.zeros(2), nmpc.model_wave())
    observer.update(0.5, x, np.zeros(2), nmpc.model_wave())  # a gap of four periods: not compared either
    assert observer.updates == 0
    observer.update(0.6, x, np.zeros(2), nmpc.model_wave())
    assert observer.updates == 1
    assert observer.describe().startswith("current ") and "m/s to" in observer.describe()
    assert "yaw moment" in observer.describe() and "surge force" not in observer.describe()  # (held at 0)
    assert set(observer.row()) == {"dist_current_north_m_s", "dist_current_east_m_s", "dist_surge_force_n",
                                   "dist_yaw_moment_nm", "dist_current_std_m_s"}
