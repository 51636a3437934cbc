"""The simulation-only bound on the estimated statistics (``estimation.spread_truth``): the statistics term gets the
sea's true slope covariance wherever the estimator would give its own, and says so in the run's metrics."""

from __future__ import annotations

import copy
import dataclasses
from pathlib import Path

import numpy as np
import pytest

from mavbridge.lab.experiment import run_scenario
from mavbridge.lab.scenario import load_scenarios
from mavbridge.waves import EstimatorSettings, make_estimator
from mavbridge.waves.source import TrueSpread, spread_line
from vessel import ConfigError

ROOT = Path(__file__).resolve().parents[2]


class _Locked:
    """An estimator locked on a wave that explains three quarters of the slope variance it measures."""

    def spread(self, explained: bool) -> np.ndarray:
        whole = np.diag([4e-3, 2e-3])
        return whole / 4 if explained else whole


def test_the_true_covariance_stands_in_only_where_the_estimator_has_one() -> None:
    truth = np.array([[1e-3, 2e-4], [2e-4, 4e-3]])
    source = TrueSpread(make_estimator(EstimatorSettings()), truth)
    assert source.spread(False) is None and source.estimate(0.0) is None  # nothing watched yet: Direct, as before
    assert "simulation" in source.name
    locked = TrueSpread(_Locked(), truth)
    assert np.array_equal(locked.spread(False), truth)
    assert np.allclose(locked.spread(True), truth / 4)  # the wave in use is not counted twice
    assert copy.deepcopy(source).covariance_ned is not None  # (no endless delegation while copying)


def _balanced(**estimation: object) -> object:
    base = {s.name: s for s in load_scenarios(ROOT / "scenarios" / "jonswap_estimated.yaml")}["balanced"]
    est = dataclasses.replace(base.estimation, watch_s=30.0, **estimation)
    return dataclasses.replace(base, estimation=est, t_max_s=15.0,
                               controller=base.controller.replace(solver="nrti"))


def test_a_run_on_the_true_statistics_plans_with_the_seas_covariance() -> None:
    """The line the run says when the statistics become known is the sea's true covariance, and the metrics name
    the source as simulation truth."""
    scenario = _balanced(spread_truth=True)
    lines: list[str] = []
    result = run_scenario(scenario, None, plots=False, progress=lines.append)
    expected = spread_line(scenario.sea.waves().slope_covariance())
    known = [line for line in lines if "sea statistics known" in line]
    assert known and expected in known[0], (expected, known)
    assert "true slope statistics (simulation)" in result.metrics["wave_source"]


def test_true_statistics_need_an_irregular_sea() -> None:
    scenario = load_scenarios(ROOT / "scenarios" / "estimated.yaml")[0]
    scenario = dataclasses.replace(scenario, estimation=dataclasses.replace(scenario.estimation, spread_truth=True),
                                   t_max_s=1.0)
    with pytest.raises(ConfigError, match="spread_truth: needs an irregular sea"):
        run_scenario(scenario, None, plots=False)


@pytest.mark.parametrize("waves", ["truth", "predicted"])
def test_true_statistics_need_the_estimator(waves: str) -> None:
    """With the truth (or the predictor's bank) flying there is no estimator's statistics to replace: refused."""
    from mavbridge.lab.scenario import Estimation

    with pytest.raises(ConfigError, match="spread_truth: needs waves: estimated"):
        Estimation(waves=waves, spread_truth=True)
