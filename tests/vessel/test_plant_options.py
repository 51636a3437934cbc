"""Plant options of issue 11: surface heave off is the paper's plant; a compiled step equals the VM's."""

from __future__ import annotations

import numpy as np
import pytest

from vessel import IrregularSea, Plant, RegularWaves, otter_parameters
from vessel.jit import find_compiler, worth_compiling


def _trajectory(plant: Plant, steps: int = 300) -> np.ndarray:
    x0 = np.zeros(14)
    x0[5], x0[6] = 0.8, 1.2
    plant.reset(x0)
    return np.array([plant.step((70.0, 40.0)).copy() for _ in range(steps)])


def test_surface_heave_off_is_bit_identical_to_the_default_plant() -> None:
    params = otter_parameters()
    default = _trajectory(Plant(params, RegularWaves()))
    explicit = _trajectory(Plant(params, RegularWaves(), surface_heave=False, compile_step=False))
    np.testing.assert_array_equal(default, explicit)
    heaving = _trajectory(Plant(params, RegularWaves(), surface_heave=True))
    assert np.max(np.abs(heaving[:, 2] - default[:, 2])) > 0.1  # the option does change heave


def test_only_large_steps_are_compiled_by_default() -> None:
    params = otter_parameters()
    assert not worth_compiling(Plant(params, RegularWaves())._function)
    big = Plant(params, IrregularSea(n_components=100).wave_field(params), compile_step=False)
    assert worth_compiling(big._function) == (find_compiler() is not None)


@pytest.mark.skipif(find_compiler() is None, reason="no C compiler on this machine")
def test_compiled_step_equals_the_virtual_machine() -> None:
    params = otter_parameters()
    waves = IrregularSea(n_components=30, seed=4).wave_field(params)
    vm = _trajectory(Plant(params, waves, surface_heave=True, compile_step=False))
    jit = _trajectory(Plant(params, waves, surface_heave=True, compile_step=True))
    np.testing.assert_allclose(jit, vm, rtol=0, atol=1e-12)
