"""The NMPC's phase-resolved wave bank (``nmpc.wave_bank``): the model matches the simulator's irregular sea when
given its components, K = 0 leaves the problem as it was, and the bank reaches the solve."""

from __future__ import annotations

import csv
import dataclasses
import math
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from mavbridge.nmpc import PARAMS, NmpcConfig, RollAwareNmpc
from mavbridge.nmpc.functions import problem_functions
from mavbridge.nmpc.layout import bank_size, parameter_layout, wave_input_size
from mavbridge.nmpc.problem import NO_DISTURBANCE, discrete_model, pack_parameters
from mavbridge.nmpc.wave_bank import ParametricSea, bank_parameters, no_bank
from mavbridge.nmpc.wave_model import CALM_PARAMETERS
from vessel import OceanCurrent, otter_parameters
from vessel.sea.irregular import synthesise

K = 6
POINTS = [(0.0, 0.0, 0.0), (12.5, -7.0, 3.3), (-40.0, 25.0, 101.7), (3.0, 60.0, 17.25)]


def _sea(roll_sign: float = 1.0):
    """A small long-crested JONSWAP sea of K components travelling towards 250° NED."""
    return synthesise("jonswap", 1.75, 6.0, 3.3, math.radians(250.0), 0.0, K, seed=4, roll_sign=roll_sign)


def _arrays(sea) -> dict[str, np.ndarray]:
    return {"amplitude_m": sea.amplitude_m, "frequency_rad_s": sea.frequency_rad_s,
            "wavenumber_rad_m": sea.wavenumber_rad_m, "direction_rad": sea.direction_rad, "phase_rad": sea.phase_rad}


def _model(sea) -> ParametricSea:
    wave = np.concatenate([CALM_PARAMETERS[:-1], [sea.roll_sign], bank_parameters(_arrays(sea), K)])
    return ParametricSea.from_vector(ca.DM(wave), K)


def test_the_bank_with_the_true_components_is_the_simulators_sea() -> None:
    sea = _sea()
    model = _model(sea)
    for north, east, t in POINTS:
        for name in ("gradient", "slope_angles", "force_per_weight"):
            got = [float(v) for v in getattr(model, name)(north, east, t)]
            want = [float(v) for v in getattr(sea, name)(north, east, t)]
            np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-15, err_msg=f"{name} at {north, east, t}")
        assert float(model.elevation(north, east, t)) == pytest.approx(float(sea.elevation(north, east, t)), abs=1e-12)
    # not a trivially flat sea: the slope is of the order of degrees somewhere
    assert max(abs(float(sea.slope_angles(n, e, t)[1])) for n, e, t in POINTS) > math.radians(0.5)


def test_the_model_step_on_the_bank_is_the_step_on_the_built_in_sea() -> None:
    """One NMPC period from a moving, rolled state: the run-time bank and the built-in field give the same state."""
    sea = _sea()
    cfg = NmpcConfig(horizon=3, wave_components=K)
    params, current = otter_parameters(), OceanCurrent()
    on_bank = discrete_model(params, None, current, cfg)
    built_in = discrete_model(params, sea, current, NmpcConfig(horizon=3))
    x = np.array([5.0, -3.0, 0.0, 0.05, -0.02, 1.2, 1.4, 0.1, 0.0, 0.01, 0.0, 0.05])
    wave = np.concatenate([CALM_PARAMETERS[:-1], [sea.roll_sign], bank_parameters(_arrays(sea), K), NO_DISTURBANCE])
    for t in (0.0, 7.3, 42.0):
        got = np.asarray(on_bank(x, [60.0, 5.0], t, wave)).ravel()
        want = np.asarray(built_in(x, [60.0, 5.0], t, np.concatenate([CALM_PARAMETERS, NO_DISTURBANCE]))).ravel()
        np.testing.assert_allclose(got, want, rtol=1e-10, atol=1e-12)
    calm = np.asarray(on_bank(x, [60.0, 5.0], 7.3, np.concatenate([CALM_PARAMETERS, no_bank(K),
                                                                  NO_DISTURBANCE]))).ravel()
    assert np.max(np.abs(calm - want)) > 1e-4  # the bank is what moved the state


