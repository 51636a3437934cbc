"""The fast solver (Gauss–Newton RTI with HPIPM): same QP data as the reference linearisation, the same
closed loop as IPOPT on a short case, and the compiled linearisation cached on disk."""

from __future__ import annotations

import math
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from mavbridge.lab.experiment import run_scenario
from mavbridge.lab.scenario import scenario_from_mapping
from mavbridge.nmpc import NmpcConfig, RollAwareNmpc
from mavbridge.nmpc.layout import NU, PARAMS
from mavbridge.nmpc.problem import discrete_model
from mavbridge.nmpc.solvers.codegen import compiler
from mavbridge.nmpc.solvers.gauss_newton import NZ, make_qp
from mavbridge.nmpc.solvers.hpipm_native import hpipm_location, native_qp
from mavbridge.nmpc.solvers.rti import linearisation, linearisation_inlined
from mavbridge.nmpc.wave_model import wave_parameters
from tests.mavbridge.test_loop_figures import figures
from vessel import OceanCurrent, RegularWaves, otter_parameters
from vessel.config import ConfigError

WAVES = RegularWaves(1.75, 35.0, 6.0, -math.pi / 2)


def test_mapped_linearisation_equals_the_inlined_one() -> None:
    cfg = NmpcConfig(horizon=4)
    step = discrete_model(otter_parameters(), None, OceanCurrent(), cfg)  # the wave from p
    mapped, inlined = linearisation(step, cfg), linearisation_inlined(step, cfg)
    rng = np.random.default_rng(3)
    w = rng.normal(size=mapped.size1_in(0)) * 0.3
    p = PARAMS.pack(x0=rng.normal(size=12), t=7.0, waypoint=[85.0, 75.0], u_prev=[20.0, 1.0],
                    weights=[5, 1550, 2, 1, 1], wave=wave_parameters(WAVES), roll_spread=[0.3, -0.1, 0.2],
                    disturbance=[0.2, -0.1, 3.0, 0.5])
    for a, b in zip(mapped(w, p), inlined(w, p), strict=True):
        np.testing.assert_allclose(ca.densify(a).full(), ca.densify(b).full(), atol=1e-10)


def _beam(solver: str) -> dict:
    return {
        "name": f"beam_{solver}",
        "sea": {"height_m": 1.75, "length_m": 35.0, "period_s": 6.0, "travel_dir_deg": -90.0},
        "start": {"heading_deg": 30.0, "surge_mps": 1.0},
        "waypoint": {"north_m": 40.0, "east_m": 10.0},
        "t_max_s": 10.0,
        "controller": {"q": 5, "r": 1550, "s": 2, "horizon": 12, "solver": solver, "rti_codegen": "off"},
    }


def test_rti_closed_loop_matches_ipopt_on_a_short_case() -> None:
    results = {}
    for solver in ("ipopt", "rti", "asrti"):
        scenario = scenario_from_mapping(_beam(solver), "test")
        results[solver] = run_scenario(scenario, None, plots=False)
    ipopt = results["ipopt"].metrics
    for solver in ("rti", "asrti"):
        fast = results[solver].metrics
        assert fast["failures"] == 0
        assert fast["avg_roll_deg"] == pytest.approx(ipopt["avg_roll_deg"], rel=0.05)
        assert fast["final_distance_m"] == pytest.approx(ipopt["final_distance_m"], rel=0.05)
        # The cold start is done by ``prepare`` before the loop; every step is a few SQP iterations: far faster.
        assert np.median(results[solver].solve_ms) < 0.5 * np.median(results["ipopt"].solve_ms)
    assert results["asrti"].metrics["background_solve_ms_max"] > 0


