"""RollAwareNmpc: builds the solver once, warm-starts it each period, and always answers with an input.

A solve that fails, or that finishes after the caller's deadline, is reported (``NmpcResult.fallback``)
and answered with the next input of the previous plan when one is still within its horizon, else with
the safe input (gentle forward surge, zero yaw moment). The answer is never NaN.
"""

from __future__ import annotations

import contextlib
import time
from concurrent.futures import TimeoutError as FuturesTimeout
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vessel import STATE_NAMES, CalmWater, OceanCurrent, OtterParameters, WaveField, otter_parameters

from .backend import SolveOutcome
from .config import NmpcConfig
from .ipopt import IpoptBackend
from .problem import NU, NX, Layout, build_nlp, discrete_model, input_bounds, pack_parameters

_BUILT: dict[Any, tuple[Any, Any, Layout]] = {}


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


def _build(params: OtterParameters, waves: WaveField, current: OceanCurrent, cfg: NmpcConfig):
    """Discrete model, NLP layout and backend for a structure; cached per process."""
    key = (params, waves, current, cfg.structural())
    try:
        cached = _BUILT.get(key)
    except TypeError:  # an unhashable wave field: build every time
        key, cached = None, None
    if cached is not None:
        return cached
    step = discrete_model(params, waves, current, cfg)
    nlp, layout = build_nlp(step, cfg)
    if cfg.solver in ("rti", "asrti"):
        from .rti import RtiBackend  # optional, heavier to build

        backend = RtiBackend(nlp, layout, cfg, step, background=cfg.solver == "asrti", problem=(params, waves, current))
    else:
        backend = IpoptBackend(nlp, layout, cfg)
    built = (step, backend, layout)
    if key is not None:
        _BUILT[key] = built
    return built


def _check_finite(values: Any, expected: int, field_name: str, names: tuple[str, ...] | None = None) -> np.ndarray:
    try:
        arr = np.asarray(values, dtype=float).ravel()
    except (TypeError, ValueError):
        raise ValueError(f"{field_name}: expected {expected} numbers, got {values!r}") from None
    if arr.size != expected:
        raise ValueError(f"{field_name}: expected {expected} numbers, got {arr.size}")
    bad = np.flatnonzero(~np.isfinite(arr))
    if bad.size:
        i = int(bad[0])
        label = f"{field_name}[{i}]" + (f" ({names[i]})" if names else "")
        raise ValueError(f"{label} is not finite: {arr[i]!r}")
    return arr


