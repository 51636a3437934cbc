"""A fast NMPC solver: real-time iterations of Gauss–Newton SQP with HPIPM (structure-exploiting QP).

Each period: the previous plan is shifted (by the controller), the initial state fixed, and a few SQP
iterations are taken, each one linearisation plus one QP in the step Δw (see ``gauss_newton``). The first
solve (and any cold start) is a full IPOPT solve; the linearisation is compiled to C once and cached on
disk (see ``codegen``). The advanced-step variant ``asrti`` is in ``asrti``.
"""

from __future__ import annotations

import numpy as np

from mavbridge.nmpc.backend import SolveOutcome
from mavbridge.nmpc.config import NmpcConfig
from mavbridge.nmpc.functions import ProblemFunctions
from mavbridge.nmpc.inputs import input_space
from mavbridge.nmpc.solvers.gauss_newton import NZ, GaussNewtonSqp, linearisation, linearisation_inlined
from mavbridge.nmpc.solvers.ipopt import IpoptBackend

__all__ = ["NZ", "RtiBackend", "linearisation", "linearisation_inlined"]


class RtiBackend:
    """Gauss–Newton real-time iterations with HPIPM; cold starts go to its own IPOPT instance."""

    name = "rti"

    def __init__(self, functions: ProblemFunctions, cfg: NmpcConfig, ipopt: IpoptBackend | None = None) -> None:
        self.cfg = cfg
        self.functions = functions
        self.layout = functions.layout
        self.ipopt = ipopt or IpoptBackend(functions, cfg)
        lin, self.codegen = functions.load_linearisation(cfg.rti_codegen)
        self.sqp: GaussNewtonSqp | None = GaussNewtonSqp(lin, cfg, "rti_qp", cfg.rti_qp_iter_max,
                                                            input_space(cfg, functions.params),
                                                            functions.linearisation_library(cfg.rti_codegen)[0])

    def iteration_limits(self) -> tuple[int, int, float]:
        """(at least, at most, input-step tolerance) SQP iterations per real-time step."""
        return self.cfg.rti_iterations, self.cfg.rti_max_iterations, self.cfg.rti_step_tol

    def prepare(self, w0: np.ndarray, p: np.ndarray, lbw: np.ndarray, ubw: np.ndarray) -> SolveOutcome:
        """The cold solve to convergence (IPOPT)."""
        return self.ipopt.prepare(w0, p, lbw, ubw)

    def solve(self, w0: np.ndarray, p: np.ndarray, lbw: np.ndarray, ubw: np.ndarray,
              lam_w0: np.ndarray | None, lam_g0: np.ndarray | None) -> SolveOutcome:
        """Cold (no duals): IPOPT. Warm: ``iteration_limits`` Gauss–Newton SQP steps from ``w0``."""
        if lam_w0 is None or lam_g0 is None:
            return self.ipopt.solve(w0, p, lbw, ubw, None, None)
        return self.real_time_iterations(w0, p, lam_w0, lam_g0)

    def real_time_iterations(self, w0: np.ndarray, p: np.ndarray, lam_w0: np.ndarray,
                             lam_g0: np.ndarray) -> SolveOutcome:
        """The warm step; the multipliers are passed through (the next cold solve may use them)."""
        if self.sqp is None:
            raise RuntimeError(f"{type(self).__name__}: solve after close()")
        low, high, tol = self.iteration_limits()
        w, statuses, violation, error = self.sqp.iterate(w0, p, low, high, tol)
        if w is None:
            return SolveOutcome(w=None, lam_w=None, lam_g=None, usable=False, status=error,
                                iterations=len(statuses), violation=violation)
        # A QP stopped at its HPIPM iteration cap (rti_qp_iter_max, by design in real time) still gives a step
        # that is taken; the next period refines the plan again. Not a failure: the name says which it is.
        capped = statuses.count(False)
        status = "RTI" if not capped else f"RTI ({capped} of {len(statuses)} QPs at the iteration cap)"
        return SolveOutcome(w=w, lam_w=lam_w0, lam_g=lam_g0, usable=True, status=status,
                            iterations=len(statuses), violation=violation)

    def advance(self, w_plan: np.ndarray, p: np.ndarray, tau: np.ndarray) -> None:
        """Nothing to do ahead of the next period."""

    def reset(self) -> None:
        """Nothing is kept between steps but the caller's plan."""

    def close(self) -> None:
        """Drop the QP, linearisation and IPOPT instances; idempotent."""
        self.sqp = None
        self.ipopt.close()