def test_rti_first_solve_is_a_full_solve_then_real_time_iterations() -> None:
    cfg = NmpcConfig(horizon=6, solver="rti", rti_codegen="off", rti_iterations=2, rti_max_iterations=2)
    nmpc = RollAwareNmpc(cfg, otter_parameters(), WAVES)
    x = np.zeros(12)
    x[5], x[6] = math.pi / 2, 1.0
    first = nmpc.solve(x, 0.0, (85.0, 75.0))
    assert first.status == "Solve_Succeeded"
    second = nmpc.solve(first.states[1], 0.1, (85.0, 75.0))
    assert second.status.startswith("RTI") and second.iterations == 2 and second.success
    assert np.all(np.isfinite(second.tau))
    nmpc.reset()
    assert nmpc.solve(x, 0.0, (85.0, 75.0)).status == "Solve_Succeeded"


@pytest.mark.parametrize("solver", ["ipopt", "rti", "asrti"])
def test_prepare_does_the_cold_solve_so_the_first_step_is_warm(solver: str) -> None:
    cfg = NmpcConfig(horizon=6, solver=solver, rti_codegen="off")
    nmpc = RollAwareNmpc(cfg, otter_parameters(), WAVES)
    x = np.zeros(12)
    x[5], x[6] = math.pi / 2, 1.0
    prepared = nmpc.prepare(x, 0.0, (85.0, 75.0))
    assert prepared.status == "Solve_Succeeded" and prepared.success
    np.testing.assert_array_equal(nmpc.last_input, [0.0, 0.0])  # nothing was applied
    first = nmpc.solve(x, 0.0, (85.0, 75.0))
    assert first.success and first.fallback is None
    # The plan from prepare starts at the same time: not shifted, so the first step is already converged.
    np.testing.assert_allclose(first.tau, prepared.tau, atol=0.5)
    if solver == "ipopt":
        assert first.iterations <= 3
    else:
        assert first.status.startswith("RTI") and first.iterations == (1 if solver == "asrti" else 2)


def test_asrti_steps_start_from_the_background_solve() -> None:
    cfg = NmpcConfig(horizon=6, solver="asrti", rti_codegen="off")
    nmpc = RollAwareNmpc(cfg, otter_parameters(), WAVES)
    x = np.zeros(12)
    x[5], x[6] = math.pi / 2, 1.0
    nmpc.prepare(x, 0.0, (85.0, 75.0))
    first = nmpc.solve(x, 0.0, (85.0, 75.0))
    assert "background" not in first.stats and first.iterations == 1
    second = nmpc.solve(first.states[1], 0.1, (85.0, 75.0))
    assert second.stats["background"] == "used" and second.iterations == 1 and second.success
    assert second.stats["background_solve_s"] > 0 and second.stats["background_iterations"] >= 1
    # The background solve ran for (predicted state, t + T): one iteration from it gives IPOPT's answer.
    reference = RollAwareNmpc(cfg.replace(solver="ipopt"), otter_parameters(), WAVES)
    reference.prepare(x, 0.0, (85.0, 75.0))
    np.testing.assert_allclose(reference.solve(x, 0.0, (85.0, 75.0)).tau, first.tau, atol=0.5)
    converged = reference.solve(first.states[1], 0.1, (85.0, 75.0))
    np.testing.assert_allclose(second.tau, converged.tau, atol=1.0)
    # A plan for another waypoint is not used; after reset nothing is pending.
    third = nmpc.solve(second.states[1], 0.2, (60.0, 75.0))
    assert third.stats["background"] == "unused" and third.success
    nmpc.reset()
    assert "background" not in nmpc.solve(x, 0.0, (85.0, 75.0)).stats


def test_asrti_worker_process_gives_the_thread_answers() -> None:
    x = np.zeros(12)
    x[5], x[6] = math.pi / 2, 1.0
    answers = {}
    for worker in ("thread", "process"):
        cfg = NmpcConfig(horizon=6, solver="asrti", rti_codegen="off", as_worker=worker)
        nmpc = RollAwareNmpc(cfg, otter_parameters(), WAVES)
        nmpc.prepare(x, 0.0, (85.0, 75.0))
        first = nmpc.solve(x, 0.0, (85.0, 75.0))
        second = nmpc.solve(first.states[1], 0.1, (85.0, 75.0))
        assert second.stats["background"] == "used"
        answers[worker] = np.concatenate([first.tau, second.tau])
    np.testing.assert_allclose(answers["process"], answers["thread"], atol=1e-9)


