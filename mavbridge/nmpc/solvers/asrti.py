"""Advanced-step RTI (solver ``asrti``): a converged solve for the predicted next state, run in the background.

Two iterations per step do not follow the converged closed loop on Balanced (arrival 88 s against IPOPT's
101 s): a few steps need 10–30 full-step iterations to settle, and the decisions they settle change the
approach to the waypoint. So after each step a worker runs the Gauss–Newton SQP to convergence (input
steps ≤ ``as_step_tol``, at most ``as_max_iterations``) for the state the model predicts at the next
sampling time under the input just applied; the next step fixes the measured state and takes
``as_iterations`` (1) iteration from that converged plan, which corrects for the prediction error.

The background solve is owned by one ``AdvancedStep`` object per backend (its worker thread or process,
its own linearisation and QP instances, the one job in flight). It solves the parameter vector it was
started with — the wave and weights current at that step; if the next step's wave or weights differ, its
plan is still the warm start (``stats["background_problem"] == "changed"``) and that step's iteration
uses the new values.
"""

from __future__ import annotations

import contextlib
import time
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures import TimeoutError as FuturesTimeout
from multiprocessing import get_context
from typing import Any

import numpy as np

from mavbridge.nmpc.backend import SolveOutcome
from mavbridge.nmpc.compiled_model import compiled_model
from mavbridge.nmpc.config import NmpcConfig
from mavbridge.nmpc.functions import ProblemFunctions, problem_functions
from mavbridge.nmpc.inputs import input_space
from mavbridge.nmpc.layout import PARAMS, parameter_layout
from mavbridge.nmpc.solvers.gauss_newton import GaussNewtonSqp
from mavbridge.nmpc.solvers.rti import RtiBackend
from mavbridge.nmpc.solvers.worker import DeferredJob, InlineWorker, Job, Worker
from vessel import OceanCurrent, OtterParameters, WaveField

# Paced (``RollAwareNmpc.pace``): a step waits for the background job at most this share of a wall period
WAIT_SHARE = 0.25

BackgroundResult = tuple[np.ndarray | None, np.ndarray, float, int]  # (w or None, p_next, seconds, iterations)


_T = PARAMS.index("t")
_GOAL = slice(PARAMS.slice("waypoint").start, PARAMS.slice("u_prev").stop)  # the waypoint and u_prev (adjacent)
_PROBLEM = slice(PARAMS.slice("weights").start, None)  # the weights, wave, roll spread and a bank block after NP
assert [name for name, _ in PARAMS.blocks] == ["x0", "t", "waypoint", "u_prev", "weights", "wave", "roll_spread",
                                               "disturbance"]


class BackgroundSolve:
    """The converged SQP for the next period, with its own linearisation and QP instances."""

    def __init__(self, functions: ProblemFunctions, cfg: NmpcConfig) -> None:
        self.cfg = cfg
        self.step = functions.step
        # the step bound to arrays and compiled once per make of model (no DM conversions; the same numbers)
        self._predict, _ = compiled_model(functions.step)
        self.layout = functions.layout
        self.blocks = parameter_layout(cfg.wave_components)
        lin, _ = functions.load_linearisation(cfg.rti_codegen)
        self.sqp = GaussNewtonSqp(lin, cfg, "asrti_qp", 0, input_space(cfg, functions.params),
                                  functions.linearisation_library(cfg.rti_codegen)[0])

    def predict(self, x0: np.ndarray, u: np.ndarray, t: float, wave: np.ndarray) -> np.ndarray:
        """The model's state one period after (x0, t) with the model's input ``u`` held, in ``wave`` (a new array)."""
        x_in, u_in, t_in, wave_in = self._predict.inputs[0:4]
        x_in[:], u_in[:], t_in[0], wave_in[:] = x0, u, t, wave
        self._predict()
        return self._predict.outputs[0].copy()

    def __call__(self, w_plan: np.ndarray, p: np.ndarray, u_applied: np.ndarray) -> BackgroundResult:
        """Predict the next state from p's under ``u_applied`` (the model's input u: τ, or the propeller thrusts)
        and p's wave, then solve from the shifted plan."""
        start = time.perf_counter()
        cfg = self.cfg
        par = PARAMS.unpack(p)
        x_next = self.predict(par.x0, u_applied, par.t, self.blocks.wave_input(p))
        p_next = p.copy()
        p_next[PARAMS.slice("x0")] = x_next
        p_next[PARAMS.index("t")] = par.t + cfg.period_s
        p_next[PARAMS.slice("u_prev")] = u_applied
        w0 = self.layout.shift(w_plan)
        w0[self.layout.x_index(0)] = x_next
        w = None
        statuses: list[bool] = []
        if np.all(np.isfinite(x_next)):
            w, statuses, _, _ = self.sqp.iterate(w0, p_next, 1, cfg.as_max_iterations, cfg.as_step_tol)
        return w, p_next, time.perf_counter() - start, len(statuses)


