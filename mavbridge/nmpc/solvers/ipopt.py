"""The reference solver: IPOPT on the SX-expanded multiple-shooting NLP, warm-started (notes' variant b).

Building an IPOPT instance (``nlpsol`` with SX expansion) takes seconds and destroying one most of a
second, which dominated short closed-loop runs (a sweep worker runs hundreds in one process). An
instance keeps nothing between calls but its last call's statistics, so a closed backend hands its
instance back to a per-process pool of idle instances (``_IDLE``, by problem structure and options)
and the next backend of that structure takes it: never two live backends on one instance.

An idle instance holds its expanded NLP (about 150 MB for an irregular sea at P = 10), so the pool is
bounded in all (``IDLE_TOTAL``, the instance returned longest ago goes first), and a problem with a
built-in wave field (an irregular sea fed as truth) is not pooled at all: that field is keyed by its
identity, every run builds a new one, so its instance could never be taken again.
"""

from __future__ import annotations

import threading

import casadi as ca
import numpy as np

from mavbridge.nmpc.backend import SolveOutcome
from mavbridge.nmpc.config import NmpcConfig
from mavbridge.nmpc.functions import ProblemFunctions, build_key

IDLE_PER_KEY = 4  # idle instances kept per structure (a process rarely has more controllers at once)
IDLE_TOTAL = 8  # idle instances kept in all structures together
_IDLE: dict[tuple, list[ca.Function]] = {}  # in order of the last return: the longest idle structure first
_IDLE_LOCK = threading.Lock()

SUCCESS_STATUSES = ("Solve_Succeeded", "Solved_To_Acceptable_Level")
ITERATION_LIMIT = "Maximum_Iterations_Exceeded"
FEASIBILITY_TOL = 1e-3  # an iteration-limited iterate (≥ 1 iteration) is used when its gaps are below this


def ipopt_options(cfg: NmpcConfig) -> dict:
    """The recommended configuration: SX expansion, IPOPT warm start, mu_init 1e-3, iteration cap."""
    return {
        "expand": True,
        "print_time": False,
        "error_on_fail": False,
        "ipopt.print_level": 0,
        "ipopt.sb": "yes",
        "ipopt.warm_start_init_point": "yes",
        "ipopt.warm_start_bound_push": 1e-6,
        "ipopt.warm_start_mult_bound_push": 1e-6,
        "ipopt.mu_init": 1e-3,
        "ipopt.max_iter": cfg.max_iter,
        "ipopt.tol": 1e-6,
        "ipopt.acceptable_tol": 1e-4,
    }


class IpoptBackend:
    """Its own IPOPT instance, built from the shared NLP expressions; ``solve`` runs it from a guess."""

    name = "ipopt"

    def __init__(self, functions: ProblemFunctions, cfg: NmpcConfig) -> None:
        self.layout = functions.layout
        self.n_g = functions.nlp["g"].numel()
        options = ipopt_options(cfg)
        self._pool_key = _pool_key(functions, options)
        self.solver: ca.Function | None = _take_idle(self._pool_key) or ca.nlpsol(
            "nmpc_ipopt", "ipopt", dict(functions.nlp), options)

    def prepare(self, w0: np.ndarray, p: np.ndarray, lbw: np.ndarray, ubw: np.ndarray) -> SolveOutcome:
        """The cold solve: IPOPT from the guess without multipliers."""
        return self.solve(w0, p, lbw, ubw, None, None)

    def advance(self, w_plan: np.ndarray, p: np.ndarray, tau: np.ndarray) -> None:
        """Nothing to do ahead of the next period."""

    def reset(self) -> None:
        """Nothing is kept between solves but the caller's guess."""

    def close(self) -> None:
        """Hand the solver instance back to the idle pool (a later solve here is refused)."""
        solver, self.solver = self.solver, None
        if solver is not None and self._pool_key is not None:
            _give_back(self._pool_key, solver)

    def solve(self, w0: np.ndarray, p: np.ndarray, lbw: np.ndarray, ubw: np.ndarray,
              lam_w0: np.ndarray | None, lam_g0: np.ndarray | None) -> SolveOutcome:
        """One NLP solve; never raises for solver failures (they come back as an unusable outcome)."""
        if self.solver is None:
            raise RuntimeError("IpoptBackend: solve after close()")
        args = {"x0": w0, "p": p, "lbx": lbw, "ubx": ubw, "lbg": 0.0, "ubg": 0.0}
        if lam_w0 is not None and lam_g0 is not None:
            args["lam_x0"] = lam_w0
            args["lam_g0"] = lam_g0
        try:
            sol = self.solver(**args)
        except RuntimeError as exc:  # evaluation errors surface here in some CasADi versions
            return SolveOutcome.failed(f"error: {str(exc).splitlines()[0]}")
        stats = self.solver.stats()
        status = str(stats.get("return_status", "unknown"))
        w = np.asarray(sol["x"]).ravel()
        gaps = np.asarray(sol["g"]).ravel()
        violation = float(np.max(np.abs(gaps))) if gaps.size else 0.0
        iterations = int(stats.get("iter_count", 0))
        finite = bool(np.all(np.isfinite(w)) and np.isfinite(violation))
        usable = finite and (status in SUCCESS_STATUSES
                             or (status == ITERATION_LIMIT and iterations > 0 and violation <= FEASIBILITY_TOL))
        return SolveOutcome(w=w, lam_w=np.asarray(sol["lam_x"]).ravel(), lam_g=np.asarray(sol["lam_g"]).ravel(),
                            usable=usable, status=status, iterations=iterations,
                            violation=violation)


def _pool_key(functions: ProblemFunctions, options: dict) -> tuple | None:
    """The idle pool's key: the problem structure and the options; None (no pooling) if unhashable or
    built on a fixed wave field (never the same object twice: see the module's description)."""
    if functions.fixed_waves is not None:
        return None
    key = (build_key(functions.params, functions.fixed_waves, functions.current, functions.cfg),
           tuple(sorted(options.items())))
    try:
        hash(key)
    except TypeError:
        return None
    return key


def _take_idle(key: tuple | None) -> ca.Function | None:
    """An idle instance of this structure, now exclusively the caller's, or None."""
    if key is None:
        return None
    with _IDLE_LOCK:
        idle = _IDLE.get(key)
        return idle.pop() if idle else None


def _give_back(key: tuple, solver: ca.Function) -> None:
    """Put a closed backend's instance in the pool (its structure now the most recent), dropping the
    instances idle longest beyond ``IDLE_PER_KEY`` and ``IDLE_TOTAL``; they are destroyed outside the lock."""
    dropped: list[ca.Function] = []
    with _IDLE_LOCK:
        idle = [*_IDLE.pop(key, []), solver]
        cut = max(0, len(idle) - IDLE_PER_KEY)
        dropped += idle[:cut]
        _IDLE[key] = idle[cut:]
        while sum(len(v) for v in _IDLE.values()) > IDLE_TOTAL:
            oldest = next(v for v in _IDLE.values() if v)
            dropped.append(oldest.pop(0))
    dropped.clear()


def idle_instances() -> int:
    """How many idle IPOPT instances this process keeps (for tests and diagnostics)."""
    with _IDLE_LOCK:
        return sum(len(idle) for idle in _IDLE.values())