def test_asrti_config_fields_are_bounded() -> None:
    for field, value in (("as_iterations", 0), ("as_max_iterations", 0), ("as_step_tol", -1.0), ("as_wait_s", -1),
                         ("as_worker", "fork")):
        with pytest.raises(ConfigError, match=field):
            NmpcConfig(**{field: value})


@pytest.mark.skipif(compiler() is None, reason="no C compiler")
def test_compiled_linearisation_is_cached_by_model_hash(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MAVBRIDGE_CACHE_DIR", str(tmp_path))
    cfg = NmpcConfig(horizon=3, solver="rti", rti_codegen="auto")
    nmpc = RollAwareNmpc(cfg, otter_parameters().replace(payload_mass=24.0), WAVES)
    assert nmpc._backend.codegen.startswith("compiled")
    libraries = list(tmp_path.glob("rti_linearisation_*.so"))
    assert len(libraries) == 1
    stamp = libraries[0].stat().st_mtime_ns
    from mavbridge.nmpc.solvers.rti import RtiBackend

    again = RtiBackend(nmpc._functions, cfg, ipopt=nmpc._backend.ipopt)
    assert again.codegen == nmpc._backend.codegen
    assert libraries[0].stat().st_mtime_ns == stamp
    x = np.zeros(12)
    x[5], x[6] = math.pi / 2, 1.0
    first = nmpc.solve(x, 0.0, (85.0, 75.0))
    assert nmpc.solve(first.states[1], 0.1, (85.0, 75.0)).success


def test_a_qp_cut_at_its_iteration_cap_is_named_so_and_its_step_is_taken() -> None:
    """The status that fills most rows of companion.csv says what happened (issue 17 item 12d): HPIPM stopped a
    QP at rti_qp_iter_max, by design in real time; the step is still a success, not a failure."""
    cfg = NmpcConfig(horizon=6, solver="rti", rti_codegen="off", rti_iterations=2, rti_max_iterations=2,
                     rti_qp_iter_max=1)
    nmpc = RollAwareNmpc(cfg, otter_parameters(), WAVES)
    x = np.zeros(12)
    x[5], x[6] = math.pi / 2, 1.0
    first = nmpc.solve(x, 0.0, (85.0, 75.0))
    step = nmpc.solve(first.states[1], 0.1, (85.0, 75.0))
    assert step.status in ("RTI (1 of 2 QPs at the iteration cap)", "RTI (2 of 2 QPs at the iteration cap)")
    assert step.success and step.fallback is None and np.all(np.isfinite(step.tau))


def _ocp_qp(horizon: int, rng: np.random.Generator) -> dict[str, ca.DM]:
    """A random QP of the augmented OCP's structure (SPD stage blocks, random dynamics, a box on the inputs, the
    first state fixed), as ``GaussNewtonSqp`` hands it to HPIPM."""
    nzu, n = NZ + NU, horizon * (NZ + NU) + NZ
    H, A = np.zeros((n, n)), np.zeros((NZ * horizon, n))
    for k in range(horizon + 1):
        size = nzu if k < horizon else NZ
        M = rng.normal(size=(size, size))
        H[k * nzu:k * nzu + size, k * nzu:k * nzu + size] = M @ M.T + 0.1 * np.eye(size)
    for k in range(horizon):
        A[k * NZ:(k + 1) * NZ, k * nzu:(k + 1) * nzu] = 0.4 * rng.normal(size=(NZ, nzu))
        A[k * NZ:(k + 1) * NZ, (k + 1) * nzu:(k + 1) * nzu + NZ] = -np.eye(NZ)
    lbx, ubx = np.full(n, -np.inf), np.full(n, np.inf)
    for k in range(horizon):
        lbx[k * nzu + NZ:(k + 1) * nzu], ubx[k * nzu + NZ:(k + 1) * nzu] = -0.5, 0.5
    lbx[0:NZ] = ubx[0:NZ] = rng.normal(size=NZ)
    gap = 0.1 * rng.normal(size=NZ * horizon)
    return {"h": ca.sparsify(ca.DM(H)), "g": ca.DM(10.0 * rng.normal(size=n)), "a": ca.sparsify(ca.DM(A)),
            "lba": ca.DM(-gap), "uba": ca.DM(-gap), "lbx": ca.DM(lbx), "ubx": ca.DM(ubx)}


@pytest.mark.skipif(compiler() is None or hpipm_location()[0] is None, reason="no C compiler or no HPIPM headers")
@pytest.mark.parametrize("iter_max", [0, 2])
def test_the_compiled_conic_gives_the_plugins_bits(iter_max: int, tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    """Same x, to the bit, and the same success flag as CasADi's HPIPM plugin, QP after QP in one instance (the
    generated code uses its output-pointer array as scratch: a second QP must still land in the outputs)."""
    monkeypatch.setenv("MAVBRIDGE_CACHE_DIR", str(tmp_path))
    rng = np.random.default_rng(11)
    horizon = 5
    first = _ocp_qp(horizon, rng)
    qp = make_qp("test_qp", first["h"].sparsity(), first["a"].sparsity(), horizon, iter_max)
    native, how = native_qp(qp)
    assert native is not None and how.startswith("compiled"), how
    successes = []
    for data in [first, *(_ocp_qp(horizon, rng) for _ in range(3))]:
        for i, name in enumerate(qp.name_in()):
            if name in data:
                native.inputs[name][:] = np.array(ca.project(data[name], qp.sparsity_in(i)).nonzeros())
        converged = native.solve()
        expected = np.asarray(qp(**data)["x"]).ravel()
        np.testing.assert_array_equal(native.x, expected)
        assert converged == qp.stats()["success"]
        successes.append(converged)
        u = np.concatenate([expected[k * (NZ + NU) + NZ:(k + 1) * (NZ + NU)] for k in range(horizon)])
        assert iter_max or np.any(np.abs(u) > 0.5 - 1e-6)  # some input on its bound: the box is in play
    assert all(successes) if iter_max == 0 else not any(successes)  # 2 iterations never converge here


def test_without_a_compiler_the_sqp_calls_casadis_plugin(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.delenv("CC", raising=False)
    monkeypatch.setenv("PATH", str(tmp_path))  # no gcc, no cc
    qp = make_qp("test_qp", ca.Sparsity.diag(NZ + NU + NZ), ca.Sparsity(NZ, NZ + NU + NZ), 1, 0)
    assert native_qp(qp) == (None, "no C compiler ($CC, gcc or cc)")
    cfg = NmpcConfig(horizon=6, solver="asrti", rti_codegen="auto")
    with RollAwareNmpc(cfg, otter_parameters(), WAVES) as nmpc:
        assert nmpc._backend.sqp.native is None and nmpc._backend.sqp.native_how.startswith("no C compiler")
        x = np.zeros(12)
        x[5], x[6] = math.pi / 2, 1.0
        first = nmpc.solve(x, 0.0, (85.0, 75.0))
        step = nmpc.solve(first.states[1], 0.1, (85.0, 75.0))
    assert step.success and step.status.startswith("RTI") and np.all(np.isfinite(step.tau))


@pytest.mark.skipif(compiler() is None or hpipm_location()[0] is None, reason="no C compiler or no HPIPM headers")
def test_the_compiled_sqp_flies_the_plugins_closed_loop() -> None:
    """asrti with the compiled linearisation and conic gives the run CasADi's Functions give, to the bit."""
    metrics = {}
    for codegen in ("off", "auto"):
        mapping = _beam("asrti")
        mapping["controller"]["rti_codegen"] = codegen
        metrics[codegen] = run_scenario(scenario_from_mapping(mapping, "test"), None, plots=False).metrics
    assert metrics["auto"]["failures"] == 0 and metrics["auto"]["steps"] > 50
    assert figures(metrics["auto"]) == figures(metrics["off"])  # every figure but the timings, exactly
