"""Native real-time iteration (solver ``nrti``): asrti's closed loop with its step split in two, in C.

Preparation (background thread, before the measurement): asrti's converged Gauss–Newton SQP for the
predicted next state, each iteration's QP linearised (compiled CasADi code of the project's own model),
condensed to the N·nu input steps (``condensed``) and solved from the previous one's active set; the last
iteration's QP, with its solved active set, is the one prepared for the feedback. Paced in real time
(``RollAwareNmpc.pace``) it stops iterating after PREPARE_SHARE of the wall period and hands over its last QP:
the iterations then spread over the periods that follow, as in plain RTI.
Feedback (the only work between measurement and input): the measured state's offset from the predicted
one enters the condensed gradient linearly; one dense box QP from the prepared active set (its first iteration
with the preparation's Cholesky factor of that set's free block) and the states by the linear dynamics — one
ctypes call into ``native_source``'s kernels on preallocated buffers. This is the RTI of Diehl et al. applied to
asrti's plan: one Gauss–Newton iteration whose linearisation point is the prediction, not the measurement (a
second-order difference).

Wave and weights changed after the preparation started take effect at the next preparation, one
period later (``stats["background_problem"] == "changed"``). Without a C compiler, or when the native
kernels cannot be built, the backend says so once and runs as ``asrti`` (slower).
"""

from __future__ import annotations

import logging
import math
import time

import numpy as np

from mavbridge.nmpc.backend import SolveOutcome
from mavbridge.nmpc.config import NmpcConfig
from mavbridge.nmpc.functions import ProblemFunctions
from mavbridge.nmpc.inputs import input_space
from mavbridge.nmpc.layout import NX, PARAMS
from mavbridge.nmpc.solvers.asrti import AdvancedStep, AsrtiBackend, BackgroundResult, BackgroundSolve
from mavbridge.nmpc.solvers.condensed import CondensedQp, Condenser, FeedbackBuffers
from mavbridge.nmpc.solvers.gauss_newton import NZ
from mavbridge.nmpc.solvers.native_lib import native_library
from mavbridge.nmpc.solvers.worker import Job

LOG = logging.getLogger(__name__)
# Paced (``RollAwareNmpc.pace``): the preparation stops iterating after this share of a wall period. It starts
# when a step ends and is taken at the next step, up to asrti's WAIT_SHARE later: a budget within that span
# (less the step's own time) hands over a QP in time, and the next preparation continues from its plan
PREPARE_SHARE = 0.75
_X0, _U_PREV = PARAMS.slice("x0"), PARAMS.slice("u_prev")  # (looked up once: the feedback runs every step)
_SAID: set[str] = set()  # what this process has been told already (the no-compiler notice, once)


def say_once(message: str) -> None:
    """Log ``message`` the first time only."""
    if message not in _SAID:
        _SAID.add(message)
        LOG.warning(message)


