"""A vessel in its three forms (a named set, a mapping, a file), for the plant and for the controller's model."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from vessel import ConfigError, Plant, otter_parameters
from vessel.allocation import shaft_speeds_to_tau, tau_limits, tau_to_shaft_speeds
from vessel.vessel_spec import VesselSpec, load_vessel, relative_to
from vessel.world import World, load_world, world_from_mapping


def test_a_named_set_a_mapping_and_a_file_give_the_same_boat(tmp_path: Path) -> None:
    named = load_vessel("corrected")
    assert named.named and named.params() == otter_parameters("corrected") and str(named) == "corrected"
    mapping = load_vessel({"base": "corrected", "payload_mass": 60.0, "propeller_scale": [1.0, 0.85]})
    assert mapping.params().payload_mass == 60.0 and mapping.params().propeller_scale == (1.0, 0.85)
    assert mapping.params().inertia_double_shift is False  # the base's own settings stay
    (tmp_path / "boat.yaml").write_text(yaml.safe_dump(mapping.to_config()))
    from_file = load_vessel(str(tmp_path / "boat.yaml"))
    assert from_file == mapping and from_file.params() == mapping.params()
    assert "from " in str(from_file) and "payload_mass 60" in str(from_file)
    assert load_vessel(mapping.to_config()) == mapping and named.to_config() == "corrected"


@pytest.mark.parametrize(("value", "message"), [
    ("titanic", r"vessel: 'titanic' is neither a named set \(published, corrected\) nor a readable vessel file"),
    ({"base": "fast"}, r"vessel.base: 'fast' is not one of published, corrected"),
    ({"payload_mas": 3}, r"vessel: unknown key 'payload_mas'"),
    ({"payload_mass": -1}, r"vessel.payload_mass: -1 is outside the allowed range \[0, 1000\] kg"),
    ({"propeller_scale": [1.0]}, r"vessel.propeller_scale: expected a list of 2 numbers"),
    ({"propeller_scale": [1.0, 3.0]}, r"vessel.propeller_scale\[1\]: 3.0 is outside the allowed range \[0.1, 2\]"),
    ({"zeta_roll": "high"}, r"vessel.zeta_roll: expected a number"),
    (7, r"vessel: expected one of published, corrected, a mapping"),
])
def test_bad_vessels_are_one_line_naming_the_key(value: object, message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        load_vessel(value)


def test_a_vessel_file_is_found_beside_the_scenario_that_names_it(tmp_path: Path) -> None:
    (tmp_path / "boats").mkdir()
    (tmp_path / "boats" / "heavy.yaml").write_text("base: published\npayload_mass: 45\n")
    (tmp_path / "run.yaml").write_text("vessel: boats/heavy.yaml\nsea: calm\n")
    world = load_world(tmp_path / "run.yaml")
    assert world.params().payload_mass == 45.0 and world.vessel.source.endswith("heavy.yaml")
    (tmp_path / "boats" / "bad.yaml").write_text("base: published\nzeta_roll: 9\n")
    with pytest.raises(ConfigError, match=r"bad.yaml.zeta_roll: 9 is outside the allowed range \[0, 2\]"), \
            relative_to(tmp_path / "run.yaml"):
        world_from_mapping({"vessel": "boats/bad.yaml"}, "run.yaml")


def test_world_round_trips_its_vessel_mapping() -> None:
    world = World({"base": "published", "zeta_roll": 0.08})
    again = world_from_mapping(world.to_mapping(), "resolved")
    assert again == world and again.params().zeta_roll == 0.08


def test_propeller_scale_scales_each_thrust_and_the_allocation_asks_the_weaker_one_for_more() -> None:
    base = otter_parameters("published")
    weak = base.replace(propeller_scale=(1.0, 0.85))
    n = 80.0  # rad/s, below saturation
    thrust = base.thrust_coeff_forward * n * n  # hand: k_pos n|n| per propeller
    tau_x, tau_n = shaft_speeds_to_tau(weak, n, n)
    assert float(tau_x) == pytest.approx(1.85 * thrust, rel=1e-12)
    assert float(tau_n) == pytest.approx(base.pontoon_offset * 0.15 * thrust, rel=1e-12)  # the port one pushes more
    left, right = tau_to_shaft_speeds(weak, 100.0, 0.0)
    x_back, n_back = shaft_speeds_to_tau(weak, left, right)
    assert float(x_back) == pytest.approx(100.0, rel=1e-9) and float(n_back) == pytest.approx(0.0, abs=1e-9)
    assert right > left and tau_limits(weak)[0] == pytest.approx(0.925 * tau_limits(base)[0])


def test_a_throttle_map_that_saturates_higher_lets_the_shafts_turn_faster() -> None:
    base = otter_parameters("published")
    fast = base.replace(shaft_speed_limit_rpm=1240.0)
    assert base.matrices().n_max * 30 / math.pi == pytest.approx(992.0, abs=1.0)
    assert fast.matrices().n_max == pytest.approx(1240.0 * math.pi / 30.0)
    assert fast.matrices().n_min / base.matrices().n_min == pytest.approx(fast.matrices().n_max / base.matrices().n_max)


def test_one_weaker_propeller_turns_the_boat_towards_it() -> None:
    spec = VesselSpec("published", (("propeller_scale", (1.0, 0.8)),))
    plant = Plant(spec.params(), dt=0.01)
    n = otter_parameters().matrices().n_max * 0.8
    plant.advance((n, n), 1000)  # 10 s, both shafts alike
    assert plant.state[11] > 0.02  # yaw rate to starboard: the starboard propeller pushes less
    straight = Plant(otter_parameters(), dt=0.01)
    straight.advance((n, n), 1000)
    assert abs(straight.state[11]) < 1e-9 and np.hypot(*straight.state[6:8]) > np.hypot(*plant.state[6:8])
