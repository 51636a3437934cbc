"""A realistic run that reuses a watch of its process (``mavbridge.lab.watch``) flies exactly the run that watches.

Real plant, sensors, estimator, disturbance observer and solver; no mocks. Each pair of runs below is flown once
reusing the watch a run with other weights left, once with the reuse off (``MAVBRIDGE_WATCH_CACHE=0``: the watch
flown afresh): every metric but the machine's timings and every row of the time series must be equal.
"""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from mavbridge.lab.experiment import run_scenario
from mavbridge.lab.scenario import Scenario, scenario_from_mapping
from mavbridge.lab.watch import ENVIRONMENT, WATCHES, watch_key

SHORT = {  # the paper's sea on the estimate, hull heaving, hidden phase, default sensors, the observer; 20 s watched
    "start": {"heading_deg": 90.0, "surge_mps": 1.5},
    "waypoint": {"north_m": 0.0, "east_m": 300.0},
    "t_max_s": 4.0,
    "controller": {"q": 5, "r": 1550, "s": 2, "horizon": 10, "solver": "nrti"},
    "estimation": {"waves": "estimated", "surface_heave": True, "hidden_phase": True, "seed": 5, "calibrate": False,
                   "watch_s": 20.0},
}
NATO_SS3 = {"spectrum": {"kind": "jonswap", "sea_state": 3, "travel_dir_deg": -90.0, "paper_roll_sign": True},
            "seed": 1}
SEAS = {  # case -> changes to SHORT
    "paper-sea": {},
    "nato-ss3": {"sea": NATO_SS3},
    "nato-ss3-predicted": {"sea": NATO_SS3, "estimation": {"waves": "predicted"}, "controller": {"wave_components": 4}},
}


def _scenario(name: str, **changes: Any) -> Scenario:
    data = {**SHORT, "controller": {**SHORT["controller"]}, "estimation": {**SHORT["estimation"]}}
    for section, values in changes.items():
        data[section] = {**data.get(section, {}), **values}
    return scenario_from_mapping(data, "test", name)


def _case(name: str, case: str, **more: dict[str, Any]) -> Scenario:
    changes = {section: dict(values) for section, values in SEAS[case].items()}
    for section, values in more.items():
        changes[section] = {**changes.get(section, {}), **values}
    return _scenario(name, **changes)


def _timing(key: str) -> bool:
    """The machine's timings (wall, solve and estimator milliseconds), not the run's."""
    return "_ms" in key or "wall" in key


def _figures(metrics: dict[str, Any]) -> dict[str, Any]:
    return {key: (_figures(value) if isinstance(value, dict) else value)
            for key, value in metrics.items() if not _timing(key)}


def _flown(scenario: Scenario, out: Path) -> tuple[dict[str, Any], list[dict[str, str]]]:
    """The run's figures and its time series' rows (timings left out)."""
    metrics = run_scenario(scenario, out, plots=False).metrics
    with (out / "timeseries.csv").open(encoding="utf-8") as handle:
        rows = [{k: v for k, v in row.items() if not _timing(k)} for row in csv.DictReader(handle)]
    return _figures(metrics), rows


def test_the_key_leaves_out_only_the_name_and_the_weights() -> None:
    base = _scenario("a")
    assert watch_key(_scenario("b", controller={"q": 8, "r": 25600, "s": 4})) == watch_key(base)
    for changes in ({"estimation": {"seed": 6}}, {"estimation": {"watch_s": 4.0}}, {"start": {"heading_deg": 60.0}},
                    {"controller": {"horizon": 12}}, {"estimation": {"sensors": "ideal"}},
                    {"estimation": {"disturbance": "none"}}):
        assert watch_key(_scenario("c", **changes)) != watch_key(base), changes


@pytest.mark.parametrize("case", SEAS)
def test_a_run_after_another_with_the_same_watch_flies_as_if_it_watched(tmp_path: Path, case: str,
                                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    WATCHES.clear()
    monkeypatch.delenv(ENVIRONMENT, raising=False)
    run_scenario(_case("first", case, controller={"r": 0.0, "q": 8}), None, plots=False)  # watches, keeps the watch
    hits = WATCHES.hits
    reused = _flown(_case("second", case), tmp_path / "reused")
    assert WATCHES.hits == hits + 1
    monkeypatch.setenv(ENVIRONMENT, "0")
    fresh = _flown(_case("second", case), tmp_path / "fresh")
    assert WATCHES.hits == hits + 1  # (off: not even looked at)
    assert reused[0] == fresh[0]
    assert len(reused[1]) == 41 and reused[1] == fresh[1]
    # the watch mattered: the observer and the estimator had learnt from it before the run's first row
    assert float(fresh[1][0]["dist_current_std_m_s"]) < 0.5 and fresh[1][0]["wave_height_m"] != ""


def test_a_run_on_another_sea_seed_watches_afresh(monkeypatch: pytest.MonkeyPatch) -> None:
    WATCHES.clear()
    monkeypatch.delenv(ENVIRONMENT, raising=False)
    run_scenario(_scenario("seed5"), None, plots=False)
    other = run_scenario(_scenario("seed6", estimation={"seed": 6}), None, plots=False).metrics
    assert WATCHES.hits == 0
    again = run_scenario(_scenario("seed6-again", estimation={"seed": 6}), None, plots=False).metrics
    assert WATCHES.hits == 1 and _figures(again) == {**_figures(other), "name": "seed6-again"}


def test_an_estimator_copied_in_the_middle_of_a_fit_goes_on_as_the_original() -> None:
    """A fit in progress is a generator, which cannot be copied: the copy makes its stages again (``AheadJob``) and
    must then give what the original gives, sample by sample, through the end of that fit and the next ones."""
    import copy

    from mavbridge.lab.sensed_plant import SensedPlant
    from mavbridge.waves import EstimatorSettings, WindowEstimator
    from mavbridge.waves.inloop import sensor_model

    class Samples:
        def __init__(self) -> None:
            self.got: list[Any] = []

        def observe(self, sample: Any) -> None:
            self.got.append(sample)

    scenario = _scenario("samples")
    samples = Samples()
    plant = SensedPlant(scenario.plant_params(), scenario.sea.waves(), scenario.sea.current(),
                        scenario.world.rigid_state(), 0.1, 0.01, True, sensor_model("default", 5), samples)
    plant.watch(30.0, 0.1)
    original = WindowEstimator(EstimatorSettings())
    rest = iter(samples.got)
    for sample in rest:
        original.observe(sample)
        job = original._job
        if job is not None and job._worked >= 2 and original.fits >= 1:  # in the middle of a fit, not the first
            break
    twin = copy.deepcopy(original)
    fits = original.fits
    for sample in rest:
        original.observe(sample)
        twin.observe(sample)
        mine, its = original.latest(sample.t_s), twin.latest(sample.t_s)
        assert (mine.row() if mine else None) == (its.row() if its else None), sample.t_s
        spread, its_spread = original.spread(False), twin.spread(False)
        assert (spread is None and its_spread is None) or np.array_equal(spread, its_spread)
    assert twin.fits == original.fits > fits + 1