class Preparation:
    """The background job: a converged Gauss–Newton SQP for the predicted next state, every iteration a
    condensed QP solved natively (as asrti's, whose HPIPM iterations it replaces); its last QP is prepared."""

    def __init__(self, solve: BackgroundSolve, condenser: Condenser) -> None:
        self.solve = solve  # asrti's: its model step, layout and augmented-layout conversions
        self.condenser = condenser
        self.buffers = FeedbackBuffers.allocate(condenser.cfg.horizon)  # this thread's own
        self.budget_s = math.inf  # wall seconds of iterations (``PreparedStep.pace``); read by the worker thread

    def __call__(self, w_plan: np.ndarray, p: np.ndarray, u_applied: np.ndarray) -> BackgroundResult:
        """(CondensedQp or None, p_next, seconds, SQP iterations) for the period after ``p``'s."""
        start = time.perf_counter()
        cfg, layout = self.condenser.cfg, self.solve.layout
        par = PARAMS.unpack(p)
        x_next = self.solve.predict(par.x0, u_applied, par.t, self.solve.blocks.wave_input(p))
        p_next = p.copy()
        p_next[PARAMS.slice("x0")] = x_next
        p_next[PARAMS.index("t")] = par.t + cfg.period_s
        p_next[PARAMS.slice("u_prev")] = u_applied
        w = layout.shift(w_plan)
        w[layout.x_index(0)] = x_next
        qp, iterations = None, 0
        if np.all(np.isfinite(x_next)):
            qp, iterations = self.converge(w, p_next, start + self.budget_s)
        return qp, p_next, time.perf_counter() - start, iterations

    def converge(self, w: np.ndarray, p: np.ndarray, stop_at: float = math.inf) -> tuple[CondensedQp | None, int]:
        """Full-step SQP from ``w`` (controller layout, x0 in place) until every input step is at most
        ``as_step_tol`` (at most ``as_max_iterations``, none begun after ``stop_at``, perf_counter seconds):
        (the QP of its last iteration, for the backend's feedback, or None when a QP failed; iterations).

        The prepared QP is the last iteration's, linearised at the plan before that iteration's step (at
        most ``as_step_tol`` away from the converged plan), not a further condensation at the converged
        plan: the feedback is then the RTI from that point, and each step costs one condensation less.
        Each iteration's QP starts from the previous one's active set, in the condenser's own arrays (an
        intermediate QP is only its step: nothing is allocated until the last is kept). An intermediate QP at its
        iteration cap (status 0) still gives a step within the box, which the next iteration corrects; only the
        last QP must be solved (status > 0) to be prepared."""
        condenser, b = self.condenser, self.buffers
        u_prev, n = PARAMS.get(p, "u_prev"), condenser.n
        b.dz0[:] = 0.0
        condenser.active[:] = 0  # all free: the first QP is solved from scratch
        done = condenser.converge(w, u_prev, p, b, stop_at - time.perf_counter())  # (None: not compiled code)
        status, it = done if done is not None else self._iterate(w, u_prev, p, stop_at)
        if status <= 0:  # a QP failed, or the last is at its iteration cap: no prepared QP (asrti's step instead)
            return None, it
        # the last QP's factor at its final active set (the feedback's starting one) is in the work buffer: kept,
        # the feedback's first iteration only substitutes (a fifth of its time, issue 32)
        return condenser.keep(status, factor=b.work[:n * n].copy()), it

    def _iterate(self, w: np.ndarray, u_prev: np.ndarray, p: np.ndarray, stop_at: float) -> tuple[int, int]:
        """``converge``'s iterations one ``Condenser.iterate`` at a time (a linearisation in CasADi's virtual
        machine): (last status, < 0 when a QP failed or a plan was not finite; iterations)."""
        condenser, b, cfg = self.condenser, self.buffers, self.condenser.cfg
        status, it = 0, 0
        for it in range(cfg.as_max_iterations):  # as_max_iterations >= 1 (NmpcConfig)
            condenser.augment(w, u_prev)
            status = condenser.iterate(None, p, b)  # from the previous QP's active set
            if status < 0 or not np.isfinite(b.w_out).all():
                return (status if status < 0 else -3), it + 1
            w = b.w_out  # (read by the next iteration's ``augment`` before its QP overwrites it)
            if np.max(np.abs(b.du)) <= cfg.as_step_tol or time.perf_counter() > stop_at:
                break
        return status, it + 1

    def at_plan(self, w: np.ndarray, p: np.ndarray) -> BackgroundResult:
        """The condensed QP at a plan already solved for ``p`` itself (after the cold solve)."""
        start = time.perf_counter()
        return self._condense(w, p), p, time.perf_counter() - start, 0

    def _condense(self, w: np.ndarray, p: np.ndarray) -> CondensedQp | None:
        qp = self.condenser.condense(self.solve.sqp.to_aug(w, PARAMS.get(p, "u_prev")), p)
        return qp if qp.guess_status > 0 else None


class PreparedStep(AdvancedStep):
    """asrti's one background worker, whose job ends with the prepared (condensed) QP."""

    def __init__(self, functions: ProblemFunctions, cfg: NmpcConfig, condenser: Condenser) -> None:
        super().__init__(functions, cfg)
        self.preparation = Preparation(self._solve, condenser)
        self._solve = self.preparation

    def pace(self, wall_period_s: float) -> None:
        """asrti's wait, and a preparation budget of PREPARE_SHARE of the wall period."""
        super().pace(wall_period_s)
        self.preparation.budget_s = PREPARE_SHARE * max(wall_period_s, 0.0)

    def prepare_now(self, w: np.ndarray, p: np.ndarray) -> CondensedQp | None:
        """Prepare the QP at ``w`` for ``p`` itself, here and now (before the loop: no job is in flight),
        and hold it for the first step."""
        result = self.preparation.at_plan(np.array(w, float), np.array(p, float))
        self._pending = Job.finished(result)
        return result[0]