class RollAwareNmpc:
    """The paper's roll-aware NMPC for the Otter; ``solve`` once per control period."""

    def __init__(self, config: NmpcConfig | None = None, params: OtterParameters | None = None,
                 waves: WaveField | None = None, current: OceanCurrent | None = None) -> None:
        self.config = config or NmpcConfig()
        self.params = params or otter_parameters("published")
        self.waves = waves or CalmWater()
        self.current = current or OceanCurrent()
        self._step, self._backend, self.layout = _build(self.params, self.waves, self.current, self.config)
        self._lbw, self._ubw = input_bounds(self.config, self.layout)
        self._safe = np.array([self.config.safe_surge_n, 0.0])
        self.reset()

    def reset(self) -> None:
        """Forget the previous plan, multipliers and last input (a new run starts from a cold start)."""
        self._w: np.ndarray | None = None
        self._lam_w: np.ndarray | None = None
        self._lam_g: np.ndarray | None = None
        self._plan_age = 0
        self._plan_t: float | None = None  # the time the stored plan starts at
        self._u_applied = np.zeros(NU)
        pending = getattr(self, "_pending", None)
        if pending is not None:  # let a running background solve end before the model is used here again
            with contextlib.suppress(FuturesTimeout):
                pending[0].result(timeout=self.config.as_wait_s)
        self._pending = None  # asrti: (Future, key) of the background solve for the next period
        if hasattr(self._backend, "reset"):
            self._backend.reset()

    @property
    def last_input(self) -> np.ndarray:
        """The input returned by the last solve (zero after reset)."""
        return self._u_applied.copy()

    def _rollout(self, x0: np.ndarray, t: float) -> np.ndarray:
        """A dynamically consistent cold-start guess: the safe input held over the horizon."""
        X = np.empty((self.layout.horizon + 1, NX))
        X[0] = x0
        for k in range(self.layout.horizon):
            nxt = np.asarray(self._step(X[k], self._safe, t + k * self.config.period_s)).ravel()
            X[k + 1] = nxt if np.all(np.isfinite(nxt)) else X[k]
        U = np.tile(self._safe, (self.layout.horizon, 1))
        return self.layout.join(X, U)

    def _shift_duals(self) -> tuple[np.ndarray | None, np.ndarray | None]:
        if self._lam_w is None or self._lam_g is None:
            return None, None
        lam_w = self.layout.shift(self._lam_w)
        gaps = self._lam_g[NX:].reshape(self.layout.horizon, NX)
        lam_g = np.concatenate([-gaps[0], gaps[1:].ravel(), gaps[-1]])
        return lam_w, lam_g

    def prepare(self, x0: Any, t: float, waypoint_ne: Any) -> NmpcResult:
        """The cold, full solve for (x0, t, waypoint), done before the control loop starts.

        The plan is kept (the input is not applied and the last input stays as it was), so the first
        ``solve`` at the same time ``t`` starts warm from it rather than with a full solve.
        """
        x0 = _check_finite(x0, NX, "x0", STATE_NAMES)
        t = float(_check_finite([t], 1, "t")[0])
        waypoint = _check_finite(waypoint_ne, 2, "waypoint_ne", ("north", "east"))
        self.reset()
        if hasattr(self._backend, "warm_up") and self.config.solver == "asrti":
            self._backend.warm_up()
        start = time.perf_counter()
        cfg = self.config
        guess = self._rollout(x0, t)
        p = pack_parameters(x0, t, waypoint, self._u_applied, cfg.weights)
        outcome: SolveOutcome = self._backend.solve(guess, p, self._lbw, self._ubw, None, None)
        wall = time.perf_counter() - start
        plan = guess
        if outcome.usable:
            self._w, self._lam_w, self._lam_g = outcome.w, outcome.lam_w, outcome.lam_g
            self._plan_t = t
            plan = outcome.w
        X, U = self.layout.split(plan)
        return NmpcResult(tau=U[0].copy() if outcome.usable else self._safe.copy(), states=X, inputs=U,
                          wall_time_s=wall, iterations=outcome.iterations, status=outcome.status,
                          success=outcome.usable, fallback=None if outcome.usable else f"solver failed: "
                          f"{outcome.status}", fallback_source=None if outcome.usable else "safe",
                          stats={"violation": outcome.violation})

    def _collect_background(self, t: float, waypoint: np.ndarray) -> tuple[np.ndarray | None, dict]:
        """asrti: the background plan for time t (waiting for it up to ``as_wait_s``), if it fits this step."""
        if self._pending is None:
            return None, {}
        future, t_expected, waypoint_expected = self._pending
        self._pending = None
        try:
            w, p_next, seconds, iterations = future.result(timeout=self.config.as_wait_s)
        except FuturesTimeout:
            return None, {"background": "late"}
        info = {"background_solve_s": seconds, "background_iterations": iterations}
        stale = abs(t - t_expected) > 0.5 * self.config.period_s
        if (w is None or stale or not np.array_equal(waypoint, waypoint_expected)
                or not np.array_equal(p_next[NX + 3:NX + 5], self._u_applied)):
            info["background"] = "unused"
            return None, info
        info["background"] = "used"
        return w, info

    def solve(self, x0: Any, t: float, waypoint_ne: Any, deadline_s: float | None = None) -> NmpcResult:
        """Plan from state x0 (12 rigid-body states) at time t (s) towards waypoint (north, east) m.

        ``deadline_s``: a solve taking longer (wall clock) is answered by the fallback input. With the
        asrti solver, the wait for the background solve started at the previous step is not part of the
        step's time (in real time that solve runs during the rest of the period); it is in ``stats``.
        """
        x0 = _check_finite(x0, NX, "x0", STATE_NAMES)
        t = float(_check_finite([t], 1, "t")[0])
        waypoint = _check_finite(waypoint_ne, 2, "waypoint_ne", ("north", "east"))
        wait_start = time.perf_counter()
        prepared, extra = self._collect_background(t, waypoint)
        extra["background_wait_s"] = time.perf_counter() - wait_start
        start = time.perf_counter()
        cfg = self.config
        have_plan = self._w is not None and self._plan_age < self.layout.horizon
        current = self._plan_t is not None and abs(self._plan_t - t) < 1e-9  # the plan from ``prepare``
        if self._w is None:
            guess = self._rollout(x0, t)
        elif prepared is not None:
            guess = prepared.copy()
        elif current:
            guess = self._w.copy()
        else:
            guess = self.layout.shift(self._w)
        guess[self.layout.x_index(0)] = x0
        lam_w, lam_g = (self._lam_w, self._lam_g) if current else self._shift_duals()
        planned_next = guess[self.layout.u_index(0)].copy()
        p = pack_parameters(x0, t, waypoint, self._u_applied, cfg.weights)
        outcome: SolveOutcome = self._backend.solve(guess, p, self._lbw, self._ubw, lam_w, lam_g)
        wall = time.perf_counter() - start

        fallback = None
        if outcome.usable:
            self._w, self._lam_w, self._lam_g = outcome.w, outcome.lam_w, outcome.lam_g
            self._plan_age = 0
            self._plan_t = t
            plan = outcome.w
            tau = outcome.w[self.layout.u_index(0)].copy()
            if deadline_s is not None and wall > deadline_s:
                fallback = f"late: {wall * 1e3:.1f} ms > deadline {deadline_s * 1e3:.1f} ms"
        else:
            fallback = f"solver failed: {outcome.status}"
            self._w, self._lam_w, self._lam_g = guess, lam_w, lam_g
            self._plan_age += 1
            self._plan_t = t
            plan = guess
            tau = planned_next
        source = None
        if fallback is not None:
            if have_plan and np.all(np.isfinite(planned_next)):
                tau, source = planned_next, "previous_plan"
            else:
                tau, source = self._safe.copy(), "safe"
                if not outcome.usable:  # nothing worth warm-starting from: the next solve starts cold
                    self._w, self._lam_w, self._lam_g = None, None, None
        tau = np.clip(tau, [cfg.tau_x_min_n, -cfg.tau_n_max_nm], [cfg.tau_x_max_n, cfg.tau_n_max_nm])
        self._u_applied = tau.copy()
        if cfg.solver == "asrti" and outcome.usable and self._lam_w is not None:
            future = self._backend.start_background(plan, p, tau)
            self._pending = (future, t + cfg.period_s, waypoint.copy())
            wall = time.perf_counter() - start  # starting the background solve is part of the step's time
        X, U = self.layout.split(plan)
        return NmpcResult(tau=tau, states=X, inputs=U, wall_time_s=wall, iterations=outcome.iterations,
                          status=outcome.status, success=outcome.usable, fallback=fallback,
                          fallback_source=source, stats={"violation": outcome.violation, **extra})