class AdvancedStep:
    """One worker and at most one background job; ``take`` hands its plan to the step it was made for."""

    def __init__(self, functions: ProblemFunctions, cfg: NmpcConfig) -> None:
        self.cfg = cfg
        self.wait_s = cfg.as_wait_s  # wall seconds a step waits for the job (``pace``)
        self.functions = functions
        self._solve = BackgroundSolve(functions, cfg) if cfg.as_worker != "process" else None
        self._executor: Worker | InlineWorker | ProcessPoolExecutor | None = None
        self._pending: Future | Job | None = None
        self.closed = False

    def _worker(self) -> Worker | InlineWorker | ProcessPoolExecutor:
        if self.closed:
            raise RuntimeError("AdvancedStep: used after close()")
        if self._executor is None:
            if self.cfg.as_worker == "process":
                f = self.functions
                self._executor = ProcessPoolExecutor(max_workers=1, mp_context=get_context("spawn"),
                                                     initializer=_worker_init,
                                                     initargs=(f.params, f.fixed_waves, f.current, self.cfg, f.wind))
            elif self.cfg.as_worker == "inline":
                self._executor = InlineWorker()
            else:
                self._executor = Worker("asrti")  # (lighter than a ThreadPoolExecutor on the step's path)
        return self._executor

    def warm_up(self) -> None:
        """Start the worker now (a worker process takes about a second to build its solver)."""
        self._worker().submit(_noop).result()

    def start(self, w_plan: np.ndarray, p: np.ndarray, u_applied: np.ndarray) -> None:
        """Start the converged solve for the period after the one ``p`` describes, ``u_applied`` (the model's
        input u) applied."""
        args = (np.array(w_plan, float), np.array(p, float), np.array(u_applied, float))
        target = _worker_solve if self._solve is None else self._solve
        self._pending = self._worker().submit(target, *args)

    def pace(self, wall_period_s: float) -> None:
        """Wait at most WAIT_SHARE of a wall period (never more than ``as_wait_s``) for the job. Paced, the work
        ahead needs its own thread: an inline worker becomes one, and a job not yet run goes to it."""
        self.wait_s = min(self.cfg.as_wait_s, WAIT_SHARE * max(wall_period_s, 0.0))
        if self.cfg.as_worker == "inline":
            self.cfg = self.cfg.replace(as_worker="thread")
            self._executor = None
            if isinstance(self._pending, DeferredJob):
                self._pending = self._pending.hand_over(self._worker())

    def take(self, p: np.ndarray) -> tuple[np.ndarray | None, dict]:
        """The background plan if it was made for this step's p (waiting up to ``wait_s``), and figures."""
        if self._pending is None:
            return None, {}
        future, self._pending = self._pending, None
        try:
            w, p_next, seconds, iterations = future.result(timeout=self.wait_s)
        except FuturesTimeout:
            return None, {"background": "late"}
        info: dict = {"background_solve_s": seconds, "background_iterations": iterations}
        now, made_for = p.tolist(), p_next.tolist()  # plain floats (each step; numpy's per-call cost is most of it)
        stale = abs(now[_T] - made_for[_T]) > 0.5 * self.cfg.period_s
        if w is None or stale or now[_GOAL] != made_for[_GOAL]:
            info["background"] = "unused"
            return None, info
        info["background"] = "used"
        info["background_problem"] = "changed" if now[_PROBLEM] != made_for[_PROBLEM] else "same"
        return w, info

    def cancel(self) -> None:
        """Let a running job end (up to ``wait_s``) and forget it; a deferred one is dropped unrun."""
        future, self._pending = self._pending, None
        if isinstance(future, DeferredJob):
            future.cancel()
        elif future is not None:
            with contextlib.suppress(FuturesTimeout):
                future.result(timeout=self.wait_s)

    def close(self) -> None:
        """Stop the worker (after its job in flight ends); idempotent."""
        if self.closed:
            return
        self.cancel()
        if self._executor is not None:
            self._executor.shutdown(wait=True, cancel_futures=True)
            self._executor = None
        self._solve = None
        self.closed = True


