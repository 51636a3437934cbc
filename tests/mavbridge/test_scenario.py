"""Scenario files: the paper's runs load as specified; bad files fail with one line naming the field."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import yaml

from mavbridge.lab.scenario import Scenario, load_scenarios
from vessel import CalmWater, ConfigError, RegularWaves
from vessel.world import SCENARIO_SECTIONS, SEA_PRESETS, World

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"

GOOD = {
    "name": "ok",
    "sea": {"height_m": 1.0},
    "start": {"north_m": 0.0, "east_m": 0.0, "heading_deg": 90.0},
    "waypoint": {"north_m": 20.0, "east_m": 0.0, "acceptance_radius_m": 2.0},
    "t_max_s": 10.0,
    "controller": {"q": 5, "r": 100, "s": 2, "horizon": 10},
}


def _write(tmp_path: Path, data: object, name: str = "s.yaml") -> Path:
    path = tmp_path / name
    path.write_text(data if isinstance(data, str) else yaml.safe_dump(data), encoding="utf-8")
    return path


def _with(section: str, **changes: object) -> dict:
    data = {k: (dict(v) if isinstance(v, dict) else v) for k, v in GOOD.items()}
    if section:
        data[section].update(changes)
    else:
        data.update(changes)
    return data


def test_table3_defines_the_six_paper_runs() -> None:
    runs = {s.name: s for s in load_scenarios(SCENARIOS / "table3.yaml")}
    expected = {"direct": (5, 0, 2), "indirect": (5, 750, 2), "low_roll": (5, 2500, 2),
                "low_q": (2, 1550, 2), "low_tack": (5, 1000, 2), "balanced": (5, 1550, 2)}
    assert list(runs) == list(expected)
    for name, (q, r, s) in expected.items():
        sc = runs[name]
        assert (sc.controller.q, sc.controller.r, sc.controller.s) == (q, r, s)
        assert (sc.controller.w_dtau_x, sc.controller.w_dtau_n) == (1.0, 1.0)
        assert sc.controller.horizon == 40 and sc.controller.period_s == 0.1
        assert (sc.waypoint.north_m, sc.waypoint.east_m, sc.waypoint.acceptance_radius_m) == (85, 75, 2)
        assert sc.t_max_s == 180.0
        waves = sc.sea.waves()
        assert waves == RegularWaves(1.75, 35.0, 6.0, -math.pi / 2)
        x0 = sc.start.state()
        assert x0[5] == pytest.approx(math.pi / 2) and not any(x0[[0, 1, 6, 7, 11]])
    assert runs["balanced"].reference.time_to_waypoint_s == 97.3
    assert runs["low_q"].reference.time_to_waypoint_s is None


def test_single_scenarios_load() -> None:
    (balanced,) = load_scenarios(SCENARIOS / "balanced.yaml")
    assert balanced.name == "balanced" and balanced.controller.r == 1550
    (calm,) = load_scenarios(SCENARIOS / "calm_short.yaml")
    assert isinstance(calm.sea.waves(), CalmWater)


def test_resolved_scenario_round_trips(tmp_path: Path) -> None:
    (sc,) = load_scenarios(_write(tmp_path, GOOD))
    (again,) = load_scenarios(_write(tmp_path, sc.to_mapping(), "resolved.yaml"))
    assert again == sc


@pytest.mark.parametrize(("data", "field", "detail"), [
    (_with("controller", q=-1.0), "controller.q", "[0, 1e+06]"),
    (_with("controller", r=-5), "controller.r", "[0, 1e+07]"),
    (_with("controller", w_dtau_n=-1), "controller.w_dtau_n", "[0, 1e+06]"),
    (_with("controller", horizon=0), "controller.horizon", "[1, 400]"),
    (_with("controller", horizon=2.5), "controller.horizon", "integer"),
    (_with("controller", solver="fast"), "controller.solver", "ipopt, rti"),
    (_with("waypoint", north_m=1.0), "waypoint", "acceptance radius"),
    (_with("waypoint", east_m=float("nan")), "waypoint.east_m", "allowed range"),
    (_with("sea", period_s=float("inf")), "sea.period_s", "[0.5, 60] s"),
    (_with("start", heading_deg=720), "start.heading_deg", "[-360, 360] deg"),
    (_with("", t_max_s=-1), "t_max_s", "s"),
    (_with("", plant="boat"), "plant", "tau, propellers"),
    (_with("controller", colour="red"), "controller", "unknown key 'colour'"),
    (_with("", extra=1), "", "unknown key 'extra'"),
])
def test_bad_scenarios_are_rejected_naming_the_field(tmp_path: Path, data: dict, field: str,
                                                     detail: str) -> None:
    path = _write(tmp_path, data)
    with pytest.raises(ConfigError) as info:
        load_scenarios(path)
    message = str(info.value)
    assert "\n" not in message
    assert message.startswith(str(path))
    assert field in message
    assert detail in message


def test_bad_run_in_a_set_names_the_run(tmp_path: Path) -> None:
    data = {"base": GOOD, "runs": {"fine": {}, "broken": {"controller": {"s": -2}}}}
    with pytest.raises(ConfigError, match=r"runs\.broken: controller\.s: -2 is outside"):
        load_scenarios(_write(tmp_path, data))
    with pytest.raises(ConfigError, match="unknown key 'runz'"):
        load_scenarios(_write(tmp_path, {"base": GOOD, "runz": {}}))
    with pytest.raises(ConfigError, match="runs: expected a mapping"):
        load_scenarios(_write(tmp_path, {"base": GOOD, "runs": []}))


def test_missing_and_malformed_files(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"nope\.yaml: cannot read file"):
        load_scenarios(tmp_path / "nope.yaml")
    with pytest.raises(ConfigError, match="not valid YAML"):
        load_scenarios(_write(tmp_path, "sea: [unclosed"))
    with pytest.raises(ConfigError, match="expected a mapping"):
        load_scenarios(_write(tmp_path, "- 1\n- 2\n"))
    with pytest.raises(ConfigError, match=r"s\.yaml: empty scenario file"):  # not silently the Balanced run
        load_scenarios(_write(tmp_path, "# only a comment\n"))


def test_scenario_is_the_world_plus_the_companion_sections() -> None:
    """The section names vessel.world knows (and the simulator checks) are this Scenario's, in file order."""
    scenario = Scenario()
    assert scenario.world == World() and scenario.sea is SEA_PRESETS["paper"]
    assert tuple(scenario.to_mapping()) == SCENARIO_SECTIONS


def test_the_waypoint_check_sees_the_files_start(tmp_path: Path) -> None:
    """A waypoint near the default start but far from the file's start is fine; one at the start is not."""
    data = {**GOOD, "start": {"north_m": 50.0}, "waypoint": {"north_m": 0.5, "east_m": 0.0}}
    (sc,) = load_scenarios(_write(tmp_path, data))
    assert sc.start.north_m == 50.0
    with pytest.raises(ConfigError, match="within the acceptance radius"):
        load_scenarios(_write(tmp_path, {**data, "waypoint": {"north_m": 50.5, "east_m": 0.0}}))
