"""RollAwareNmpc: owns its solver backend, warm-starts it each period (nrti: only when its prepared QP is not
enough, see ``_feedback_only``), and always answers with an input.

The built problem (immutable CasADi Functions) comes from the per-process cache in ``functions``; the
backend — solver instances, the asrti worker — is this controller's own and ends with ``close()``. The
wave the model predicts with and the weights are run-time parameters (``set_wave``): no rebuild.

A solve that fails, or that finishes after the caller's deadline, is reported (``NmpcResult.fallback``)
and answered with the next input of the previous plan when one is still within its horizon, else with
the safe input (gentle forward surge, zero yaw moment). The answer is never NaN.

The model's input u is τ or the two propeller thrusts (``NmpcConfig.inputs``, see ``inputs``); the plan,
the previous input in p and the warm starts are in u, and the answers (``NmpcResult.tau``, ``inputs``,
``last_input``) are converted to (τ_X, τ_N) here, so the rest of the code sees τ whatever the setting.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mavbridge.nmpc.backend import BackendLifetime, NmpcBackend, SolveOutcome
from mavbridge.nmpc.config import NmpcConfig
from mavbridge.nmpc.functions import ProblemFunctions, problem_functions
from mavbridge.nmpc.inputs import InputSpace, input_space
from mavbridge.nmpc.layout import NU, NX, Layout
from mavbridge.nmpc.model_state import on_mean_surface
from mavbridge.nmpc.problem import input_bounds
from mavbridge.nmpc.run_parameters import SeaInputs, SeaKnowledge
from vessel import STATE_NAMES, CalmWater, OceanCurrent, OtterParameters, WaveField
from vessel.sea.wind import Wind


@dataclass(frozen=True)
class NmpcResult:
    """One period's answer: the input to apply, the plan and the solver's statistics."""

    tau: np.ndarray  # (τ_X N, τ_N N·m) to apply now, always finite
    states: np.ndarray  # predicted states (P+1)×12 of the plan that produced ``tau``
    inputs: np.ndarray  # planned inputs P×2
    wall_time_s: float
    iterations: int
    status: str  # the solver's own status text
    success: bool  # the solver produced an iterate that was used for the plan
    fallback: str | None = None  # None, or why the input came from elsewhere
    fallback_source: str | None = None  # "previous_plan" or "safe"
    stats: dict = field(default_factory=dict)
    roll_term_active: bool = True  # the solve weighted roll (R > 0 and a wave known; see ``set_wave``)


def make_backend(functions: ProblemFunctions, cfg: NmpcConfig) -> NmpcBackend:
    """A new backend (its own solver instances) for the configured solver."""
    if cfg.solver == "nrti":
        from mavbridge.nmpc.solvers.nrti import NrtiBackend  # asrti with the native preparation/feedback split

        return NrtiBackend(functions, cfg)
    if cfg.solver == "asrti":
        from mavbridge.nmpc.solvers.asrti import AsrtiBackend  # optional, heavier to build

        return AsrtiBackend(functions, cfg)
    if cfg.solver == "rti":
        from mavbridge.nmpc.solvers.rti import RtiBackend

        return RtiBackend(functions, cfg)
    from mavbridge.nmpc.solvers.ipopt import IpoptBackend

    return IpoptBackend(functions, cfg)


def _check_finite(values: Any, expected: int, field_name: str, names: tuple[str, ...] | None = None) -> np.ndarray:
    if type(values) is np.ndarray and values.shape == (expected,) and values.dtype == np.float64 \
            and all(map(math.isfinite, values.tolist())):  # the step's own arrays: no conversion, one check
        return values
    try:
        arr = np.asarray(values, dtype=float).ravel()
    except (TypeError, ValueError):
        raise ValueError(f"{field_name}: expected {expected} numbers, got {values!r}") from None
    if arr.size != expected:
        raise ValueError(f"{field_name}: expected {expected} numbers, got {arr.size}")
    if all(map(math.isfinite, arr.tolist())):  # plain floats: a few numbers, every step (numpy's calls cost more)
        return arr
    i = int(np.flatnonzero(~np.isfinite(arr))[0])
    label = f"{field_name}[{i}]" + (f" ({names[i]})" if names else "")
    raise ValueError(f"{label} is not finite: {arr[i]!r}")


def checked_inputs(x0: Any, t: Any, waypoint_ne: Any) -> tuple[np.ndarray, float, np.ndarray]:
    """(x0, t, waypoint) as finite numbers, or ValueError naming the field (and state name)."""
    x = _check_finite(x0, NX, "x0", STATE_NAMES)
    time_s = t if type(t) is float and math.isfinite(t) else float(_check_finite([t], 1, "t")[0])
    return x, time_s, _check_finite(waypoint_ne, 2, "waypoint_ne", ("north", "east"))


def model_inputs(config: NmpcConfig, x0: Any, t: Any, waypoint_ne: Any) -> tuple[np.ndarray, float, np.ndarray]:
    """Checked inputs; the heave taken out of x0 when ``heave_feedback`` is ``none`` (see model_state)."""
    x0, t, waypoint = checked_inputs(x0, t, waypoint_ne)
    if config.heave_feedback == "none":
        x0 = on_mean_surface(x0)
    return x0, t, waypoint


def rollout(step: Any, layout: Layout, x0: np.ndarray, t: float, u: np.ndarray, period_s: float,
            wave: np.ndarray) -> np.ndarray:
    """A dynamically consistent cold-start guess: input u held over the horizon from x0 at t."""
    X = np.empty((layout.horizon + 1, NX))
    X[0] = x0
    for k in range(layout.horizon):
        nxt = np.asarray(step(X[k], u, t + k * period_s, wave)).ravel()
        X[k + 1] = nxt if np.all(np.isfinite(nxt)) else X[k]
    return layout.join(X, np.tile(u, (layout.horizon, 1)))


def shift_duals(layout: Layout, lam_w: np.ndarray | None,
                lam_g: np.ndarray | None) -> tuple[np.ndarray | None, np.ndarray | None]:
    """The multipliers of a plan shifted by one stage (None when there are none)."""
    return shift_duals_by(layout, lam_w, lam_g, 1)


def shift_duals_by(layout: Layout, lam_w: np.ndarray | None, lam_g: np.ndarray | None,
                   stages: int) -> tuple[np.ndarray | None, np.ndarray | None]:
    """``shift_duals`` made ``stages`` times, at once (bit for bit): stage i takes stage i + stages, the last ones
    repeated; the initial-state block takes the negated gap that the last of those shifts moved into it."""
    if lam_w is None or lam_g is None:
        return None, None
    if stages <= 0:
        return lam_w, lam_g
    P, m = layout.horizon, NX + NU
    X = np.concatenate([lam_w[:P * m].reshape(P, m)[:, :NX], lam_w[P * m:].reshape(1, NX)])
    U = lam_w[:P * m].reshape(P, m)[:, NX:]
    ahead = np.arange(P + 1) + stages
    X, U = X[np.minimum(ahead, P)], U[np.minimum(ahead[:P], P - 1)]
    gaps = lam_g[NX:].reshape(P, NX)
    return (np.concatenate([np.hstack([X[:P], U]).ravel(), X[P]]),
            np.concatenate([-gaps[min(stages - 1, P - 1)], gaps[np.minimum(ahead[:P], P - 1)].ravel()]))


class RollAwareNmpc(SeaInputs, BackendLifetime):
    """The paper's roll-aware NMPC for the Otter; ``solve`` once per control period.

    Each controller owns its backend (solver instances, the asrti worker); only immutable CasADi Functions
    are shared between controllers of the same structure. ``close()`` (or leaving a ``with`` block) stops
    the worker and frees the solvers; it is idempotent, and a closed controller refuses to solve.

    The wave the model predicts with is a run-time parameter: ``waves`` at construction (RegularWaves or
    CalmWater), then whatever ``set_wave`` gives. Any other WaveField is built into the model instead
    (one build per field) and cannot be changed.
    """

    def __init__(self, config: NmpcConfig | None = None, params: OtterParameters | None = None,
                 waves: WaveField | None = None, current: OceanCurrent | None = None, wind: Wind | None = None) -> None:
        self.config = config or NmpcConfig()
        self.params = params or self.config.model.params()  # (the model's hull, published unless set)
        self.waves: WaveField = waves or CalmWater()
        self.current = current or OceanCurrent()
        self.wind = wind  # built in: simulation truth for a bound only (the companion never knows it)
        self._functions = problem_functions(self.params, self.waves, self.current, self.config, wind)
        self._step = self._functions.step
        self.layout = self._functions.layout
        self._sea = SeaKnowledge(self.config, self._functions.fixed_waves, self.waves)
        self._own_backend(make_backend(self._functions, self.config))
        self._prepared_feedback = getattr(self._backend, "prepared_feedback", None)  # nrti: see ``_feedback_only``
        self.inputs: InputSpace = input_space(self.config, self.params)
        self._lbw, self._ubw = input_bounds(self.config, self.layout, self.inputs)
        self._safe = self.inputs.clip(self.inputs.from_tau(np.array([self.config.safe_surge_n, 0.0])))
        self.reset()

    def reset(self) -> None:
        """Forget the previous plan, multipliers and last input (a new run starts from a cold start)."""
        self._w: np.ndarray | None = None
        self._lam_w: np.ndarray | None = None
        self._lam_g: np.ndarray | None = None
        self._plan_age = 0
        self._plan_t: float | None = None  # the time the stored plan starts at
        self._u_applied = np.zeros(NU)
        self._dual_shifts = 0  # steps whose shift of the stored multipliers is still to be made (``_stored_duals``)
        self._deferred: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None  # (plan, p, u) for ``advance``
        if not self._closed:
            self._backend.reset()  # asrti: let a running background solve end, and forget it

    # --- the wave -------------------------------------------------------------------------------------

    @property
    def takes_waves(self) -> bool:
        """True when ``set_wave`` works: built with a regular wave or calm water, not a fixed field."""
        return self._functions.fixed_waves is None

    def pace(self, wall_period_s: float) -> None:
        """Fly in real time, periods of ``wall_period_s`` wall seconds: a step waits a quarter of one at most for
        the background plan; nrti's preparation iterates for three quarters, then hands over its last QP (RTI).
        Without a call (lockstep, experiments) nothing is timed; solvers with no background ignore it."""
        advanced = getattr(self._backend, "advanced", None)
        if advanced is not None:
            advanced.pace(float(wall_period_s))

    def _parameters(self, x0: np.ndarray, t: float, waypoint: np.ndarray) -> np.ndarray:
        return self._sea.pack(x0, t, waypoint, self._u_applied)

    # --- solving --------------------------------------------------------------------------------------

    @property
    def last_input(self) -> np.ndarray:
        """The input (τ_X, τ_N) returned by the last solve (zero after reset)."""
        return self.inputs.to_tau(self._u_applied).copy()

    def _rollout(self, x0: np.ndarray, t: float) -> np.ndarray:
        return rollout(self._step, self.layout, x0, t, self._safe, self.config.period_s, self._sea.model_wave())

    def prepare(self, x0: Any, t: float, waypoint_ne: Any) -> NmpcResult:
        """The cold, full solve for (x0, t, waypoint), done before the control loop starts.

        The plan is kept (the input is not applied and the last input stays as it was), so the first
        ``solve`` at the same time ``t`` starts warm from it rather than with a full solve.
        """
        self._check_open()
        x0, t, waypoint = model_inputs(self.config, x0, t, waypoint_ne)
        self.reset()
        start = time.perf_counter()
        guess = self._rollout(x0, t)
        p = self._parameters(x0, t, waypoint)
        outcome: SolveOutcome = self._backend.prepare(guess, p, self._lbw, self._ubw)
        wall = time.perf_counter() - start
        plan = guess
        if outcome.usable:
            self._w, self._lam_w, self._lam_g = outcome.w, outcome.lam_w, outcome.lam_g
            self._plan_t = t
            plan = outcome.w
        X, U = self.layout.split(plan)
        u = U[0].copy() if outcome.usable else self._safe.copy()
        return NmpcResult(tau=self.inputs.to_tau(u), states=X, inputs=self.inputs.to_tau(U),
                          wall_time_s=wall, iterations=outcome.iterations, status=outcome.status,
                          success=outcome.usable, fallback=None if outcome.usable else f"solver failed: "
                          f"{outcome.status}", fallback_source=None if outcome.usable else "safe",
                          stats={"violation": outcome.violation}, roll_term_active=self.roll_term_active)

    def _warm_guess(self, x0: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
        """(primal guess with x0 in place, λ_w, λ_g): the stored plan (shifted unless it starts at t)."""
        current = self._plan_t is not None and abs(self._plan_t - t) < 1e-9  # the plan from ``prepare``
        guess = self._rollout(x0, t) if self._w is None else self._w.copy() if current else self.layout.shift(self._w)
        guess[self.layout.x_index(0)] = x0
        lam_w, lam_g = self._stored_duals()
        if not current:
            lam_w, lam_g = shift_duals(self.layout, lam_w, lam_g)
        return guess, lam_w, lam_g

    def _stored_duals(self) -> tuple[np.ndarray | None, np.ndarray | None]:
        """The stored multipliers with the shifts the prepared feedback's steps left to be made (``_feedback_only``),
        made at once: a step after a long run of them costs no more than one shift."""
        self._lam_w, self._lam_g = shift_duals_by(self.layout, self._lam_w, self._lam_g, self._dual_shifts)
        self._dual_shifts = 0
        return self._lam_w, self._lam_g

    def _feedback_only(self, p: np.ndarray, t: float) -> SolveOutcome | None:
        """nrti's step on the QP prepared for p, without a warm start (None: not nrti, no stored plan, or no usable
        feedback; then the full step). Its plan is stored; the multipliers are kept as they were, their shift for
        this step left to be made when a warm start needs them (``_stored_duals``): the same warm starts, bit for
        bit, as shifting them every step."""
        if self._prepared_feedback is None or self._w is None or self._lam_w is None or self._lam_g is None:
            return None
        outcome = self._prepared_feedback(p)
        if outcome is None:
            return None
        self._dual_shifts += not (self._plan_t is not None and abs(self._plan_t - t) < 1e-9)
        return outcome

    def solve(self, x0: Any, t: float, waypoint_ne: Any, deadline_s: float | None = None,
              defer_advance: bool = False) -> NmpcResult:
        """Plan from state x0 (12 rigid-body states) at time t (s) towards waypoint (north, east) m.

        ``deadline_s``: a solve taking longer (wall clock) is answered by the fallback input. With the
        asrti solver, the wait for the background solve started at the previous step is not part of the
        step's time (in real time that solve runs during the rest of the period); it is in ``stats``.
        ``defer_advance``: the work ahead for the next period (asrti, nrti: the background preparation) is not
        started here but by ``advance()``, which the companion calls once the command is sent, so that the
        command neither waits for its start nor shares the interpreter with it; ``wall_time_s`` then ends at
        the input. The next ``solve`` starts what was left if ``advance`` was not called.
        """
        self._check_open()
        self.advance()
        x0, t, waypoint = model_inputs(self.config, x0, t, waypoint_ne)
        start = time.perf_counter()
        have_plan = self._w is not None and self._plan_age < self.layout.horizon
        p = self._parameters(x0, t, waypoint)
        guess = lam_w = lam_g = None  # the warm start: made only when the step needs it
        outcome = self._feedback_only(p, t)
        if outcome is None:
            guess, lam_w, lam_g = self._warm_guess(x0, t)
            outcome = self._backend.solve(guess, p, self._lbw, self._ubw, lam_w, lam_g)
            if outcome.start is not None:  # the backend started from its own plan (asrti: the background one)
                guess = outcome.start
        wall = time.perf_counter() - start - outcome.wait_s
        late = deadline_s is not None and wall > deadline_s
        if late and guess is None:  # the fallback is the previous plan's next input: from the plan stored until now
            guess = self._warm_guess(x0, t)[0]
        u_chosen, plan, fallback, source = self._choose_input(outcome, guess, lam_w, lam_g, have_plan, t)
        if fallback is None and late:
            fallback = f"late: {wall * 1e3:.1f} ms > deadline {deadline_s * 1e3:.1f} ms"
            u_chosen, source = self._fallback_input(guess, have_plan, outcome.usable)
        u = self.inputs.clip(u_chosen)  # the model's input u: τ, or the propeller thrusts
        self._u_applied = u.copy()
        if outcome.usable:
            self._deferred = (plan, p, u)
            if not defer_advance:
                self.advance()
                wall = time.perf_counter() - start - outcome.wait_s  # starting work ahead is part of the step
        X, U = self.layout.split(plan)
        stats = {"violation": outcome.violation, "background_wait_s": outcome.wait_s, **outcome.stats}
        return NmpcResult(tau=self.inputs.to_tau(u), states=X, inputs=self.inputs.to_tau(U), wall_time_s=wall,
                          iterations=outcome.iterations, status=outcome.status, success=outcome.usable,
                          fallback=fallback,
                          fallback_source=source, stats=stats, roll_term_active=self.roll_term_active)

    def advance(self) -> None:
        """Start the work ahead that ``solve(..., defer_advance=True)`` left (nothing if none is left)."""
        if self._deferred is not None:
            plan, p, u = self._deferred
            self._deferred = None
            self._backend.advance(plan, p, u)

    def _choose_input(self, outcome: SolveOutcome, guess: np.ndarray | None, lam_w: np.ndarray | None,
                      lam_g: np.ndarray | None, have_plan: bool,
                      t: float) -> tuple[np.ndarray, np.ndarray, str | None, str | None]:
        """(u, plan, fallback reason, fallback source) after a solve (u: the model's input); stores the plan
        for the next step (and the outcome's multipliers, unless it has none: the prepared feedback's)."""
        self._plan_t = t
        if outcome.usable:
            self._w = outcome.w
            if outcome.lam_w is not None:
                self._lam_w, self._lam_g = outcome.lam_w, outcome.lam_g
            self._plan_age = 0
            return outcome.w[self.layout.u_index(0)].copy(), outcome.w, None, None
        self._w, self._lam_w, self._lam_g = guess, lam_w, lam_g  # (a failed step always made its warm start)
        self._plan_age += 1
        tau, source = self._fallback_input(guess, have_plan, usable=False)
        return tau, guess, f"solver failed: {outcome.status}", source

    def _fallback_input(self, guess: np.ndarray, have_plan: bool, usable: bool) -> tuple[np.ndarray, str]:
        """The previous plan's next input while it is within its horizon, else the safe input."""
        planned_next = guess[self.layout.u_index(0)].copy()
        if have_plan and np.all(np.isfinite(planned_next)):
            return planned_next, "previous_plan"
        if not usable:  # nothing worth warm-starting from: the next solve starts cold
            self._w, self._lam_w, self._lam_g = None, None, None
        return self._safe.copy(), "safe"
