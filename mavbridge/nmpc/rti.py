"""A fast NMPC solver: real-time iterations of Gauss–Newton SQP with HPIPM (structure-exploiting QP).

Each period: the previous plan is shifted (by the controller), the initial state fixed, and a few SQP
iterations are taken, each one linearisation plus one QP in the step Δw. The cost is the IPOPT problem's
written as squared residuals, so the Gauss–Newton Hessian 2JᵀJ is positive semi-definite by construction:
    √W·ΔU_k, √Q·e_ψ, √R·φ, √(S·d), √w_min·smoothmax(0, u_min − u)
(the linear distance term as a square root, the min-speed kink smoothed with (z + √(z² + ε))/2).
HPIPM wants stage-separable costs, and ΔU_k couples u_k with u_{k−1}: the state is augmented with the
previous input, z = [x (12), u_prev (2)], u_prev,k+1 = u_k. The first solve (and any cold start) is a
full IPOPT solve; the linearisation is compiled to C once and cached on disk (see ``codegen``).

Advanced-step RTI (solver ``asrti``): two iterations per step do not follow the converged closed loop on
Balanced (arrival 88 s against IPOPT's 101 s): a few steps need 10–30 full-step iterations to settle, and
the decisions they settle change the approach to the waypoint. So after each step a worker thread runs the
SQP to convergence (input steps ≤ ``as_step_tol``, at most ``as_max_iterations``) for the state the model
predicts at the next sampling time, under the input just applied; the next step fixes the measured state
and takes ``as_iterations`` (1) iteration from that converged plan, which corrects for the prediction error.
"""

from __future__ import annotations

import time
from concurrent.futures import Future, ProcessPoolExecutor, ThreadPoolExecutor
from multiprocessing import get_context

import casadi as ca
import numpy as np

from .backend import SolveOutcome
from .codegen import compiled
from .config import NmpcConfig
from .ipopt import IpoptBackend
from .problem import NP, NU, NX, Layout, distance, heading_error, unpack_parameters

NZ = NX + NU
SMOOTH_EPS = 1e-4
DIST_SQRT_EPS = 1e-9
HESSIAN_REG = 1e-8


def _smooth_max0(z: ca.SX) -> ca.SX:
    return 0.5 * (z + ca.sqrt(z**2 + SMOOTH_EPS))


def _state_residuals(x: ca.SX, waypoint: ca.SX, weights: ca.SX, cfg: NmpcConfig) -> ca.SX:
    """√Q·e_ψ, √R·φ, √(S·d), √w_min·smoothmax(0, u_min − u): their squares sum to the state cost."""
    q, r, s = weights[0], weights[1], weights[2]
    return ca.vertcat(ca.sqrt(q) * heading_error(x, waypoint), ca.sqrt(r) * x[3],
                      ca.sqrt(s * distance(x, waypoint) + DIST_SQRT_EPS),
                      np.sqrt(cfg.min_speed_weight) * _smooth_max0(cfg.min_speed_mps - x[6]))


def linearisation_inlined(step: ca.Function, cfg: NmpcConfig) -> ca.Function:
    """(w_aug, p) -> (H, g, A, gaps), one SX expression over the whole horizon (reference version)."""
    P = cfg.horizon
    n = P * (NZ + NU) + NZ
    w = ca.SX.sym("w", n)
    p = ca.SX.sym("p", NP)
    _, t0, waypoint, _, weights = unpack_parameters(p)

    def z_at(k: int) -> ca.SX:
        return w[k * (NZ + NU):k * (NZ + NU) + NZ]

    def u_at(k: int) -> ca.SX:
        return w[k * (NZ + NU) + NZ:(k + 1) * (NZ + NU)]

    residuals, gaps = [], []
    for k in range(P):
        z, u, z_next = z_at(k), u_at(k), z_at(k + 1)
        gaps.append(ca.vertcat(step(z[0:NX], u, t0 + k * cfg.period_s), u) - z_next)
        residuals += [ca.sqrt(weights[3]) * (u[0] - z[NX]), ca.sqrt(weights[4]) * (u[1] - z[NX + 1]),
                      _state_residuals(z_next[0:NX], waypoint, weights, cfg)]
    res = ca.vertcat(*residuals)
    gap = ca.vertcat(*gaps)
    J = ca.jacobian(res, w)
    H = 2 * (J.T @ J) + HESSIAN_REG * ca.SX.eye(n)
    g = 2 * (J.T @ res)
    A = ca.jacobian(gap, w)
    return ca.Function("rti_linearisation", [w, p], [H, g, A, gap], ["w", "p"], ["H", "g", "A", "gap"])


