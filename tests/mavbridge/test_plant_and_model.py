"""The plant and the controller's model apart: the world's `vessel:` is the boat, `controller.model:` and the
companion's `model:` what the NMPC predicts with; neither reads the other."""

from __future__ import annotations

import io
import socket
from contextlib import redirect_stdout
from pathlib import Path

import pytest
import yaml

from mavbridge.cli import main
from mavbridge.cli.args import single_scenario
from mavbridge.companion.config import load_companion_config
from mavbridge.lab.scenario import Scenario, load_scenarios, scenario_from_mapping
from sim_vehicle.harness import free_port
from vessel import ConfigError, otter_parameters


def test_the_default_model_is_the_published_otter_whatever_the_plant() -> None:
    scenario = scenario_from_mapping({"vessel": {"base": "published", "payload_mass": 60}}, "s.yaml")
    assert scenario.plant_params().payload_mass == 60.0
    assert scenario.model_params() == otter_parameters("published")
    assert Scenario().plant_params() == Scenario().model_params()  # nothing set: Table III's boat and model


def test_controller_model_in_its_three_forms_and_the_resolved_file_round_trips(tmp_path: Path) -> None:
    (tmp_path / "id").mkdir()
    (tmp_path / "id" / "vessel.yaml").write_text("base: published\nzeta_roll: 0.1\n")
    (tmp_path / "runs.yaml").write_text(yaml.safe_dump({
        "base": {"vessel": "corrected", "sea": "calm"},
        "runs": {"named": {"controller": {"model": "corrected"}},
                 "mapping": {"controller": {"model": {"base": "published", "gyration_roll": 0.5}}},
                 "file": {"controller": {"model": "id/vessel.yaml"}}}}, sort_keys=False))
    named, mapping, from_file = load_scenarios(tmp_path / "runs.yaml")
    assert named.model_params() == otter_parameters("corrected")
    assert mapping.model_params().gyration_roll == 0.5 and from_file.model_params().zeta_roll == 0.1
    assert all(s.plant_params() == otter_parameters("corrected") for s in (named, mapping, from_file))
    again = scenario_from_mapping(yaml.safe_load(yaml.safe_dump(from_file.to_mapping())), "resolved")
    assert again.model_params() == from_file.model_params() and again.plant_params() == from_file.plant_params()


def test_a_bad_model_is_one_line_naming_the_file_and_key(tmp_path: Path) -> None:
    path = tmp_path / "s.yaml"
    path.write_text("controller:\n  model: {base: published, zeta_roll: -1}\n")
    with pytest.raises(ConfigError, match=r"s.yaml: controller.model.zeta_roll: -1 is outside the allowed range"):
        load_scenarios(path)


def test_the_companions_model_comes_from_its_own_config_beside_it(tmp_path: Path) -> None:
    (tmp_path / "boat.yaml").write_text("base: published\npayload_mass: 45\n")
    (tmp_path / "companion.yaml").write_text("model: boat.yaml\n")
    config = load_companion_config(tmp_path / "companion.yaml")
    assert config.model is not None and config.model.params().payload_mass == 45.0
    scenario = single_scenario(None, None, config.model)
    assert scenario.model_params().payload_mass == 45.0 and scenario.plant_params().payload_mass == 25.0
    assert load_companion_config(None).model is None  # unset: the scenario's controller.model
    (tmp_path / "bad.yaml").write_text("model: nowhere.yaml\n")
    with pytest.raises(ConfigError, match=r"bad.yaml: model: 'nowhere.yaml' is neither a named set"):
        load_companion_config(tmp_path / "bad.yaml")


def test_check_says_which_model_it_flies(tmp_path: Path) -> None:
    (tmp_path / "boat.yaml").write_text("base: corrected\nzeta_roll: 0.12\n")
    (tmp_path / "companion.yaml").write_text(f"model: {tmp_path / 'boat.yaml'}\n")
    out = io.StringIO()
    with redirect_stdout(out):
        port = free_port(socket.SOCK_DGRAM)
        main(["check", "--config", str(tmp_path / "companion.yaml"), "--connect", f"udpin:127.0.0.1:{port}",
              "--timeout", "0.5", "--solves", "0"])
    line = next(line for line in out.getvalue().splitlines() if line.startswith("model: "))
    assert "corrected with zeta_roll 0.12" in line and "boat.yaml" in line


def test_the_companions_nmpc_is_built_from_its_model_alone_whatever_the_scenarios_boat_and_water() -> None:
    from mavbridge.companion.flight import build_nmpc
    from mavbridge.companion.wave_gate import make_wave_source

    scenario = scenario_from_mapping({"vessel": {"base": "corrected", "payload_mass": 60},
                                      "sea": {"current_speed_mps": 0.5, "current_dir_deg": 90, "wind_speed_mps": 8},
                                      "controller": {"solver": "rti", "model": {"base": "published",
                                                                                "zeta_roll": 0.1}}}, "s.yaml")
    waves = make_wave_source("estimated", scenario.sea.waves, 1.0, 0.0, None)
    with build_nmpc(scenario, waves) as nmpc:
        assert nmpc.params == scenario.model_params() != scenario.plant_params()
        assert nmpc.current.speed_mps == 0.0 and nmpc.wind is None  # never told the water or the air
        assert list(nmpc.disturbance) == [0.0, 0.0, 0.0, 0.0]  # until it learns them