def test_no_bank_leaves_the_layout_and_the_problem_as_before() -> None:
    cfg = NmpcConfig(horizon=4)
    assert parameter_layout(0) is PARAMS
    assert [name for name, _ in PARAMS.blocks] == ["x0", "t", "waypoint", "u_prev", "weights", "wave", "roll_spread",
                                                   "disturbance"]
    assert wave_input_size(0) == 7 + 4 and bank_size(0) == 0
    built = problem_functions(otter_parameters(), None, OceanCurrent(), cfg)
    assert built.nlp["p"].numel() == PARAMS.size
    assert built.step.size1_in(3) == 7 + 4
    with_bank = parameter_layout(K)
    assert with_bank.blocks[:-1] == PARAMS.blocks and with_bank.blocks[-1] == ("bank", 3 + 6 * K)
    assert all(with_bank.slice(name) == PARAMS.slice(name) for name, _ in PARAMS.blocks)
    banked = problem_functions(otter_parameters(), None, OceanCurrent(), cfg.replace(wave_components=K))
    assert banked.nlp["p"].numel() == PARAMS.size + 3 + 6 * K
    p = pack_parameters(np.zeros(12), 1.0, np.array([1.0, 2.0]), np.zeros(2), cfg.weights, CALM_PARAMETERS,
                        bank=no_bank(K))
    expected = np.concatenate([CALM_PARAMETERS, no_bank(K), NO_DISTURBANCE])
    np.testing.assert_array_equal(with_bank.wave_input(p), expected)
    with pytest.raises(ValueError, match="wave_components = 0"):
        RollAwareNmpc(cfg).set_wave_bank(_arrays(_sea()))


@pytest.mark.parametrize("solver", ["rti", "nrti"])
def test_a_controller_on_the_bank_weights_roll_and_plans_against_the_sea(solver: str) -> None:
    """With no regular wave known, the bank alone switches the roll term on, and the plan's predicted roll is
    the one in the true sea."""
    sea = _sea()
    cfg = NmpcConfig(horizon=20, wave_components=K, solver=solver, rti_codegen="off")
    x0 = np.zeros(12)
    x0[5], x0[6] = math.radians(90.0), 1.0
    with RollAwareNmpc(cfg) as nmpc:
        nmpc.set_wave(None)
        assert not nmpc.roll_term_active
        nmpc.set_wave_bank(_arrays(sea), 1.0, sea.roll_sign)
        assert nmpc.bank_active and nmpc.roll_term_active
        nmpc.prepare(x0, 30.0, [85.0, 75.0])
        result = nmpc.solve(x0, 30.0, [85.0, 75.0])
        assert result.success and result.roll_term_active
        assert np.max(np.abs(result.states[:, 3])) > math.radians(0.3)
        nmpc.set_wave_bank(None)
        assert not nmpc.bank_active and not nmpc.roll_term_active


def test_the_bank_fades_to_half_its_weight_after_the_fade_time() -> None:
    sea = _sea()
    wave = np.concatenate([CALM_PARAMETERS, bank_parameters(_arrays(sea), K, 0.8, 10.0, 1.5)])
    model = ParametricSea.from_vector(ca.DM(wave), K)
    assert float(model.weight_at(10.0)) == pytest.approx(0.8)
    assert float(model.weight_at(11.5)) == pytest.approx(0.4)
    full = ParametricSea.from_vector(ca.DM(np.concatenate([CALM_PARAMETERS, bank_parameters(_arrays(sea), K)])), K)
    g_half, g_full = (float(m.gradient(3.0, 4.0, 11.5)[1]) for m in (model, full))
    assert abs(g_full) > 1e-3 and g_half == pytest.approx(0.4 * g_full, rel=1e-12)
    with pytest.raises(ValueError, match="fade"):
        bank_parameters(_arrays(sea), K, 1.0, 0.0, 0.0)


def test_a_short_closed_loop_on_the_predictor_plans_on_its_bank(tmp_path: Path) -> None:
    """Beam seas, under way: the predictor watches the drifting boat (the scenario's 60 s: its skill 1 s ahead
    reaches the 0.6 that turns it on after 40-50 s of a drifting boat), becomes confident 1 s ahead, and
    the NMPC plans on its bank for most of the run (said in the notes, counted in the metrics)."""
    from mavbridge.lab.experiment import run_scenario
    from mavbridge.lab.scenario import load_scenarios

    root = Path(__file__).resolve().parents[2]
    sc = {s.name: s for s in load_scenarios(root / "scenarios" / "jonswap_estimated.yaml")}["balanced"]
    world = dataclasses.replace(sc.world, start=dataclasses.replace(sc.world.start, heading_deg=0.0, surge_mps=1.5))
    sc = dataclasses.replace(sc, world=world, t_max_s=6.0,
                             waypoint=dataclasses.replace(sc.waypoint, north_m=100.0, east_m=0.0),
                             estimation=dataclasses.replace(sc.estimation, waves="predicted", watch_s=60.0),
                             controller=sc.controller.replace(wave_components=K, horizon=10))
    out = tmp_path / "run"
    m = run_scenario(sc, out, plots=False).metrics
    assert m["wave_source"] == "estimated+phase-bank"
    with (out / "timeseries.csv").open(encoding="utf-8") as handle:
        on = [float(row["wave_bank_on"]) for row in csv.DictReader(handle)]
    assert set(on) <= {0.0, 1.0} and sum(on) / len(on) == pytest.approx(m["bank_fraction"], abs=0.02)
    assert m["bank_fraction"] > 0.5
    assert any("phase bank confident" in line for line in m["notes"])
    assert 0.5 <= m["bank_fade_s_median"] <= 4.0
