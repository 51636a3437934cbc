"""vessel.world: presets, the one world loader, and the closed-loop plants built from a World."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from vessel import CalmWater, Plant, RegularWaves
from vessel.closed_loop import PropellerPlant, TauPlant, substeps_per_period
from vessel.config import ConfigError
from vessel.sea_state import SeaState, Start
from vessel.world import SCENARIO_SECTIONS, SEA_PRESETS, World, load_world, world_from_mapping, world_preset


def test_presets_are_the_papers_sea_and_calm_water() -> None:
    assert world_preset("paper").sea.waves() == RegularWaves(1.75, 35.0, 6.0, -math.pi / 2)
    assert isinstance(world_preset("calm").sea.waves(), CalmWater)
    assert World() == world_preset("paper") and World().vessel == "published"
    with pytest.raises(ConfigError, match=r"sea: 'rough' is not one of paper, calm"):
        world_preset("rough")


def test_sea_with_waves_of_keeps_the_current() -> None:
    sea = SeaState(height_m=1.0, current_speed_mps=0.5, current_dir_deg=45.0)
    calm = sea.with_waves_of(SEA_PRESETS["calm"])
    assert calm.height_m == 0.0 and (calm.current_speed_mps, calm.current_dir_deg) == (0.5, 45.0)
    assert "current 0.5 m/s" in calm.describe() and "calm water" in calm.describe()
    assert SEA_PRESETS["paper"].describe().startswith("regular waves H 1.75 m")


def test_world_from_mapping_reads_only_the_world_and_names_fields() -> None:
    world = world_from_mapping({"vessel": "corrected", "sea": "calm", "start": {"heading_deg": 10},
                                "controller": {"q": 1}, "waypoint": {}}, "f.yaml")
    assert world == World("corrected", SEA_PRESETS["calm"], Start(heading_deg=10.0))
    assert world.rigid_state()[5] == pytest.approx(math.radians(10.0)) and world.plant_state().shape == (14,)
    for data, message in [({"sae": {}}, "f.yaml: unknown key 'sae'"), ({"vessel": 3}, "f.yaml: vessel: 3"),
                          ({"sea": {"period_s": 0}}, "f.yaml: sea.period_s"),
                          ({"start": {"colour": 1}}, "f.yaml: start: unknown key 'colour'")]:
        with pytest.raises(ConfigError, match=message):
            world_from_mapping(data, "f.yaml")
    assert "reference" in SCENARIO_SECTIONS and "runs" not in SCENARIO_SECTIONS


def test_load_world_refuses_directories_sets_and_empty_files(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="is a directory"):
        load_world(tmp_path)
    (tmp_path / "set.yaml").write_text("base: {}\nruns: {a: {}}\n")
    with pytest.raises(ConfigError, match="single-run"):
        load_world(tmp_path / "set.yaml")
    (tmp_path / "empty.yaml").write_text("# nothing\n")
    with pytest.raises(ConfigError, match="empty scenario file"):
        load_world(tmp_path / "empty.yaml")


def test_substeps_must_divide_the_period() -> None:
    assert substeps_per_period(0.1, 0.01) == 10
    with pytest.raises(ConfigError, match="plant_dt_s"):
        substeps_per_period(0.1, 0.03)


def test_propeller_plant_is_vessel_plant_in_the_worlds_sea() -> None:
    """Built from a World: the same numbers as a Plant given that world's sea and start by hand."""
    world = World(sea=SeaState(height_m=1.0, current_speed_mps=0.3), start=Start(heading_deg=30.0, surge_mps=1.0))
    closed = PropellerPlant(world, 0.1, 0.01)
    by_hand = Plant(world.params(), world.sea.waves(), world.sea.current(), dt=0.01, x0=world.plant_state())
    for _ in range(5):
        closed.advance(0.0, np.zeros(2), (60.0, 40.0))
        by_hand.advance((60.0, 40.0), 10)
    assert np.array_equal(closed.plant.state, by_hand.state) and closed.shaft_speeds is not None


def test_tau_plant_rolls_in_the_worlds_waves_only() -> None:
    north = Start(heading_deg=0.0)  # the paper's waves travel West: a beam sea for a boat heading North
    calm = TauPlant(World(sea=SEA_PRESETS["calm"], start=north), 0.1, 0.01)
    waves = TauPlant(World(sea=SEA_PRESETS["paper"], start=north), 0.1, 0.01)
    for step in range(20):
        calm.advance(step * 0.1, np.zeros(2), (0.0, 0.0))
        waves.advance(step * 0.1, np.zeros(2), (0.0, 0.0))
    assert calm.rigid_state[3] == 0.0 and calm.rigid_state[7] == 0.0  # no roll, no sway in calm water
    assert abs(waves.rigid_state[3]) > math.radians(0.5)  # the paper's beam sea rolls the boat
    assert calm.shaft_speeds is None
