"""The native RTI (solver ``nrti``): its kernels against CasADi's QP solvers, its whole Balanced run
against asrti's (within 1 % on average roll and arrival, inputs never NaN; asrti's own run matches converged
IPOPT, and bench/nmpc_solve.py prints the three side by side), and its fallback where no C compiler exists.
"""

from __future__ import annotations

import csv
import dataclasses
import logging
import math
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from mavbridge.lab.experiment import run_scenario
from mavbridge.lab.scenario import Scenario, load_scenarios
from mavbridge.nmpc import NmpcConfig, RollAwareNmpc
from mavbridge.nmpc.layout import NU, NX
from mavbridge.nmpc.solvers.codegen import CACHE_ENV, HOT_FLAGS, compiled_library, compiler, load
from mavbridge.nmpc.solvers.gauss_newton import NZ
from mavbridge.nmpc.solvers.native_lib import BoxQp, native_library, ptr
from vessel import RegularWaves, otter_parameters

ROOT = Path(__file__).resolve().parents[2]
WAVES = RegularWaves(1.75, 35.0, 6.0, -math.pi / 2)
needs_compiler = pytest.mark.skipif(compiler() is None, reason="the native kernels need a C compiler")


def _qrqp(H: ca.DM, g: np.ndarray, A: ca.DM | None, lba: np.ndarray | None, lbx: np.ndarray,
          ubx: np.ndarray) -> np.ndarray:
    """The QP solved by CasADi's own active-set solver (the reference)."""
    sp = {"h": ca.DM(H).sparsity()} | ({"a": ca.DM(A).sparsity()} if A is not None else {})
    qp = ca.conic("reference", "qrqp", sp, {"print_iter": False, "print_header": False, "print_info": False})
    args = {"h": H, "g": g, "lbx": lbx, "ubx": ubx} | ({"a": A, "lba": lba, "uba": lba} if A is not None else {})
    return np.asarray(qp(**args)["x"]).ravel()


@needs_compiler
def test_box_qp_solves_random_problems_from_a_wrong_guess() -> None:
    lib, how = native_library()
    assert lib is not None, how
    rng = np.random.default_rng(5)
    n = 30
    box = BoxQp(lib, n, 60, 1e-10)
    for _ in range(5):
        M = rng.normal(size=(n, n))
        H = M @ M.T + 0.5 * np.eye(n)
        g = rng.normal(size=n) * 10
        lo, hi = -rng.uniform(0.1, 1, n), rng.uniform(0.1, 1, n)
        state = np.ones(n, np.intc)  # everything at its upper bound: most of the guess is wrong
        x, status = box.solve(H, g, lo, hi, state)
        assert status > 0
        reference = _qrqp(ca.DM(H), g, None, None, lo, hi)
        np.testing.assert_allclose(x, reference, atol=1e-6)
        assert np.sum(state != 0) > 0  # some bounds are active, so the pivoting had work to do


