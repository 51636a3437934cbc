"""`mavbridge identify` end to end on an Otter API log the test writes of a hull it knows: the figures against
the plant's own (measured by the test on the plant), the outputs and their round trip into the model, bad input."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
import yaml

from mavbridge.cli.main import main
from mavbridge.companion.config import load_companion_config
from mavbridge.identify.model import plant_decay
from mavbridge.lab.scenario import load_scenarios
from tests.mavbridge.field_logs import OTTER_41
from tests.mavbridge.identify_logs import write_identify_log
from vessel import Plant, load_parameters, otter_parameters

HULL = otter_parameters().replace(gyration_roll=0.6, zeta_roll=0.12, max_speed=2.5)


def plant_full_speed() -> float:
    """The hull's steady surge speed at full shaft speed, measured on the plant."""
    plant = Plant(HULL, dt=0.02)
    n = HULL.matrices().n_max
    return float(plant.advance((n, n), 3000)[6])


@pytest.fixture(scope="module")
def identified(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, int]:
    folder = tmp_path_factory.mktemp("identify")
    log = folder / "2024-03-22_12-00-00.csv"
    write_identify_log(log, HULL, 600, seed=3)
    return folder, main(["identify", str(log), "--out", str(folder / "out")])


def test_roll_and_surge_match_the_plant(identified: tuple[Path, int]) -> None:
    folder, code = identified
    assert code == 0
    data = json.loads((folder / "out" / "identify.json").read_text())
    decay = plant_decay(HULL, "roll")
    assert data["roll_period_s"]["value"] == pytest.approx(decay.period_s, rel=0.05)
    assert data["roll_damping_ratio"]["value"] == pytest.approx(decay.zeta, rel=0.3)
    assert data["roll_period_s"]["low"] <= data["roll_period_s"]["value"] <= data["roll_period_s"]["high"]
    assert "free decay" in data["roll_period_s"]["source"]
    assert data["surge_speed_full_forward_m_s"]["value"] == pytest.approx(plant_full_speed(), rel=0.05)
    assert any("reverse" in line for line in data["not_identified"])


def test_vessel_yaml_loads_and_its_model_decays_as_identified(identified: tuple[Path, int]) -> None:
    folder, _ = identified
    mapping = yaml.safe_load((folder / "out" / "vessel.yaml").read_text())
    assert mapping["base"] == "published"
    fields = {k: v for k, v in mapping.items() if k != "base"}
    assert set(fields) <= set(otter_parameters().__dataclass_fields__)
    assert all(getattr(otter_parameters(), k) != v for k, v in fields.items())  # only what changed
    params = load_parameters(folder / "out" / "vessel.yaml")
    assert params == otter_parameters().replace(**fields)
    # The file as the scenario's vessel:, controller.model: and the companion's model: load it, unchanged
    (folder / "run.yaml").write_text("vessel: out/vessel.yaml\ncontroller: {model: out/vessel.yaml}\n")
    (folder / "companion.yaml").write_text("model: out/vessel.yaml\n")
    scenario = load_scenarios(folder / "run.yaml")[0]
    assert scenario.plant_params() == params and scenario.model_params() == params
    assert load_companion_config(folder / "companion.yaml").model.params() == params
    data = json.loads((folder / "out" / "identify.json").read_text())
    measured = plant_decay(params, "roll")
    assert measured.period_s == pytest.approx(data["roll_period_s"]["value"], rel=0.01)
    assert data["model_check"]["roll"]["identified_model"]["period_s"] == pytest.approx(measured.period_s, rel=1e-3)


def test_page_is_self_contained(identified: tuple[Path, int]) -> None:
    folder, _ = identified
    page = (folder / "out" / "identify.html").read_text()
    assert page.count("data:image/png;base64,") >= 3
    assert "http" not in page.replace("http-equiv", "") and "<script" not in page


def test_an_existing_output_is_never_overwritten(identified: tuple[Path, int], capsys: pytest.CaptureFixture) -> None:
    folder, _ = identified
    before = (folder / "out" / "identify.json").read_bytes()
    code = main(["identify", str(folder / "2024-03-22_12-00-00.csv"), "--out", str(folder / "out")])
    assert code == 2
    assert "already holds" in capsys.readouterr().err
    assert (folder / "out" / "identify.json").read_bytes() == before


def test_a_log_that_identifies_nothing_is_one_line_and_exit_2(tmp_path: Path,
                                                              capsys: pytest.CaptureFixture) -> None:
    log = tmp_path / "short.csv"
    write_identify_log(log, HULL, 20, seed=4, kick_deg=0.0)
    blank = {OTTER_41.index("n1") + 1, OTTER_41.index("n2") + 1}  # no command: nothing but 20 s of attitude ...
    zero = {OTTER_41.index(f"current_rotational_velocities_{k}") + 1 for k in (1, 2, 3)}  # ... its rates all zero
    lines = log.read_text().splitlines()  # (the hull's start pitches it 4.6°/s: a decay in the pitch rate)
    rows = [";".join("" if n in blank else "0.000" if n in zero else c for n, c in enumerate(line.split(";")))
            for line in lines[1:]]
    log.write_text("\n".join([lines[0], *rows]) + "\n")
    code = main(["identify", str(log), "--out", str(tmp_path / "out")])
    captured = capsys.readouterr()
    assert code == 2
    assert "nothing identifiable" in captured.err and len(captured.err.strip().splitlines()) == 1
    assert "Traceback" not in captured.out + captured.err
    assert not (tmp_path / "out").exists()


def test_spreadsheet_mangled_numbers_do_not_crash(tmp_path: Path) -> None:
    log = tmp_path / "mangled.csv"
    write_identify_log(log, HULL, 120, seed=5)
    lines = log.read_text().splitlines()
    roll_rate = OTTER_41.index("current_rotational_velocities_1") + 1
    lines[5] = lines[5].replace(";0.0;", ";04.feb;", 1)
    lines[9] = ";".join(c if n != roll_rate else "jan.68" for n, c in enumerate(lines[9].split(";")))
    log.write_text("\n".join(lines) + "\n")
    assert main(["identify", str(log), "--out", str(tmp_path / "out")]) == 0
    assert math.isfinite(json.loads((tmp_path / "out" / "identify.json").read_text())["roll_period_s"]["value"])