def linearisation(step: ca.Function, cfg: NmpcConfig) -> ca.Function:
    """(w_aug, p) -> (H, g, A, gaps): Gauss–Newton QP data at w_aug for the augmented OCP.

    One stage function (dynamics, its Jacobians, the stage's Gauss–Newton cost block) is written in SX
    and mapped over the horizon; the blocks are assembled in MX. Generated code holds the stage once
    (small C file, fast to compile) and gives the same numbers as ``linearisation_inlined``.
    """
    P = cfg.horizon
    z, u, t = ca.SX.sym("z", NZ), ca.SX.sym("u", NU), ca.SX.sym("t")
    on = ca.SX.sym("on")  # 0 for stage 0: the cost has no term on the fixed initial state
    waypoint, weights = ca.SX.sym("wp", 2), ca.SX.sym("weights", 5)
    f_aug = ca.vertcat(step(z[0:NX], u, t), u)
    res = ca.vertcat(ca.sqrt(weights[3]) * (u[0] - z[NX]), ca.sqrt(weights[4]) * (u[1] - z[NX + 1]),
                     on * _state_residuals(z[0:NX], waypoint, weights, cfg))
    zu = ca.vertcat(z, u)
    J = ca.jacobian(res, zu)
    stage = ca.Function("rti_stage", [z, u, t, on, waypoint, weights],
                        [f_aug, ca.jacobian(f_aug, zu), 2 * (J.T @ J), 2 * (J.T @ res)])
    r_end = _state_residuals(z[0:NX], waypoint, weights, cfg)
    J_end = ca.jacobian(r_end, z)
    terminal = ca.Function("rti_terminal", [z, waypoint, weights], [2 * (J_end.T @ J_end), 2 * (J_end.T @ r_end)])

    n = P * (NZ + NU) + NZ
    w = ca.MX.sym("w", n)
    p = ca.MX.sym("p", NP)
    t0, wp, wts = p[NX], p[NX + 1:NX + 3], p[NX + 5:NX + 10]
    W = ca.reshape(w[0:P * (NZ + NU)], NZ + NU, P)
    Z, U = W[0:NZ, :], W[NZ:, :]
    z_end = w[P * (NZ + NU):]
    Z_next = ca.horzcat(Z[:, 1:], z_end)
    times = t0 + ca.DM(np.arange(P) * cfg.period_s).T
    flags = ca.DM([[0.0] + [1.0] * (P - 1)])
    F, AB, Hs, gs = stage.map(P)(Z, U, times, flags, ca.repmat(wp, 1, P), ca.repmat(wts, 1, P))
    H_end, g_end = terminal(z_end, wp, wts)
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