def _eliminated(AB: np.ndarray, Hs: np.ndarray, gs: np.ndarray, gap: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(Hc, gc, Gc) by eliminating the states explicitly: Δz_k = Γ_k ΔU + Φ_k dz0 + c_k, then the stage
    costs summed over v_k = T_k ΔU + ... (the textbook construction, cubic in the horizon)."""
    N, nzu, nz = AB.shape
    nu, n = nzu - nz, AB.shape[0] * (nzu - nz)
    Gam, Phi, c = np.zeros((nz, n)), np.eye(nz), np.zeros(nz)
    Hc, gc, Gc = np.zeros((n, n)), np.zeros(n), np.zeros((n, nz))
    for k in range(N + 1):
        E = np.zeros((nu, n))
        if k < N:
            E[:, k * nu:(k + 1) * nu] = np.eye(nu)
        T, F, v0 = np.vstack([Gam, E]), np.vstack([Phi, np.zeros((nu, nz))]), np.concatenate([c, np.zeros(nu)])
        H = Hs[k].T
        Hc += T.T @ H @ T
        gc += T.T @ (H @ v0 + gs[k])
        Gc += T.T @ H @ F
        if k < N:
            M = AB[k].T  # nz x nzu, [A_k B_k]
            Gam = M[:, :nz] @ Gam + M[:, nz:] @ E
            Phi, c = M[:, :nz] @ Phi, M[:, :nz] @ c + gap[k]
    return Hc, gc, Gc


@needs_compiler
def test_condensing_equals_the_explicit_elimination_on_a_random_problem() -> None:
    """The C recursion (quadratic in N) against the cubic textbook elimination, with A's zero rows and
    columns (as u_prev's) and dense ones elsewhere, a terminal cost, and a nonzero gap."""
    lib, how = native_library()
    assert lib is not None, how
    rng = np.random.default_rng(11)
    N, nz, nu = 7, 6, 2
    nzu, n = nz + nu, N * nu
    AB = rng.normal(scale=0.5, size=(N, nzu, nz))  # [k, column, row]: CasADi's column-major blocks
    AB[:, :, 4] = 0.0  # a zero row of A (and of B) ...
    AB[:, 5, :] = 0.0  # ... and a zero column of A, as the augmented u_prev's
    L = rng.normal(size=(N + 1, nzu, nzu))
    Hs = np.einsum("kij,klj->kil", L, L) + 0.1 * np.eye(nzu)  # symmetric positive definite
    Hs[N, nz:, :] = Hs[N, :, nz:] = 0.0  # the terminal block: states only
    gs, gap = rng.normal(size=(N + 1, nzu)), rng.normal(size=(N, nz))
    gs[N, nz:] = 0.0
    arrays = [np.ascontiguousarray(a.ravel()) for a in (AB, Hs, gs, gap)]
    Gam, Phi, c = np.zeros((N + 1) * nz * n), np.zeros((N + 1) * nz * nz), np.zeros((N + 1) * nz)
    Hc, gc, Gc = np.zeros(n * n), np.zeros(n), np.zeros(n * nz)
    tmp = np.zeros(4 * nz * nz + 2 * nz + 2 * nu * nz)
    assert lib.nrti_condense(N, nz, nu, *(ptr(a) for a in (*arrays, Gam, Phi, c, Hc, gc, Gc, tmp))) == 0
    want_H, want_g, want_G = _eliminated(AB, Hs, gs, gap)
    np.testing.assert_allclose(Hc.reshape(n, n), want_H, rtol=1e-10, atol=1e-9)
    np.testing.assert_allclose(gc, want_g, rtol=1e-10, atol=1e-9)
    np.testing.assert_allclose(Gc.reshape(n, nz), want_G, rtol=1e-10, atol=1e-9)


@needs_compiler
def test_feedback_equals_the_sparse_qp_for_a_measured_state() -> None:
    cfg = NmpcConfig(horizon=8, solver="nrti", rti_codegen="off")
    x0 = np.zeros(12)
    x0[5], x0[6] = 0.5, 1.0
    waypoint = np.array([40.0, 10.0])
    with RollAwareNmpc(cfg, otter_parameters(), WAVES) as nmpc:
        nmpc.prepare(x0, 0.0, waypoint)
        backend = nmpc._backend
        qp = backend.advanced.take(nmpc._parameters(x0, 0.0, waypoint))[0]
        assert qp is not None, "the preparation after the cold solve gave no QP"
        measured = x0 + np.array([0.05, -0.03, 0.01, 0.02, -0.01, 0.03, 0.1, 0.02, 0.0, 0.02, 0.0, -0.02])
        p = nmpc._parameters(measured, 0.0, waypoint)
        outcome = backend.feedback(qp, p, np.zeros(1), np.zeros(1))
        assert outcome is not None and outcome.usable
        # The reference: the same Gauss–Newton QP (the sparse linearisation at the prepared plan) with the
        # initial state fixed at the measurement, solved by qrqp.
        H, g, A, gap = nmpc._functions.linearisation(qp.w_aug, qp.p)
        dz0 = np.concatenate([measured - qp.w_aug[:NX], np.zeros(NU)])
        lbw, ubw = np.full(qp.w_aug.size, -np.inf), np.full(qp.w_aug.size, np.inf)
        for k in range(cfg.horizon):
            u = slice(k * (NZ + NU) + NZ, (k + 1) * (NZ + NU))
            lbw[u], ubw[u] = (cfg.tau_x_min_n, -cfg.tau_n_max_nm), (cfg.tau_x_max_n, cfg.tau_n_max_nm)
        lbx, ubx = lbw - qp.w_aug, ubw - qp.w_aug
        lbx[:NZ] = ubx[:NZ] = dz0
        step = _qrqp(H, np.asarray(g).ravel(), A, -np.asarray(gap).ravel(), lbx, ubx)
        reference = backend.solve_plan(dataclasses.replace(qp, w_aug=qp.w_aug + step))
        np.testing.assert_allclose(outcome.w, reference, atol=1e-5)
        assert np.max(np.abs(outcome.w - backend.solve_plan(qp))) > 1e-3  # the measurement moved the plan


@needs_compiler
def test_the_feedback_from_the_preparations_factor_is_the_feedback_that_factors() -> None:
    """The preparation keeps its last QP's factor at the active set the feedback starts from (issue 32): the
    feedback's first iteration then only substitutes, and gives bit for bit what factoring gives, whether the
    measurement keeps the active set or moves it."""
    cfg = NmpcConfig(horizon=8, solver="nrti")
    x0, waypoint = np.zeros(12), np.array([40.0, 10.0])
    x0[5], x0[6] = 0.5, 1.0
    with RollAwareNmpc(cfg, otter_parameters(), WAVES) as nmpc:
        nmpc.prepare(x0, 0.0, waypoint)
        backend, p = nmpc._backend, nmpc._parameters(x0, 0.0, waypoint)
        preparation = backend.advanced.preparation
        qp, p_next, _, _ = preparation(nmpc._w, p, np.array([cfg.tau_x_max_n, 0.0]))
        assert qp is not None and qp.factor is not None
        factoring = preparation.condenser.bind(qp, factor=None)
        with pytest.raises(ValueError, match="read-only"):
            qp.state0[0] = 1  # the factor is of this active set's free block
        rng, pivots, none = np.random.default_rng(3), set(), np.zeros(1)
        for scale in (0.0, 0.02, 0.2, 1.0, 3.0, 10.0):
            measured = p_next.copy()
            measured[:NX] += scale * rng.normal(size=NX)
            kept, factored = (backend.feedback(q, measured, none, none) for q in (qp, factoring))
            assert kept is not None and factored is not None
            assert np.array_equal(kept.w, factored.w) and kept.stats == factored.stats, scale
            pivots.add(kept.stats["qp_pivots"])
        assert 1 in pivots and max(pivots) > 1, pivots  # the active set kept, and moved
        bogus = preparation.condenser.bind(qp, factor=2.0 * qp.factor)  # the factor is what the first step uses
        assert not np.array_equal(backend.feedback(bogus, p_next, none, none).w, backend.feedback(qp, p_next, none,
                                                                                                none).w)


@needs_compiler
@pytest.mark.parametrize("codegen", ["off", "auto"])  # the SQP iterated from Python, and in one C call
def test_a_paced_preparation_stops_at_its_budget_and_hands_over_its_last_qp(codegen: str) -> None:
    """Paced at a wall period (a companion in real time), a step waits a quarter of it for the background and
    the preparation iterates for three quarters, then hands over the QP of its last iteration; unpaced (lockstep,
    experiments) nothing is timed and the preparation converges."""
    cfg = NmpcConfig(horizon=8, solver="nrti", rti_codegen=codegen)
    x0, waypoint = np.zeros(12), np.array([40.0, 10.0])
    with RollAwareNmpc(cfg, otter_parameters(), WAVES) as nmpc:
        nmpc.prepare(x0, 0.0, waypoint)
        advanced = nmpc._backend.advanced
        preparation = advanced.preparation
        assert advanced.wait_s == cfg.as_wait_s and preparation.budget_s == math.inf
        nmpc.pace(0.1)
        assert advanced.wait_s == pytest.approx(0.025) and preparation.budget_s == pytest.approx(0.075)
        p = nmpc._parameters(x0, 0.0, waypoint)
        u_far = np.array([cfg.tau_x_min_n, cfg.tau_n_max_nm])  # full astern, hard over: the plan must change
        preparation.budget_s = math.inf
        _, _, _, converged_iterations = preparation(nmpc._w, p, u_far)
        nmpc.pace(0.0)  # no time at all: one iteration, and its QP
        qp, p_next, _, iterations = preparation(nmpc._w, p, u_far)
        assert converged_iterations > 1, "the test's input did not make the preparation iterate"
        assert iterations == 1 and qp is not None and qp.guess_status > 0
        np.testing.assert_array_equal(qp.p, p_next)


def _run_metrics(scenario: Scenario, out: str | None) -> dict:
    return run_scenario(scenario, out, plots=False).metrics


@needs_compiler
@pytest.mark.slow
def test_nrti_balanced_run_is_within_one_percent_of_asrti(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The same closed loop as asrti (whose run matches converged IPOPT to 0.4 % roll and 0.2 % arrival:
    bench/nmpc_solve.py prints all three side by side; IPOPT's run takes minutes, so CI compares with asrti).
    The two runs side by side, one process each (as Table III's test)."""
    balanced = next(s for s in load_scenarios(ROOT / "scenarios" / "balanced.yaml") if s.name == "balanced")
    nrti = dataclasses.replace(balanced, controller=balanced.controller.replace(solver="nrti"))
    asrti = dataclasses.replace(balanced, controller=balanced.controller.replace(solver="asrti"))
    monkeypatch.setenv("OMP_NUM_THREADS", "1")  # the children's (spawned: they read it at start)
    with ProcessPoolExecutor(max_workers=2, mp_context=get_context("spawn")) as pool:
        reference_run = pool.submit(_run_metrics, asrti, None)
        m = pool.submit(_run_metrics, nrti, str(tmp_path)).result()
        reference = reference_run.result()
    assert reference["time_to_waypoint_s"] is not None, "the asrti reference never reached the waypoint"
    assert m["time_to_waypoint_s"] is not None, "nrti never reached the waypoint"
    assert m["avg_roll_deg"] == pytest.approx(reference["avg_roll_deg"], rel=0.01)
    assert m["time_to_waypoint_s"] == pytest.approx(reference["time_to_waypoint_s"], rel=0.01)
    assert m["failures"] == 0
    with open(tmp_path / "timeseries.csv", newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["tau_x_n"] not in ("", None)]
    taus = np.array([[float(r["tau_x_n"]), float(r["tau_n_nm"])] for r in rows])
    assert len(taus) == m["steps"] and np.all(np.isfinite(taus))


def test_without_a_compiler_nrti_runs_as_asrti_and_says_so_once(monkeypatch: pytest.MonkeyPatch, tmp_path: Path,
                                                                  caplog: pytest.LogCaptureFixture) -> None:
    from mavbridge.nmpc.solvers import nrti

    monkeypatch.delenv("CC", raising=False)
    monkeypatch.setenv("PATH", str(tmp_path))  # no gcc, no cc
    monkeypatch.setattr(nrti, "_SAID", set())
    cfg = NmpcConfig(horizon=6, solver="nrti", rti_codegen="off")
    x0 = np.zeros(12)
    x0[6] = 1.0
    with caplog.at_level(logging.WARNING, logger="mavbridge.nmpc.solvers.nrti"):
        for _ in range(2):
            with RollAwareNmpc(cfg, otter_parameters(), WAVES) as nmpc:
                assert nmpc._backend.buffers is None  # no native kernels
                nmpc.prepare(x0, 0.0, [40.0, 10.0])
                results = [nmpc.solve(x0, 0.1 * k, [40.0, 10.0]) for k in range(3)]
    assert all(r.success and np.all(np.isfinite(r.tau)) for r in results)
    assert all(r.status.startswith("RTI") for r in results)  # asrti's step
    notices = [r for r in caplog.records if "running as asrti" in r.getMessage()]
    assert len(notices) == 1, [r.getMessage() for r in caplog.records]


@needs_compiler
def test_a_library_built_with_other_flags_is_another_cached_library(tmp_path: Path,
                                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    """The cache key names the compiler flags: the hot functions' -O3 build never answers for an -O1 one (or back),
    and both compute the same bits (no contraction, no fast math: the loop's figures rest on it)."""
    monkeypatch.setenv(CACHE_ENV, str(tmp_path))
    x = ca.SX.sym("x", 3)
    fn = ca.Function("flags_probe", [x], [ca.sin(x[0]) * x[1] + x[2] / (1.0 + x[0] ** 2) + ca.sqrt(x[1] ** 2 + 1e-4)])
    plain, _ = compiled_library(fn)
    hot, _ = compiled_library(fn, HOT_FLAGS)
    assert plain is not None and hot is not None and plain != hot
    assert sorted(path.name for path in tmp_path.glob("*.so")) == sorted([plain.name, hot.name])
    points = np.random.default_rng(3).normal(size=(200, 3))
    answers = [np.array([float(load(fn, lib)(point)) for point in points]) for lib in (plain, hot)]
    assert answers[0].tobytes() == answers[1].tobytes()


@needs_compiler
def test_the_condensers_gather_is_the_augmented_layout() -> None:
    """``Condenser.augment`` (the SQP iterations' one gather into the condenser's own array) puts a plan in place
    exactly as ``GaussNewtonSqp.to_aug`` makes it, byte for byte, and ``iterate`` then linearises there."""
    cfg = NmpcConfig(horizon=5, solver="nrti")
    with RollAwareNmpc(cfg, otter_parameters(), WAVES) as nmpc:
        preparation = nmpc._backend.advanced.preparation
        condenser, sqp = preparation.condenser, preparation.solve.sqp
        rng = np.random.default_rng(7)
        for _ in range(3):
            w, u_prev = rng.normal(size=(cfg.horizon + 1) * NX + cfg.horizon * NU), rng.normal(size=NU)
            condenser.augment(w, u_prev)
            assert condenser.w_aug.tobytes() == sqp.to_aug(w, u_prev).tobytes()
        np.testing.assert_array_equal(sqp.from_aug(condenser.w_aug), w)


@needs_compiler
def test_the_sqp_in_one_c_call_is_the_python_loop_bit_for_bit(monkeypatch: pytest.MonkeyPatch) -> None:
    """``Condenser.converge`` (nrti_converge: the whole preparation SQP in C) and the loop over ``Condenser.iterate``
    (kept for a linearisation in CasADi's virtual machine) make the same C calls: the same iterations and the same
    prepared QP, byte for byte, from a start that needs several iterations."""
    cfg = NmpcConfig(horizon=8, solver="nrti")
    x0, waypoint = np.zeros(12), np.array([40.0, 10.0])
    x0[5], x0[6] = 0.5, 1.0
    with RollAwareNmpc(cfg, otter_parameters(), WAVES) as nmpc:
        nmpc.prepare(x0, 0.0, waypoint)
        preparation = nmpc._backend.advanced.preparation
        p = nmpc._parameters(x0, 0.0, waypoint)
        u_far = np.array([cfg.tau_x_min_n, cfg.tau_n_max_nm])  # full astern, hard over: the plan must change
        native = preparation(nmpc._w, p, u_far)
        monkeypatch.setattr(preparation.condenser, "converge", lambda *args: None)  # as with no compiled code
        looped = preparation(nmpc._w, p, u_far)
    (qp, _, _, iterations), (qp_looped, _, _, iterations_looped) = native, looped
    assert qp is not None and qp_looped is not None
    assert iterations == iterations_looped > 1
    for a, b in zip(qp.arrays, qp_looped.arrays, strict=True):
        assert a.tobytes() == b.tobytes()
    m = int(np.count_nonzero(qp.state0 == 0))  # the factor: its m x m lower triangle (the rest is never read)
    lower = [np.tril(f[:m * m].reshape(m, m)) for f in (qp.factor, qp_looped.factor)]
    assert lower[0].tobytes() == lower[1].tobytes()
