"""What a process keeps between NMPC builds (issue 53) is immutable and changes no run.

The HPIPM conic and its compiled library (``gauss_newton.shared_conic``), the block linearisation of a problem
structure (``ProblemFunctions.block_linearisation``) and the sensed plant's unbound functions (kept with the watch)
are built once per process; every controller and plant still owns the buffers it calls them with. A run flown after
another, from these caches, gives exactly the figures of the same run flown with every cache cleared first.
Real solver, plant, sensors and estimator; no mocks.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from mavbridge.lab.experiment import run_scenario
from mavbridge.lab.scenario import Scenario, scenario_from_mapping
from mavbridge.lab.watch import MAKES, WATCHES
from mavbridge.nmpc import NmpcConfig, RollAwareNmpc, compiled_model, functions
from mavbridge.nmpc.solvers import gauss_newton
from mavbridge.nmpc.solvers.codegen import compiler
from vessel import otter_parameters

needs_compiler = pytest.mark.skipif(compiler() is None, reason="no C compiler")

SHORT = {  # NATO sea state 3 on the estimate, the observer, nrti; 20 s watched, 4 s flown
    "start": {"heading_deg": 90.0, "surge_mps": 1.5},
    "waypoint": {"north_m": 0.0, "east_m": 300.0},
    "t_max_s": 4.0,
    "controller": {"q": 5, "r": 1550, "s": 2, "horizon": 10, "solver": "nrti"},
    "sea": {"spectrum": {"kind": "jonswap", "sea_state": 3, "travel_dir_deg": -90.0, "paper_roll_sign": True},
            "seed": 1},
    "estimation": {"waves": "estimated", "surface_heave": True, "hidden_phase": True, "seed": 5, "calibrate": False,
                   "watch_s": 20.0},
}


def _scenario(name: str, **controller: float) -> Scenario:
    return scenario_from_mapping({**SHORT, "controller": {**SHORT["controller"], **controller}}, "test", name)


def _figures(metrics: dict[str, Any]) -> dict[str, Any]:
    """The run's own figures: the machine's timings (wall, solve and estimator milliseconds) left out."""
    return {key: (_figures(value) if isinstance(value, dict) else value)
            for key, value in metrics.items() if "_ms" not in key and "wall" not in key}


def _clear_caches() -> None:
    """Forget all a process keeps between runs: the conics, the kept watches (with their plants' functions), the
    built problem structures (with their block linearisations) and the compiled models."""
    gauss_newton.clear_conics()
    WATCHES.clear()
    MAKES.clear()
    for cache in (functions._FUNCTIONS, functions._FIXED_FUNCTIONS, functions._LIBRARIES, functions._FIXED_LIBRARIES):
        cache.clear()
    compiled_model._generic.cache_clear()
    compiled_model._compiled.cache_clear()


@needs_compiler
def test_two_controllers_share_the_compiled_conic_and_blocks_but_no_buffers() -> None:
    cfg = NmpcConfig(**SHORT["controller"])
    a, b = RollAwareNmpc(cfg, otter_parameters()), RollAwareNmpc(cfg, otter_parameters())
    try:
        sqps = [nmpc._backend.advanced.preparation.solve.sqp for nmpc in (a, b)]
        assert sqps[0].native is not None and sqps[1].native is not None
        assert sqps[0].qp is sqps[1].qp  # the one conic Function of this key ...
        assert sqps[0].native is not sqps[1].native  # ... each SQP its own compiled instance and buffers
        for name, buffer in sqps[0].native.inputs.items():
            assert not np.shares_memory(buffer, sqps[1].native.inputs[name]), name
        assert not np.shares_memory(sqps[0].native.x, sqps[1].native.x)
        lins = [nmpc._backend.advanced.preparation.condenser.lin for nmpc in (a, b)]
        assert lins[0] is not lins[1]
        assert not any(np.shares_memory(x, y) for x, y in zip(lins[0].outputs, lins[1].outputs, strict=True))
        assert len(a._functions._blocks) == 1  # built once for the structure
    finally:
        a.close()
        b.close()


@needs_compiler
def test_a_run_from_the_caches_flies_as_a_run_with_every_cache_cleared() -> None:
    run_scenario(_scenario("before", r=12800), None, plots=False)  # fills every cache
    warm = _figures(run_scenario(_scenario("run"), None, plots=False).metrics)
    assert WATCHES.hits >= 1 and MAKES.hits >= 1  # (the watch and the plant's functions came from the first run)
    _clear_caches()
    assert gauss_newton.clear_conics() == 0 and functions.cached_structures() == 0
    cold = _figures(run_scenario(_scenario("run"), None, plots=False).metrics)
    assert warm == cold


def test_a_failed_conic_compile_is_tried_again_a_settled_answer_is_kept(tmp_path, monkeypatch) -> None:
    """A compile that failed (here a compiler that always fails, into an empty cache) is not kept: the next NMPC
    of the process tries again; "no C compiler" is a settled answer and is kept."""
    import casadi as ca

    nz, n = gauss_newton.NZ, gauss_newton.NZ + gauss_newton.NU  # one stage: [x0 u0] and x1
    h = ca.diagcat(ca.DM.ones(n, n), ca.DM.ones(nz, nz)).sparsity()
    a = ca.horzcat(ca.DM.ones(nz, n), ca.DM.eye(nz)).sparsity()
    monkeypatch.setenv("MAVBRIDGE_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv("CC", "false")  # found on PATH, exits 1
    gauss_newton.clear_conics()
    _, library, how = gauss_newton.shared_conic("qp_fail_test", h, a, 1, 0)
    assert library is None and "failed" in how
    assert gauss_newton.clear_conics() == 0  # not kept
    monkeypatch.setattr(gauss_newton, "compiler", lambda: None)
    monkeypatch.setattr("mavbridge.nmpc.solvers.hpipm_native.compiler", lambda: None)
    _, library, how = gauss_newton.shared_conic("qp_fail_test", h, a, 1, 0)
    assert library is None and "no C compiler" in how
    assert gauss_newton.clear_conics() == 1  # kept