class NrtiBackend(AsrtiBackend):
    """asrti with a native preparation/feedback split (see the module docstring)."""

    name = "nrti"

    def __init__(self, functions: ProblemFunctions, cfg: NmpcConfig) -> None:
        if cfg.as_worker == "process":  # the prepared QP lives in this process's memory
            cfg = cfg.replace(as_worker="thread")
        super().__init__(functions, cfg)
        lib, self.native = native_library()
        self.buffers: FeedbackBuffers | None = None
        self._taken: tuple[np.ndarray, CondensedQp | None, dict, float] | None = None  # see ``prepared_feedback``
        if lib is None:
            say_once(f"nrti: {self.native}; running as asrti (slower)")
            return
        lin, how = functions.block_linearisation(cfg)  # (built once per structure in a process)
        if not how.startswith("compiled"):
            say_once(f"nrti: the block linearisation runs in CasADi's virtual machine ({how}); preparation is slower")
        self.lib = lib
        self.buffers = FeedbackBuffers.allocate(cfg.horizon)
        self.advanced.close()  # asrti's plain worker, replaced by the preparing one
        self.advanced = PreparedStep(functions, cfg, Condenser(lib, lin, cfg, self.buffers,
                                                                     input_space(cfg, functions.params)))

    def prepare(self, w0: np.ndarray, p: np.ndarray, lbw: np.ndarray, ubw: np.ndarray) -> SolveOutcome:
        """The cold solve (IPOPT), then the QP at its plan is prepared for the first step (and the feedback
        run once on it, so that the first step finds its code and buffers warm)."""
        outcome = super().prepare(w0, p, lbw, ubw)
        if outcome.usable and isinstance(self.advanced, PreparedStep):
            qp = self.advanced.prepare_now(outcome.w, p)
            if qp is not None:
                self.feedback(qp, p, outcome.lam_w, outcome.lam_g)
        return outcome

    def prepared_feedback(self, p: np.ndarray) -> SolveOutcome | None:
        """The step when a QP was prepared for this p: the feedback alone, which needs no warm start (so the controller
        makes none: shifting the plan and its multipliers cost the step as much as the feedback, paced, issue 32).
        None when there is no prepared QP or its feedback failed: ``solve`` then goes on from what was taken here.
        The outcome's multipliers are None (the feedback leaves them as they were)."""
        if self.buffers is None:
            return None
        qp, info, wait = self._take(p)
        outcome = None if qp is None else self.feedback(qp, p, None, None)
        if outcome is None:
            self._taken = (p, qp, info, wait)  # (its feedback, if any, was tried: ``solve`` does not try it again)
            return None
        outcome.wait_s = wait
        outcome.stats.update(info, background_wait_s=wait)
        return outcome

    def _take(self, p: np.ndarray) -> tuple[CondensedQp | None, dict, float]:
        """(the QP prepared for p or None, the background's figures, the wall seconds waited for it)."""
        wait_start = time.perf_counter()
        qp, info = self.advanced.take(p)
        return qp, info, time.perf_counter() - wait_start

    def solve(self, w0: np.ndarray, p: np.ndarray, lbw: np.ndarray, ubw: np.ndarray,
              lam_w0: np.ndarray | None, lam_g0: np.ndarray | None) -> SolveOutcome:
        """The feedback step on the QP prepared for this p; asrti's step when there is none."""
        if self.buffers is None or lam_w0 is None or lam_g0 is None:
            self._taken = None  # (asrti's step takes the background plan itself)
            return super().solve(w0, p, lbw, ubw, lam_w0, lam_g0)
        taken, self._taken = self._taken, None
        tried = taken is not None and taken[0] is p  # ``prepared_feedback`` took for this very p: its feedback failed
        qp, info, wait = taken[1:] if tried else self._take(p)
        outcome = None if qp is None or tried else self.feedback(qp, p, lam_w0, lam_g0)
        start = None
        if outcome is None:  # no prepared QP, or it failed: one SQP iteration from the best plan there is
            start = w0 if qp is None else self.solve_plan(qp)
            outcome = self.real_time_iterations(start, p, lam_w0, lam_g0)
            info["feedback"] = "sqp"
        outcome.start = start
        outcome.wait_s = wait
        outcome.stats.update(info, background_wait_s=wait)
        return outcome

    def reset(self) -> None:
        """Drop the job in flight, and what ``prepared_feedback`` took."""
        self._taken = None
        super().reset()

    def solve_plan(self, qp: CondensedQp) -> np.ndarray:
        """The prepared plan in the controller's layout."""
        return self.advanced.preparation.solve.sqp.from_aug(qp.w_aug)

    def feedback(self, qp: CondensedQp, p: np.ndarray, lam_w0: np.ndarray | None,
                 lam_g0: np.ndarray | None) -> SolveOutcome | None:
        """One native call: the box QP for the measured state, the plan from its input steps (None: failed)."""
        b = self.buffers
        np.subtract(p[_X0], qp.w_aug[0:NX], out=b.dz0[0:NX])
        np.subtract(p[_U_PREV], qp.w_aug[NX:NZ], out=b.dz0[NX:NZ])
        status = self.lib.nrti_feedback(*qp.args)
        if status < 0 or not np.isfinite(b.w_out).all():
            return None
        return SolveOutcome(w=b.w_out.copy(), lam_w=lam_w0, lam_g=lam_g0, usable=True,
                            status="NRTI" if status > 0 else "NRTI (QP iteration cap)", iterations=1,
                            stats={"qp_pivots": status, "feedback": "native"})
