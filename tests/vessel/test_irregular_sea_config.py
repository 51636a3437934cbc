"""IrregularSea settings: sea-state defaults, validation with one-line errors, YAML loading, the CLI form."""

from __future__ import annotations

import math

import pytest

from vessel import ConfigError, otter_parameters
from vessel.config import from_mapping
from vessel.sea.irregular import IrregularWaves
from vessel.sea.irregular_sea import IrregularSea, parse_sea_spec
from vessel.sea.spectra import nato_sea_state
from vessel.sea.waves import CalmWater


def test_defaults_are_the_papers_height_and_period() -> None:
    sea = IrregularSea()
    assert (sea.significant_height_m, sea.peak_period_s, sea.effective_gamma) == (1.75, 6.0, 3.3)
    assert sea.n_components >= 100
    assert isinstance(sea.wave_field(otter_parameters()), IrregularWaves)


def test_sea_state_fills_height_and_period_unless_given() -> None:
    hs, tp = nato_sea_state(5)
    assert (IrregularSea(sea_state=5).significant_height_m, IrregularSea(sea_state=5).peak_period_s) == (hs, tp)
    given = IrregularSea(sea_state=5, hs_m=3.0, tp_s=8.5)
    assert (given.significant_height_m, given.peak_period_s) == (3.0, 8.5)
    assert isinstance(IrregularSea(sea_state=0).wave_field(), CalmWater)
    assert IrregularSea(sea_state=1, tp_s=3.0).significant_height_m == pytest.approx(0.05)
    with pytest.raises(ConfigError, match=r"tp_s: sea state 1 .*\[1, 30\] s"):
        IrregularSea(sea_state=1)


def test_pierson_moskowitz_ignores_gamma() -> None:
    assert IrregularSea(spectrum="pm", gamma=5.0).effective_gamma == 1.0


@pytest.mark.parametrize(("changes", "words"), [
    ({"hs_m": 0.0}, ["hs_m", "(0, 30] m"]),
    ({"hs_m": -1.0}, ["hs_m", "(0, 30] m"]),
    ({"tp_s": 0.5}, ["tp_s", "[1, 30] s"]),
    ({"tp_s": 31.0}, ["tp_s", "[1, 30] s"]),
    ({"gamma": 0.9}, ["gamma", "[1, 10]"]),
    ({"gamma": 10.5}, ["gamma", "[1, 10]"]),
    ({"sea_state": 9}, ["sea_state", "[0, 8]"]),
    ({"sea_state": -1}, ["sea_state", "[0, 8]"]),
    ({"spreading_s": -0.5}, ["spreading_s", ">= 0"]),
    ({"seed": 1.5}, ["seed", "integer"]),
    ({"seed": "7"}, ["seed", "integer"]),
    ({"seed": True}, ["seed", "integer"]),
    ({"n_components": 5}, ["n_components", "[10, 5000]"]),
    ({"depth_m": 0.1}, ["depth_m", "[0.5, 10000] m"]),
    ({"start_s": 1e6}, ["start_s", "[-86400, 86400] s"]),
    ({"start_s": math.inf}, ["start_s", "[-86400, 86400] s"]),
    ({"hs_m": math.nan}, ["hs_m", "(0, 30] m"]),
    ({"spectrum": "bretschneider"}, ["spectrum", "jonswap, pm"]),
    ({"hs_m": 9.0, "tp_s": 2.0}, ["hs_m", "breaks"]),
])
def test_bad_values_raise_one_line_errors_naming_field_and_range(changes: dict, words: list[str]) -> None:
    with pytest.raises(ConfigError) as info:
        IrregularSea(**changes)
    message = str(info.value)
    assert "\n" not in message
    for word in words:
        assert word in message


def test_yaml_mapping_loads_and_rejects_unknown_keys_and_non_integer_seeds() -> None:
    sea = from_mapping(IrregularSea, {"spectrum": "pm", "hs_m": 2, "tp_s": 8, "seed": 3}, "scenario.yaml: sea")
    assert (sea.spectrum, sea.significant_height_m, sea.seed) == ("pm", 2.0, 3)
    with pytest.raises(ConfigError, match=r"scenario\.yaml: sea: unknown key 'height'"):
        from_mapping(IrregularSea, {"height": 2}, "scenario.yaml: sea")
    with pytest.raises(ConfigError, match=r"scenario.yaml: sea.seed: expected an integer"):
        from_mapping(IrregularSea, {"seed": 2.5}, "scenario.yaml: sea")


def test_cli_form_jonswap_and_pm() -> None:
    sea = parse_sea_spec("jonswap:1.75,6,-90")
    assert (sea.spectrum, sea.hs_m, sea.tp_s, sea.travel_dir_deg, sea.gamma, sea.spreading_s) == (
        "jonswap", 1.75, 6.0, -90.0, 3.3, 0.0)
    full = parse_sea_spec("JONSWAP: 2.5, 9, 45, 2.0, 10", seed=11, n_components=150, depth_m=30.0)
    assert (full.gamma, full.spreading_s, full.seed, full.n_components, full.depth_m) == (2.0, 10.0, 11, 150, 30.0)
    pm = parse_sea_spec("pm:1,5,0")
    assert (pm.spectrum, pm.effective_gamma) == ("pm", 1.0)


@pytest.mark.parametrize(("text", "words"), [
    ("jonswap:0,6,-90", ["--sea HS", "(0, 30] m"]),
    ("jonswap:1.75,0.5,-90", ["--sea TP", "[1, 30] s"]),
    ("jonswap:1.75,6,-90,11", ["--sea GAMMA", "[1, 10]"]),
    ("jonswap:1.75,6,-90,3.3,-1", ["--sea SPREADING", ">= 0"]),
    ("jonswap:1.75,6,400", ["--sea DIR", "[-360, 360] deg"]),
    ("jonswap:abc,6,-90", ["--sea HS", "not a number", "(0, 30] m"]),
    ("jonswap:1.75,6", ["--sea", "jonswap:HS,TP,DIR"]),
    ("pm:1.75,6,-90,3.3", ["--sea", "pm:HS,TP,DIR"]),
    ("ochi:1,6,0", ["--sea", "jonswap:HS,TP,DIR"]),
    ("1.75,35,6,-90", ["--sea", "jonswap:HS,TP,DIR"]),
    ("jonswap:12,3,0", ["--sea", "hs_m", "breaks"]),
])
def test_cli_form_errors_name_the_flag_item_and_range(text: str, words: list[str]) -> None:
    with pytest.raises(ConfigError) as info:
        parse_sea_spec(text)
    message = str(info.value)
    assert "\n" not in message
    for word in words:
        assert word in message, message
