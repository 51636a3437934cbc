"""A CasADi function with its constants made an input evaluates exactly what it did, a plant step too."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from vessel import OceanCurrent, otter_parameters
from vessel.dynamics import rigid_body_ode
from vessel.jit import BoundFunction, constants_as_input
from vessel.plant import rk4_step
from vessel.sea.irregular import synthesise


def _sea(seed: int) -> object:
    return synthesise("jonswap", 1.0, 5.0, 3.3, 0.5, 10.0, 24, seed)


def test_constants_become_an_input_and_nothing_else_changes() -> None:
    x, y = ca.SX.sym("x", 3), ca.SX.sym("y")
    f = ca.Function("f", [x, y], [0.65 * ca.sin(1.3 * x) * y - ca.DM([0.1, 0.2, 0.3]), ca.sumsqr(x) / 7.0 + y],
                    ["x", "y"], ["a", "b"])
    g, constants = constants_as_input(f)
    assert g.name_in() == ["x", "y", "constants"] and constants.size == g.nnz_in(2) > 0
    rng = np.random.default_rng(3)
    for _ in range(200):
        xv, yv = rng.normal(size=3), float(rng.normal())
        for want, got in zip(f(xv, yv), g(xv, yv, constants), strict=True):
            assert np.array_equal(np.asarray(want), np.asarray(got))


def test_a_plant_step_rebuilt_steps_bit_for_bit() -> None:
    step = rk4_step(rigid_body_ode(otter_parameters(), _sea(5), OceanCurrent(), True), 0.01)
    generic, constants = constants_as_input(step)
    a, b = BoundFunction(step), BoundFunction(generic)
    b.inputs[3][:] = constants
    rng = np.random.default_rng(0)
    x = np.zeros(12)
    for k in range(300):
        u = rng.uniform(-50.0, 50.0, 2)
        for call in (a, b):
            call.inputs[0][:], call.inputs[1][:], call.inputs[2][0] = x, u, 0.01 * k
            call()
        assert np.array_equal(a.outputs[0], b.outputs[0])
        x = a.outputs[0].copy()
    assert np.any(x != 0.0)


def test_a_sparse_input_or_output_is_refused_not_rebuilt_wrong() -> None:
    x = ca.SX.sym("x", ca.Sparsity.diag(3))  # nonzeros only on the diagonal
    y = ca.SX.sym("y", 3)
    with pytest.raises(ValueError, match="input 0 sparse"):
        constants_as_input(ca.Function("f", [x], [2.5 * ca.sum1(x)]))
    with pytest.raises(ValueError, match="output 0 sparse"):
        constants_as_input(ca.Function("g", [y], [ca.diag(2.5 * y)]))
