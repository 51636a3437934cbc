"""Gauss–Newton SQP for the paper's problem: the QP data (linearisation) and the iteration with HPIPM.

The cost is the IPOPT problem's written as squared residuals, so the Gauss–Newton Hessian 2JᵀJ is
positive semi-definite by construction:
    √W·ΔU_k, √Q·e_ψ, √R·φ, √(S·d), √w_min·smoothmax(0, u_min − u) (and √w_e·the heading error's excess over its
    limit, where one is set)
(the linear distance term as a square root, the min-speed kink smoothed with (z + √(z² + ε))/2).
HPIPM wants stage-separable costs, and ΔU_k couples u_k with u_{k−1}: the state is augmented with the
previous input, z = [x (12), u_prev (2)], u_prev,k+1 = u_k. Gaps are F(z_k, u_k) − z_{k+1}; the QP is
solved in the step Δw with bounds lbw − w ≤ Δw ≤ ubw − w and full steps.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from pathlib import Path

import casadi as ca
import numpy as np

from mavbridge.nmpc.config import NmpcConfig
from mavbridge.nmpc.inputs import InputSpace, input_space, input_tau
from mavbridge.nmpc.layout import (
    NU,
    NX,
    PARAMS,
    ROLL_SPREAD_NAMES,
    WEIGHT_NAMES,
    members,
    parameter_layout,
    wave_input_size,
)
from mavbridge.nmpc.problem import (
    distance,
    expected_roll_residuals,
    heading_error,
    heading_excess,
    min_speed,
    roll_fade,
)
from mavbridge.nmpc.solvers.codegen import cache_dir, compiler
from mavbridge.nmpc.solvers.hpipm_native import NativeQp, qp_library, solve_natively
from mavbridge.nmpc.solvers.native_lib import CompiledFunction

NZ = NX + NU
SMOOTH_EPS = 1e-4
DIST_SQRT_EPS = 1e-9
HESSIAN_REG = 1e-8
# Stage Functions with CasADi's common-subexpression elimination: the model and its Jacobian repeat the same sines,
# cosines and products (nrti's stage: 118 trigonometric calls, 30 distinct), each now computed once (the same
# operations on the same operands: the same bits)
CSE = {"cse": True}


def _smooth_max0(z: ca.SX) -> ca.SX:
    return 0.5 * (z + ca.sqrt(z**2 + SMOOTH_EPS))


def _state_residuals(x: ca.SX, waypoint: ca.SX, weights: ca.SX, cfg: NmpcConfig, roll_spread: ca.SX) -> ca.SX:
    """√Q·e_ψ, √R·φ, √(S·d), √w_min·smoothmax(0, u_min − u), Lᵀy: their squares sum to the state cost."""
    w = members("weights", weights)
    q, r, s = w["q"], w["r"], w["s"]
    fade = roll_fade(x, waypoint, cfg)
    residuals = [ca.sqrt(q) * heading_error(x, waypoint), ca.sqrt(r) * fade * x[3],
                 ca.sqrt(s * distance(x, waypoint) + DIST_SQRT_EPS),
                 np.sqrt(cfg.min_speed_weight) * _smooth_max0(min_speed(x, waypoint, cfg) - x[6]),
                 fade * expected_roll_residuals(x, roll_spread)]
    if cfg.heading_limit_deg > 0:
        residuals.append(np.sqrt(cfg.heading_limit_weight) * heading_excess(x, waypoint, cfg))
    return ca.vertcat(*residuals)


def _input_change_residuals(u: ca.SX, u_before: ca.SX, weights: ca.SX,
                            matrix: np.ndarray | None = None) -> list[ca.SX]:
    """√W11·Δτ_X, √W22·Δτ_N; u_before is the augmented state's previous input z[NX:NZ]; Δτ = B·Δu for
    propeller-thrust inputs (``matrix`` B), Δu itself when u is τ."""
    w = members("weights", weights)
    if matrix is None:
        return [ca.sqrt(w["w_dtau_x"]) * (u[0] - u_before[0]), ca.sqrt(w["w_dtau_n"]) * (u[1] - u_before[1])]
    dtau = input_tau(u - u_before, matrix)
    return [ca.sqrt(w["w_dtau_x"]) * dtau[0], ca.sqrt(w["w_dtau_n"]) * dtau[1]]


def linearisation_inlined(step: ca.Function, cfg: NmpcConfig, matrix: np.ndarray | None = None) -> ca.Function:
    """(w_aug, p) -> (H, g, A, gaps), one SX expression over the whole horizon (reference version);
    ``matrix`` B of propeller-thrust inputs or None (u is τ)."""
    P = cfg.horizon
    n = P * (NZ + NU) + NZ
    w = ca.SX.sym("w", n)
    blocks = parameter_layout(cfg.wave_components)
    p = ca.SX.sym("p", blocks.size)
    par = blocks.unpack(p)
    t0, waypoint, weights, wave, spread = par.t, par.waypoint, par.weights, blocks.wave_input(p), par.roll_spread

    def z_at(k: int) -> ca.SX:
        return w[k * (NZ + NU):k * (NZ + NU) + NZ]

    def u_at(k: int) -> ca.SX:
        return w[k * (NZ + NU) + NZ:(k + 1) * (NZ + NU)]

    residuals, gaps = [], []
    for k in range(P):
        z, u, z_next = z_at(k), u_at(k), z_at(k + 1)
        gaps.append(ca.vertcat(step(z[0:NX], u, t0 + k * cfg.period_s, wave), u) - z_next)
        residuals += [*_input_change_residuals(u, z[NX:NZ], weights, matrix),
                      _state_residuals(z_next[0:NX], waypoint, weights, cfg, spread)]
    res = ca.vertcat(*residuals)
    gap = ca.vertcat(*gaps)
    J = ca.jacobian(res, w)
    H = 2 * (J.T @ J) + HESSIAN_REG * ca.SX.eye(n)
    g = 2 * (J.T @ res)
    A = ca.jacobian(gap, w)
    return ca.Function("rti_linearisation", [w, p], [H, g, A, gap], ["w", "p"], ["H", "g", "A", "gap"])


def linearisation(step: ca.Function, cfg: NmpcConfig, matrix: np.ndarray | None = None) -> ca.Function:
    """(w_aug, p) -> (H, g, A, gaps): Gauss–Newton QP data at w_aug for the augmented OCP (``matrix``: B of
    propeller-thrust inputs, None when u is τ).

    One stage function (dynamics, its Jacobians, the stage's Gauss–Newton cost block) is written in SX
    and mapped over the horizon; the blocks are assembled in MX. Generated code holds the stage once
    (small C file, fast to compile) and gives the same numbers as ``linearisation_inlined``.
    """
    P = cfg.horizon
    z, u, t = ca.SX.sym("z", NZ), ca.SX.sym("u", NU), ca.SX.sym("t")
    on = ca.SX.sym("on")  # 0 for stage 0: the cost has no term on the fixed initial state
    waypoint, weights = ca.SX.sym("wp", 2), ca.SX.sym("weights", len(WEIGHT_NAMES))
    wave = ca.SX.sym("wave", wave_input_size(cfg.wave_components))
    spread = ca.SX.sym("roll_spread", len(ROLL_SPREAD_NAMES))
    f_aug = ca.vertcat(step(z[0:NX], u, t, wave), u)
    res = ca.vertcat(*_input_change_residuals(u, z[NX:NZ], weights, matrix),
                     on * _state_residuals(z[0:NX], waypoint, weights, cfg, spread))
    zu = ca.vertcat(z, u)
    J = ca.jacobian(res, zu)
    stage = ca.Function("rti_stage", [z, u, t, on, waypoint, weights, wave, spread],
                        [f_aug, ca.jacobian(f_aug, zu), 2 * (J.T @ J), 2 * (J.T @ res)], CSE)
    r_end = _state_residuals(z[0:NX], waypoint, weights, cfg, spread)
    J_end = ca.jacobian(r_end, z)
    terminal = ca.Function("rti_terminal", [z, waypoint, weights, spread],
                           [2 * (J_end.T @ J_end), 2 * (J_end.T @ r_end)], CSE)

    n = P * (NZ + NU) + NZ
    w = ca.MX.sym("w", n)
    blocks = parameter_layout(cfg.wave_components)
    p = ca.MX.sym("p", blocks.size)
    par = blocks.unpack(p)
    t0, wp, wts, wv, spread_p = par.t, par.waypoint, par.weights, blocks.wave_input(p), par.roll_spread
    W = ca.reshape(w[0:P * (NZ + NU)], NZ + NU, P)
    Z, U = W[0:NZ, :], W[NZ:, :]
    z_end = w[P * (NZ + NU):]
    Z_next = ca.horzcat(Z[:, 1:], z_end)
    times = t0 + ca.DM(np.arange(P) * cfg.period_s).T
    flags = ca.DM([[0.0] + [1.0] * (P - 1)])
    F, AB, Hs, gs = stage.map(P)(Z, U, times, flags, ca.repmat(wp, 1, P), ca.repmat(wts, 1, P),
                                 ca.repmat(wv, 1, P), ca.repmat(spread_p, 1, P))
    H_end, g_end = terminal(z_end, wp, wts, spread_p)
    gap = ca.vec(F - Z_next)
    AB_blocks = ca.horzsplit(AB, list(range(0, P * (NZ + NU) + 1, NZ + NU)))
    shift = np.zeros((NZ * P, n))  # the −I blocks of x_{k+1} in the gap rows
    for k in range(P):
        col = (k + 1) * (NZ + NU)
        shift[k * NZ:(k + 1) * NZ, col:col + NZ] = -np.eye(NZ)
    A = ca.horzcat(ca.diagcat(*AB_blocks), ca.MX(NZ * P, NZ)) + ca.sparsify(ca.DM(shift))
    H_blocks = ca.horzsplit(Hs, list(range(0, P * (NZ + NU) + 1, NZ + NU)))
    H = ca.diagcat(*H_blocks, H_end) + HESSIAN_REG * ca.DM.eye(n)
    g = ca.vertcat(ca.vec(gs), g_end)
    return ca.Function("rti_linearisation", [w, p], [H, g, A, gap], ["w", "p"], ["H", "g", "A", "gap"])




def make_qp(name: str, H_sp: ca.Sparsity, A_sp: ca.Sparsity, horizon: int, iter_max: int) -> ca.Function:
    """An HPIPM conic for the augmented OCP (speed_abs mode; ``iter_max`` 0 keeps HPIPM's default cap)."""
    hpipm: dict = {"mode": "speed_abs"}
    if iter_max > 0:
        hpipm["iter_max"] = iter_max
    return ca.conic(name, "hpipm", {"h": H_sp, "a": A_sp},
                    {"N": horizon, "nx": [NZ] * (horizon + 1), "nu": [NU] * horizon + [0], "ng": [0] * (horizon + 1),
                     "hpipm": hpipm, "error_on_fail": False, "print_problem": False, "print_time": False})


CONICS_KEPT = 16
_CONICS: OrderedDict[tuple, tuple[ca.Function, Path | None, str]] = OrderedDict()
_CONICS_LOCK = threading.Lock()


def shared_conic(name: str, H_sp: ca.Sparsity, A_sp: ca.Sparsity, horizon: int,
                 iter_max: int) -> tuple[ca.Function, Path | None, str]:
    """(``make_qp``'s conic, its compiled library or None, how), built once per process for each key: the
    sparsities serialised and the other arguments of ``make_qp`` (all the conic and its generated source depend on),
    the compiler and the cache directory ``qp_library`` uses. Deterministic and immutable: every SQP of a run, and
    every run of a tune, would build the same one again. The conic Function is shared only to be compiled and to
    size a ``NativeQp`` (which owns its buffers); an SQP that calls it as CasADi's plugin builds its own
    (``make_qp``). A compile that failed is not kept (a full disk or a timeout under load passes; the next NMPC
    tries again); a settled answer (no compiler, no HPIPM headers) is."""
    key = (name, H_sp.serialize(), A_sp.serialize(), horizon, iter_max, compiler(), cache_dir())
    with _CONICS_LOCK:
        if key in _CONICS:
            _CONICS.move_to_end(key)
            return _CONICS[key]
    qp = make_qp(name, H_sp, A_sp, horizon, iter_max)
    library, how = qp_library(qp)
    if library is not None or "failed" not in how:
        with _CONICS_LOCK:
            _CONICS[key] = (qp, library, how)
            while len(_CONICS) > CONICS_KEPT:
                _CONICS.popitem(last=False)
    return qp, library, how


def clear_conics() -> int:
    """Forget the kept conics (for tests); how many there were."""
    with _CONICS_LOCK:
        n = len(_CONICS)
        _CONICS.clear()
        return n


class GaussNewtonSqp:
    """Full-step Gauss–Newton SQP with its own linearisation and QP instances (one per thread of use).

    Where a C compiler is found (and ``rti_codegen`` is "auto") both run as compiled C called on numpy buffers
    (``native_lib.CompiledFunction``, ``hpipm_native``): the same code on the same numbers as CasADi's calls of the
    linearisation and the HPIPM plugin, without their per-call conversions. Otherwise they are CasADi Functions.
    With the compiled conic, ``qp`` is the process's shared conic Function (``shared_conic``), kept for its shape
    and never called: only an SQP without ``native`` calls ``qp``, and that one is its own."""

    def __init__(self, lin: ca.Function, cfg: NmpcConfig, qp_name: str, qp_iter_max: int,
                 space: InputSpace | None = None, lin_library: Path | None = None) -> None:
        """``space``: the inputs' box (default: the τ box, for τ inputs only); ``lin_library``: ``lin`` compiled
        (called through its C API when given)."""
        P = cfg.horizon
        space = space or input_space(cfg, None)
        self.cfg = cfg
        self.lin = lin
        self.n = P * (NZ + NU) + NZ
        self.u_mask = np.zeros(self.n, bool)
        self.lb = np.full(self.n, -np.inf)
        self.ub = np.full(self.n, np.inf)
        for k in range(P):
            u = slice(k * (NZ + NU) + NZ, (k + 1) * (NZ + NU))
            self.u_mask[u] = True
            self.lb[u] = space.low
            self.ub[u] = space.high
        self.native: NativeQp | None = None
        self.native_how = "CasADi's plugin (rti_codegen off)"
        qp: ca.Function | None = None
        if cfg.rti_codegen == "auto":  # the conic and its library from this process's cache; the buffers its own
            qp, library, how = shared_conic(qp_name, lin.sparsity_out(0), lin.sparsity_out(2), P, qp_iter_max)
            self.native, self.native_how = solve_natively(library, how, qp)
        # the conic: called as CasADi's plugin (its work memory and stats are this instance's) without a native one
        own = self.native is None or qp is None
        self.qp = make_qp(qp_name, lin.sparsity_out(0), lin.sparsity_out(2), P, qp_iter_max) if own else qp
        self.native_lin: CompiledFunction | None = None
        self._w, self._p = np.zeros(self.n), np.zeros(lin.nnz_in(1))  # the native linearisation's inputs
        if self.native is not None and lin_library is not None:
            self.native_lin = CompiledFunction(lin_library, lin.name(), [lin.nnz_out(i) for i in range(4)],
                                               [lin.nnz_in(0), lin.nnz_in(1)])
            self.native_lin.bind(self._w, self._p)
        # where the nonzeros of g and of the gaps go in the QP's dense g, lba and uba (structural zeros stay +0.0,
        # as when CasADi densifies them)
        self._g_rows = np.array(lin.sparsity_out(1).row(), int)
        self._gap_rows = np.array(lin.sparsity_out(3).row(), int)

    def to_aug(self, w: np.ndarray, u_applied: np.ndarray) -> np.ndarray:
        """Augmented decision vector from the controller's layout."""
        P = self.cfg.horizon
        stages = w[:P * (NX + NU)].reshape(P, NX + NU)
        U = stages[:, NX:]
        u_prev = np.vstack([u_applied, U])
        body = np.hstack([stages[:, :NX], u_prev[:P], U]).ravel()
        return np.concatenate([body, w[P * (NX + NU):], u_prev[P]])

    def from_aug(self, w_aug: np.ndarray) -> np.ndarray:
        """The controller's layout from the augmented vector."""
        P = self.cfg.horizon
        stages = w_aug[:P * (NZ + NU)].reshape(P, NZ + NU)
        body = np.hstack([stages[:, :NX], stages[:, NZ:]]).ravel()
        return np.concatenate([body, w_aug[P * (NZ + NU):P * (NZ + NU) + NX]])

    def iterate(self, w0: np.ndarray, p: np.ndarray, min_iter: int, max_iter: int,
                step_tol: float) -> tuple[np.ndarray | None, list[bool], float, str]:
        """SQP from w0 (controller layout), x0 and u_prev fixed by bounds: (w or None, QP successes,
        the last gap violation, error text). Stops after ``min_iter`` once every input step ≤ ``step_tol``."""
        x0, u_applied = PARAMS.get(p, "x0"), PARAMS.get(p, "u_prev")
        w = self.to_aug(np.asarray(w0, float), u_applied)
        w[0:NX] = x0
        lb, ub = self.lb.copy(), self.ub.copy()
        lb[0:NX] = ub[0:NX] = x0
        lb[NX:NZ] = ub[NX:NZ] = u_applied
        w[NX:NZ] = u_applied
        if self.native is not None:
            return self._iterate_native(self.native, w, lb, ub, p, min_iter, max_iter, step_tol)
        p_dm = ca.DM(p)
        statuses: list[bool] = []
        violation = float("nan")
        for it in range(max_iter):
            H, g, A, gap = self.lin(ca.DM(w), p_dm)
            violation = float(np.max(np.abs(np.asarray(gap))))
            sol = self.qp(h=H, g=g, a=A, lba=-gap, uba=-gap, lbx=lb - w, ubx=ub - w)
            step = np.asarray(sol["x"]).ravel()
            stats = self.qp.stats()
            statuses.append(bool(stats.get("success", False)))
            if not np.all(np.isfinite(step)):
                return None, statuses, violation, f"RTI: QP {stats.get('return_status', 'failed')}"
            w = w + step
            if it + 1 >= min_iter and np.max(np.abs(step[self.u_mask])) <= step_tol:
                break
        return self.from_aug(w), statuses, violation, ""

    def _linearise(self, w: np.ndarray, p: np.ndarray) -> list[np.ndarray]:
        """(H, g, A, gaps) at w: each output's nonzeros."""
        if self.native_lin is None:
            return [np.array(out.nonzeros()) for out in self.lin(ca.DM(w), ca.DM(p))]
        self._w[:] = w
        return self.native_lin.call()

    def _iterate_native(self, qp: NativeQp, w: np.ndarray, lb: np.ndarray, ub: np.ndarray, p: np.ndarray,
                        min_iter: int, max_iter: int, step_tol: float) -> tuple[np.ndarray | None, list[bool], float,
                                                                                 str]:
        """``iterate``'s loop with the compiled conic (``qp``), each QP's data written into its input buffers."""
        q = qp.inputs
        self._p[:] = p
        statuses: list[bool] = []
        violation = float("nan")
        for it in range(max_iter):
            H, g, A, gap = self._linearise(w, p)
            violation = float(np.max(np.abs(gap)))
            q["h"][:], q["a"][:] = H, A
            q["g"][self._g_rows] = g
            q["lba"][self._gap_rows] = -gap
            q["uba"][self._gap_rows] = q["lba"][self._gap_rows]
            np.subtract(lb, w, out=q["lbx"])
            np.subtract(ub, w, out=q["ubx"])
            statuses.append(qp.solve())
            step = qp.x
            if not np.all(np.isfinite(step)):
                return None, statuses, violation, "RTI: QP failed"
            w = w + step
            if it + 1 >= min_iter and np.max(np.abs(step[self.u_mask])) <= step_tol:
                break
        return self.from_aug(w), statuses, violation, ""