class RtiBackend:
    """Gauss–Newton real-time iterations with HPIPM; cold starts go to IPOPT.

    With ``background`` (solver ``asrti``, advanced-step RTI), ``start_background`` runs a converged
    Gauss–Newton SQP for the state the model predicts one period ahead, in a worker thread (its own
    Function and QP instances; CasADi releases the GIL while they run) or, with ``as_worker`` "process", in
    a worker process that builds its own copy. The next step starts its real-time
    iterations from that converged plan instead of the shifted, once-iterated one.
    """

    name = "rti"

    def __init__(self, nlp: dict, layout: Layout, cfg: NmpcConfig, step: ca.Function,
                 ipopt: IpoptBackend | None = None, background: bool = False, problem: tuple | None = None,
                 build_ipopt: bool = True) -> None:
        self.cfg = cfg
        self.layout = layout
        self.step = step
        self.problem = problem  # (params, waves, current): what a worker process needs to build its own copy
        self.ipopt = ipopt or (IpoptBackend(nlp, layout, cfg) if build_ipopt else None)
        P = cfg.horizon
        self.n = P * (NZ + NU) + NZ
        lin = linearisation(step, cfg)
        if cfg.rti_codegen == "auto":
            self.lin, self.codegen = compiled(lin)
        else:
            self.lin, self.codegen = lin, "sx-vm (codegen off)"
        self._H_sp = lin.sparsity_out(0)
        self._A_sp = lin.sparsity_out(2)
        self.qp = self._make_qp("rti_qp", cfg.rti_qp_iter_max)
        self.u_mask = np.zeros(self.n, bool)
        self.lb = np.full(self.n, -np.inf)
        self.ub = np.full(self.n, np.inf)
        for k in range(P):
            u = slice(k * (NZ + NU) + NZ, (k + 1) * (NZ + NU))
            self.u_mask[u] = True
            self.lb[u] = (cfg.tau_x_min_n, -cfg.tau_n_max_nm)
            self.ub[u] = (cfg.tau_x_max_n, cfg.tau_n_max_nm)
        self.background = background
        self._executor: ThreadPoolExecutor | ProcessPoolExecutor | None = None
        if background and cfg.as_worker == "process" and problem is None:
            raise ValueError("as_worker 'process' needs the problem (params, waves, current)")
        if background:
            # Separate instances for the worker thread, so the two threads never share a Function's memory.
            self.bg_lin = compiled(lin)[0] if cfg.rti_codegen == "auto" else linearisation(step, cfg)
            self.bg_step = self.step
            self.bg_qp = self._make_qp("asrti_qp", 0)

    def _make_qp(self, name: str, iter_max: int) -> ca.Function:
        P = self.cfg.horizon
        hpipm: dict = {"mode": "speed_abs"}
        if iter_max > 0:
            hpipm["iter_max"] = iter_max
        return ca.conic(name, "hpipm", {"h": self._H_sp, "a": self._A_sp},
                        {"N": P, "nx": [NZ] * (P + 1), "nu": [NU] * P + [0], "ng": [0] * (P + 1),
                         "hpipm": hpipm, "error_on_fail": False, "print_problem": False, "print_time": False})

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

    def _iterate(self, w0: np.ndarray, p: np.ndarray, lin: ca.Function, qp: ca.Function, min_iter: int,
                 max_iter: int, step_tol: float) -> tuple[np.ndarray | None, list[bool], float, str]:
        """Full-step Gauss–Newton SQP from w0 (controller layout) with x0 and u_prev fixed by bounds."""
        u_applied = p[NX + 3:NX + 5]
        w = self.to_aug(np.asarray(w0, float), u_applied)
        w[0:NX] = p[0:NX]
        lb, ub = self.lb.copy(), self.ub.copy()
        lb[0:NX] = ub[0:NX] = p[0:NX]
        lb[NX:NZ] = ub[NX:NZ] = u_applied
        w[NX:NZ] = u_applied
        p_dm = ca.DM(p)
        statuses: list[bool] = []
        violation = float("nan")
        u_mask = self.u_mask
        for it in range(max_iter):
            H, g, A, gap = lin(ca.DM(w), p_dm)
            violation = float(np.max(np.abs(np.asarray(gap))))
            sol = qp(h=H, g=g, a=A, lba=-gap, uba=-gap, lbx=lb - w, ubx=ub - w)
            step = np.asarray(sol["x"]).ravel()
            stats = qp.stats()
            statuses.append(bool(stats.get("success", False)))
            if not np.all(np.isfinite(step)):
                return None, statuses, violation, f"RTI: QP {stats.get('return_status', 'failed')}"
            w = w + step
            if it + 1 >= min_iter and np.max(np.abs(step[u_mask])) <= step_tol:
                break
        return self.from_aug(w), statuses, violation, ""

    def solve(self, w0: np.ndarray, p: np.ndarray, lbw: np.ndarray, ubw: np.ndarray,
              lam_w0: np.ndarray | None, lam_g0: np.ndarray | None) -> SolveOutcome:
        """Cold: IPOPT. Warm: ``rti_iterations`` Gauss–Newton SQP steps from the shifted plan (asrti:
        ``as_iterations`` steps from the plan given, the background solve's when there is one)."""
        if lam_w0 is None or lam_g0 is None:
            return self.ipopt.solve(w0, p, lbw, ubw, None, None)
        cfg = self.cfg
        if self.background:
            low = high = cfg.as_iterations
        else:
            low, high = cfg.rti_iterations, cfg.rti_max_iterations
        w, statuses, violation, error = self._iterate(w0, p, self.lin, self.qp, low, high, cfg.rti_step_tol)
        if w is None:
            return SolveOutcome(w=None, lam_w=None, lam_g=None, usable=False, status=error,
                                iterations=len(statuses), violation=violation)
        status = "RTI" if all(statuses) else f"RTI ({statuses.count(False)} QP unconverged)"
        return SolveOutcome(w=w, lam_w=lam_w0, lam_g=lam_g0, usable=True, status=status,
                            iterations=len(statuses), violation=violation)

    def _worker(self) -> ThreadPoolExecutor | ProcessPoolExecutor:
        if self._executor is None:
            if self.cfg.as_worker == "process":
                self._executor = ProcessPoolExecutor(max_workers=1, mp_context=get_context("spawn"),
                                                     initializer=_worker_init, initargs=(*self.problem, self.cfg))
            else:
                self._executor = ThreadPoolExecutor(max_workers=1, thread_name_prefix="asrti")
        return self._executor

    def warm_up(self) -> None:
        """Start the background worker now (a worker process takes about a second to build its solver)."""
        self._worker().submit(_noop).result()

    def start_background(self, w_plan: np.ndarray, p: np.ndarray, tau: np.ndarray) -> Future:
        """Start the converged solve for the next period: the model's prediction of the next state from
        ``p``'s state under ``tau``, the plan shifted by one stage. The Future gives (w, p_next, seconds,
        iterations), w None when the solve failed."""
        args = (np.array(w_plan, float), np.array(p, float), np.array(tau, float))
        if self.cfg.as_worker == "process":
            return self._worker().submit(_worker_solve, *args)
        return self._worker().submit(self._background_solve, *args)

    def _background_solve(self, w_plan: np.ndarray, p: np.ndarray,
                          tau: np.ndarray) -> tuple[np.ndarray | None, np.ndarray, float, int]:
        start = time.perf_counter()
        cfg = self.cfg
        x_next = np.asarray(self.bg_step(p[0:NX], tau, p[NX])).ravel()
        p_next = p.copy()
        p_next[0:NX] = x_next
        p_next[NX] = p[NX] + cfg.period_s
        p_next[NX + 3:NX + 5] = tau
        w0 = self.layout.shift(w_plan)
        w0[self.layout.x_index(0)] = x_next
        w = None
        statuses: list[bool] = []
        if np.all(np.isfinite(x_next)):
            w, statuses, _, _ = self._iterate(w0, p_next, self.bg_lin, self.bg_qp, 1, cfg.as_max_iterations,
                                              cfg.as_step_tol)
        return w, p_next, time.perf_counter() - start, len(statuses)


_WORKER_BACKEND: RtiBackend | None = None


def _noop() -> None:
    return None


def _worker_init(params, waves, current, cfg: NmpcConfig) -> None:
    """In a worker process: build this problem's backend once (the compiled linearisation comes from the cache)."""
    global _WORKER_BACKEND
    from .problem import build_nlp, discrete_model

    step = discrete_model(params, waves, current, cfg)
    nlp, layout = build_nlp(step, cfg)
    _WORKER_BACKEND = RtiBackend(nlp, layout, cfg, step, background=True, problem=(params, waves, current),
                                 build_ipopt=False)


def _worker_solve(w_plan: np.ndarray, p: np.ndarray, tau: np.ndarray) -> tuple[np.ndarray | None, np.ndarray,
                                                                               float, int]:
    assert _WORKER_BACKEND is not None
    return _WORKER_BACKEND._background_solve(w_plan, p, tau)
