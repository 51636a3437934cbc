"""vessel.world: presets, the one world loader, and the closed-loop plants built from a World."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from vessel import CalmWater, Plant, RegularWaves
from vessel.closed_loop import PropellerPlant, TauPlant, substeps_per_period
from vessel.config import ConfigError
from vessel.sea.state import SeaState, Start
from vessel.world import SCENARIO_SECTIONS, SEA_PRESETS, World, load_world, world_from_mapping, world_preset


def test_presets_are_the_papers_sea_and_calm_water() -> None:
    assert world_preset("paper").sea.waves() == RegularWaves(1.75, 35.0, 6.0, -math.pi / 2)
    assert isinstance(world_preset("calm").sea.waves(), CalmWater)
    assert World() == world_preset("paper") and str(World().vessel) == "published"
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
    for data, message in [({"sae": {}}, "f.yaml: unknown key 'sae'"),
                          ({"vessel": 3}, "f.yaml: vessel: expected one of published"),
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


IRREGULAR = {"spectrum": {"kind": "jonswap", "hs_m": 1.75, "tp_s": 6, "gamma": 3.3, "travel_dir_deg": -90,
                          "spreading_s": None, "n_components": 120}, "seed": 7}


def test_irregular_sea_section_builds_the_irregular_field_and_round_trips() -> None:
    """``sea: {spectrum: {kind, …}, seed}`` -> an IrregularWaves with that seed; to_mapping reads back equal."""
    from vessel.sea.irregular import IrregularWaves

    world = world_from_mapping({"sea": {**IRREGULAR, "current_speed_mps": 0.3}}, "f.yaml")
    sea = world.sea
    assert sea.spectrum is not None and sea.spectrum.seed == 7 and sea.spectrum.spreading_s == 0.0
    waves = sea.waves(world.params())
    assert isinstance(waves, IrregularWaves) and waves.n_components == 120
    other = world_from_mapping({"sea": {**IRREGULAR, "seed": 8}}, "f.yaml").sea.waves()
    assert not np.array_equal(waves.phase_rad, other.phase_rad)
    assert world_from_mapping(world.to_mapping(), "resolved") == world
    assert "jonswap Hs 1.75 m, Tp 6 s" in sea.describe() and "current 0.3 m/s" in sea.describe()
    assert SeaState(spectrum=None) == SEA_PRESETS["paper"]  # the paper's sea is untouched


def test_sea_state_alone_is_a_jonswap_sea_from_table_one() -> None:
    sea = world_from_mapping({"sea": {"sea_state": 4}}, "f.yaml").sea
    assert sea.spectrum is not None and sea.spectrum.sea_state == 4 and sea.spectrum.spectrum == "jonswap"
    assert 1.25 <= sea.spectrum.significant_height_m <= 2.5  # Table I band of sea state 4
    assert isinstance(world_from_mapping({"sea": {"sea_state": 0}}, "f.yaml").sea.waves(), CalmWater)


@pytest.mark.parametrize(("sea", "message"), [
    ({"spectrum": {"hs_m": 0}}, r"f.yaml: sea.spectrum.hs_m: 0 is outside the allowed range \(0, 30\] m"),
    ({"spectrum": {"tp_s": 0.5}}, r"sea.spectrum.tp_s: 0.5 is outside the allowed range \[1, 30\] s"),
    ({"spectrum": {"tp_s": 31}}, r"sea.spectrum.tp_s: 31 is outside the allowed range \[1, 30\] s"),
    ({"spectrum": {"gamma": 0.5}}, r"sea.spectrum.gamma: 0.5 is outside the allowed range \[1, 10\]"),
    ({"spectrum": {"gamma": 11}}, r"sea.spectrum.gamma: 11 is outside the allowed range \[1, 10\]"),
    ({"sea_state": 9}, r"sea.spectrum.sea_state: 9 is outside the allowed range \[0, 8\]"),
    ({"sea_state": -1}, r"sea.spectrum.sea_state: -1 is outside the allowed range \[0, 8\]"),
    ({"spectrum": {"spreading_s": -1}}, r"sea.spectrum.spreading_s: -1 is outside the allowed range >= 0"),
    ({"seed": 1.5}, r"sea.spectrum.seed: expected an integer"),
    ({"seed": "x"}, r"sea.spectrum.seed: expected an integer"),
    ({"spectrum": {"kind": "bretschneider"}}, r"sea.spectrum.spectrum: 'bretschneider' is not one of jonswap, pm"),
    ({"spectrum": {"hsm": 1}}, r"sea.spectrum: unknown key 'hsm'"),
    ({"spectrum": 3}, r"sea.spectrum: expected a mapping"),
    ({"sead": 3}, r"sea: unknown key 'sead'"),
])
def test_bad_irregular_sea_fields_are_one_line_errors(sea: dict, message: str) -> None:
    with pytest.raises(ConfigError, match=message) as info:
        world_from_mapping({"sea": sea}, "f.yaml")
    assert "\n" not in str(info.value)
