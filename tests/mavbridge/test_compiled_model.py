"""Compiled models (``mavbridge.nmpc.compiled_model``) evaluate what CasADi's virtual machine does, bit for bit: the
realistic plant's half period steps exactly as the mapped one, one compiled function serving every seed."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from mavbridge.nmpc.compiled_model import compiled_model, model_make
from vessel import OceanCurrent, otter_parameters
from vessel.dynamics import rigid_body_ode
from vessel.jit import BoundFunction, find_compiler
from vessel.plant import rk4_step
from vessel.sea.irregular import synthesise

pytestmark = pytest.mark.skipif(find_compiler() is None, reason="no C compiler")


def _sea(seed: int) -> object:
    return synthesise("jonswap", 1.0, 5.0, 3.3, 0.5, 10.0, 24, seed)


def test_a_compiled_model_gives_the_virtual_machines_numbers() -> None:
    x, t = ca.SX.sym("x", 2), ca.SX.sym("t")
    f = ca.Function("g", [x, t], [ca.vertcat(0.3 * ca.cos(1.7 * t + x[0]) * x[1], ca.atan2(x[1], x[0]) / 3.0)])
    call, compiled = compiled_model(f)
    vm = BoundFunction(f)
    assert compiled and len(call.inputs) == 3  # (x, t, the constants)
    rng = np.random.default_rng(7)
    for _ in range(100):
        xv, tv = rng.normal(size=2), float(rng.uniform(0, 100))
        for bound in (call, vm):
            bound.inputs[0][:], bound.inputs[1][0] = xv, tv
            bound()
        assert np.array_equal(call.outputs[0], vm.outputs[0])


def test_compiled_half_period_equals_the_mapped_one_and_serves_every_seed() -> None:
    from mavbridge.lab import sensed_plant as hp

    params = otter_parameters()
    halves = []
    for seed in (1, 2):
        step = rk4_step(rigid_body_ode(params, _sea(seed), OceanCurrent(), True), 0.01)
        compiled, mapped = hp.half_period(model_make(step), 5, 0.01), hp.MappedHalf(step, 5, 0.01)
        assert isinstance(compiled, hp.CompiledHalf)
        x = np.zeros(12)
        for k in range(100):
            for half in (compiled, mapped):
                half.hold(np.array([30.0 * np.sin(k), 5.0]))
            got, want = compiled.run(x, 0.05 * k).copy(), mapped.run(x, 0.05 * k).copy()
            assert np.array_equal(got, want)
            x = want
        halves.append(compiled)
    assert halves[0]._call.function is halves[1]._call.function  # the second seed compiled nothing


def test_the_same_model_again_is_not_rebuilt() -> None:
    from mavbridge.nmpc import compiled_model as cm

    x = ca.SX.sym("x", 2)
    f = ca.Function("h", [x], [ca.sin(0.25 * x) * 1.5])
    first, _ = compiled_model(f)
    hits = cm._generic.cache_info().hits
    second, compiled = compiled_model(ca.Function("h", [x], [ca.sin(0.25 * x) * 1.5]))  # built anew, equal
    assert compiled and cm._generic.cache_info().hits == hits + 1
    assert second is not first and second.inputs[0] is not first.inputs[0]  # its own buffers
    assert np.array_equal(second.inputs[-1], first.inputs[-1])
