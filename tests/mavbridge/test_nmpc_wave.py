"""The wave as a run-time NLP parameter: the parametric field is RegularWaves' numbers, one built solver
serves any wave, ``set_wave(None)`` flies without the roll term, asrti's background keeps its wave."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import pytest

from mavbridge.nmpc import PARAMS, NmpcConfig, RollAwareNmpc, wave_parameters
from mavbridge.nmpc.functions import cached_structures
from mavbridge.nmpc.problem import NO_DISTURBANCE, discrete_model
from mavbridge.nmpc.wave_model import ParametricRegularWaves
from vessel import CalmWater, OceanCurrent, RegularWaves, otter_parameters

WAVES = RegularWaves(1.75, 35.0, 6.0, -math.pi / 2)
OTHER = RegularWaves(1.2, 28.0, 5.0, 0.4, paper_roll_sign=False, phase_rad=2.0)
TARGET = (85.0, 75.0)


def _start() -> np.ndarray:
    x = np.zeros(12)
    x[5], x[6] = math.pi / 2, 1.0
    return x


def _cfg(solver: str, **changes: object) -> NmpcConfig:
    return NmpcConfig(horizon=6, solver=solver, rti_codegen="off", **changes)


@pytest.mark.parametrize("waves", [WAVES, OTHER, RegularWaves(0.5, 60.0, 9.0, 2.5, phase_rad=-0.7)])
def test_parametric_field_gives_the_regular_waves_numbers(waves: RegularWaves) -> None:
    field = ParametricRegularWaves.from_vector(wave_parameters(waves))
    rng = np.random.default_rng(1)
    north, east, t = rng.uniform(-200, 200, 50), rng.uniform(-200, 200, 50), rng.uniform(0, 300, 50)
    assert field.roll_sign == waves.roll_sign
    np.testing.assert_allclose(field.elevation(north, east, t), waves.elevation(north, east, t), rtol=0, atol=1e-12)
    for ours, theirs in ((field.slope_angles, waves.slope_angles), (field.force_per_weight, waves.force_per_weight)):
        np.testing.assert_allclose(ours(north, east, t), theirs(north, east, t), rtol=0, atol=1e-12)


@pytest.mark.parametrize("waves", [WAVES, OTHER, CalmWater()])
def test_parametric_model_equals_the_built_in_wave_model(waves: RegularWaves | CalmWater) -> None:
    cfg = NmpcConfig()
    built_in = discrete_model(otter_parameters(), waves, OceanCurrent(), cfg)
    parametric = discrete_model(otter_parameters(), None, OceanCurrent(), cfg)
    rng = np.random.default_rng(2)
    wave = np.concatenate([wave_parameters(waves), NO_DISTURBANCE])  # (the model input ends in the disturbance)
    for _ in range(20):
        x, u, t = rng.normal(size=12) * 0.3, rng.normal(size=2) * 50, rng.uniform(0, 100)
        np.testing.assert_allclose(np.asarray(parametric(x, u, t, wave)), np.asarray(built_in(x, u, t, wave)),
                                   rtol=1e-13, atol=1e-13)


@pytest.mark.parametrize("solver", ["ipopt", "asrti"])
def test_set_wave_predicts_with_the_new_wave_without_a_rebuild(solver: str) -> None:
    with RollAwareNmpc(_cfg(solver), otter_parameters(), CalmWater()) as calm_built, \
            RollAwareNmpc(_cfg(solver), otter_parameters(), OTHER) as reference:
        structures = cached_structures()
        calm_built.set_wave(OTHER)
        assert calm_built.waves == OTHER
        ours, theirs = calm_built.prepare(_start(), 0.0, TARGET), reference.prepare(_start(), 0.0, TARGET)
        np.testing.assert_allclose(ours.states, theirs.states, atol=1e-6)
        x = _start()
        for k in range(3):
            a, b = calm_built.solve(x, 0.1 * k, TARGET), reference.solve(x, 0.1 * k, TARGET)
            np.testing.assert_allclose(a.tau, b.tau, atol=1e-6)
            x = a.states[1]
        assert cached_structures() == structures  # nothing was built for the new wave
        # And the wave matters: the calm-water prediction differs.
        calm_built.set_wave(CalmWater())
        assert not np.allclose(calm_built.prepare(_start(), 0.0, TARGET).states, theirs.states, atol=1e-3)


def test_no_wave_knowledge_predicts_calm_water_without_the_roll_term() -> None:
    with RollAwareNmpc(_cfg("ipopt"), otter_parameters(), WAVES) as nmpc, \
            RollAwareNmpc(_cfg("ipopt", r=0.0), otter_parameters(), CalmWater()) as direct_calm:
        x = _start()
        x[3] = 0.1  # a heeled start: the roll term would act on it
        with_wave = nmpc.solve(x, 0.0, TARGET)
        assert with_wave.roll_term_active
        nmpc.set_wave(None)
        assert not nmpc.roll_term_active and isinstance(nmpc.waves, CalmWater)
        nmpc.reset()
        blind = nmpc.solve(x, 0.0, TARGET)
        assert not blind.roll_term_active and blind.success
        np.testing.assert_allclose(blind.tau, direct_calm.solve(x, 0.0, TARGET).tau, atol=1e-6)
        assert not np.allclose(blind.tau, with_wave.tau, atol=1e-2)
        assert not direct_calm.solve(x, 0.1, TARGET).roll_term_active  # R = 0 in the configuration
        nmpc.set_wave(WAVES)
        assert nmpc.roll_term_active
        nmpc.reset()
        np.testing.assert_allclose(nmpc.solve(x, 0.0, TARGET).tau, with_wave.tau, atol=1e-9)


def test_warm_start_stays_valid_across_a_small_wave_change() -> None:
    # rti and converged ipopt fly the same step under WAVES, then both get a changed wave: rti's warm step
    # from the plan made for the old wave still lands on the converged answer for the new one.
    nudged = RegularWaves(2.0, 35.0, 6.0, -math.pi / 2 + 0.2, phase_rad=0.6)
    taus = {}
    for name, solver, waves in (("rti", "rti", nudged), ("converged", "ipopt", nudged), ("old", "ipopt", WAVES)):
        with RollAwareNmpc(_cfg(solver), otter_parameters(), WAVES) as nmpc:
            x = _start()
            nmpc.prepare(x, 0.0, TARGET)
            first = nmpc.solve(x, 0.0, TARGET)
            nmpc.set_wave(waves)
            x1 = taus.setdefault("x1", first.states[1])  # every controller continues from the same state
            step = nmpc.solve(x1, 0.1, TARGET)
            assert step.success
            if solver == "rti":
                assert step.status.startswith("RTI")  # a warm step, not a cold solve
            else:
                assert step.iterations < 15  # the old plan is a good start for IPOPT too
            taus[name] = step.tau
    np.testing.assert_allclose(taus["rti"], taus["converged"], atol=1.0)
    assert abs(taus["old"][0] - taus["converged"][0]) > 4.0  # the change matters to the answer


def test_asrti_background_solve_keeps_the_wave_it_was_started_with() -> None:
    with RollAwareNmpc(_cfg("asrti"), otter_parameters(), WAVES) as nmpc:
        x = _start()
        nmpc.prepare(x, 0.0, TARGET)
        first = nmpc.solve(x, 0.0, TARGET)  # starts the background solve for t = 0.1 with WAVES
        nmpc.set_wave(OTHER)
        _, p_next, _, _ = nmpc._backend.advanced._pending.result(timeout=30)
        np.testing.assert_array_equal(PARAMS.get(p_next, "wave"), wave_parameters(WAVES))
        second = nmpc.solve(first.states[1], 0.1, TARGET)  # its plan warm-starts the step with OTHER
        assert second.success and second.stats["background"] == "used"
        assert second.stats["background_problem"] == "changed"
        third = nmpc.solve(second.states[1], 0.2, TARGET)
        assert third.stats["background_problem"] == "same"


def test_set_wave_rejects_bad_waves_with_the_field_named() -> None:
    with RollAwareNmpc(_cfg("ipopt"), otter_parameters(), WAVES) as nmpc:
        with pytest.raises(ValueError, match=r"waves\.height_m"):
            nmpc.set_wave(RegularWaves(math.nan, 35.0, 6.0, 0.0))
        with pytest.raises(ValueError, match=r"waves\.phase_rad"):
            nmpc.set_wave(RegularWaves(1.0, 35.0, 6.0, 0.0, phase_rad=math.inf))
        with pytest.raises(TypeError, match="RegularWaves, CalmWater or None"):
            nmpc.set_wave("paper")  # type: ignore[arg-type]
        assert nmpc.waves == WAVES  # unchanged by the rejected calls


@dataclass(frozen=True)
class SteadySlope:
    """A wave field the parametric regular wave cannot represent: a constant surface slope."""

    alpha_n: float = 0.05
    roll_sign: float = 1.0

    def elevation(self, north: Any, east: Any, t: Any) -> Any:
        return self.alpha_n * north

    def slope_angles(self, north: Any, east: Any, t: Any) -> tuple[Any, Any]:
        return 0 * north + self.alpha_n, 0 * north

    def force_per_weight(self, north: Any, east: Any, t: Any) -> tuple[Any, Any]:
        return 0 * north - 0.5 * math.sin(2 * self.alpha_n), 0 * north


def test_another_wave_field_is_built_in_and_cannot_be_replaced() -> None:
    with RollAwareNmpc(_cfg("rti"), otter_parameters(), SteadySlope()) as fixed, \
            RollAwareNmpc(_cfg("rti"), otter_parameters(), CalmWater()) as calm:
        assert fixed._functions is not calm._functions  # its own build, keyed by the field
        a, b = fixed.prepare(_start(), 0.0, TARGET), calm.prepare(_start(), 0.0, TARGET)
        assert a.success and not np.allclose(a.states, b.states, atol=1e-3)  # the slope is in its model
        with pytest.raises(ValueError, match="fixed SteadySlope"):
            fixed.set_wave(WAVES)