class AsrtiBackend(RtiBackend):
    """RTI whose steps start from the background solve of the previous period (see the module docstring)."""

    name = "asrti"

    def __init__(self, functions: ProblemFunctions, cfg: NmpcConfig) -> None:
        super().__init__(functions, cfg)
        self.advanced = AdvancedStep(functions, cfg)

    def iteration_limits(self) -> tuple[int, int, float]:
        """``as_iterations`` per step, from the converged background plan."""
        return self.cfg.as_iterations, self.cfg.as_iterations, self.cfg.rti_step_tol

    def prepare(self, w0: np.ndarray, p: np.ndarray, lbw: np.ndarray, ubw: np.ndarray) -> SolveOutcome:
        """Start the worker, then the cold solve (IPOPT)."""
        self.advanced.warm_up()
        return super().prepare(w0, p, lbw, ubw)

    def solve(self, w0: np.ndarray, p: np.ndarray, lbw: np.ndarray, ubw: np.ndarray,
              lam_w0: np.ndarray | None, lam_g0: np.ndarray | None) -> SolveOutcome:
        """The step from the background plan made for this p when there is one, else from ``w0``."""
        wait_start = time.perf_counter()
        plan, info = self.advanced.take(p)
        wait = time.perf_counter() - wait_start
        start = None
        if lam_w0 is None or lam_g0 is None:
            outcome = self.ipopt.solve(w0, p, lbw, ubw, None, None)
        else:
            if plan is not None:
                start = plan.copy()
                start[self.layout.x_index(0)] = PARAMS.get(p, "x0")
            outcome = self.real_time_iterations(w0 if start is None else start, p, lam_w0, lam_g0)
        outcome.start = start
        outcome.wait_s = wait
        outcome.stats.update(info, background_wait_s=wait)
        return outcome

    def advance(self, w_plan: np.ndarray, p: np.ndarray, u_applied: np.ndarray) -> None:
        """Start the background solve for the next period."""
        self.advanced.start(w_plan, p, u_applied)

    def reset(self) -> None:
        """Drop the job in flight."""
        self.advanced.cancel()

    def close(self) -> None:
        """Stop the worker and drop the solver instances; idempotent."""
        self.advanced.close()
        super().close()


_WORKER_SOLVE: BackgroundSolve | None = None


def _noop() -> None:
    return None


def _worker_init(params: OtterParameters, fixed_waves: WaveField | None, current: OceanCurrent,
                 cfg: NmpcConfig, wind: Any = None) -> None:
    """In a worker process: build this problem's background solve once (the library comes from the cache)."""
    global _WORKER_SOLVE
    _WORKER_SOLVE = BackgroundSolve(problem_functions(params, fixed_waves, current, cfg, wind), cfg)


def _worker_solve(w_plan: np.ndarray, p: np.ndarray, u_applied: np.ndarray) -> BackgroundResult:
    if _WORKER_SOLVE is None:
        raise RuntimeError("asrti worker process: not initialised")
    return _WORKER_SOLVE(w_plan, p, u_applied)
