"""Small numerical tools the estimators share, in numpy alone (the project carries no SciPy): a bounded
Levenberg–Marquardt least-squares fit, and the alternating extrema of a noisy signal by hysteresis."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

Residuals = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class LsqResult:
    """The parameters found, their residuals and the Jacobian there (for a covariance)."""

    x: np.ndarray
    fun: np.ndarray
    jac: np.ndarray


def jacobian(fun: Residuals, x: np.ndarray, f0: np.ndarray) -> np.ndarray:
    """Forward-difference Jacobian of ``fun`` at ``x``."""
    J = np.empty((f0.size, x.size))
    for k in range(x.size):
        h = 1e-6 * max(1.0, abs(float(x[k])))
        step = x.copy()
        step[k] += h
        J[:, k] = (fun(step) - f0) / h
    return J


def least_squares(fun: Residuals, x0: np.ndarray, lower: np.ndarray, upper: np.ndarray,
                  iterations: int = 200) -> LsqResult:
    """Minimise Σ fun(x)² within [lower, upper] (Levenberg–Marquardt, steps clipped into the bounds)."""
    lower, upper = np.asarray(lower, float), np.asarray(upper, float)
    x = np.clip(np.asarray(x0, float), lower, upper)
    f = fun(x)
    cost, damping = float(f @ f), 1e-3
    J = jacobian(fun, x, f)
    for _ in range(iterations):
        A, g = J.T @ J, J.T @ f
        step = np.linalg.solve(A + damping * np.diag(np.diag(A) + 1e-12), -g)
        trial = np.clip(x + step, lower, upper)
        f_trial = fun(trial)
        trial_cost = float(f_trial @ f_trial)
        if np.isfinite(trial_cost) and trial_cost < cost:
            done = cost - trial_cost < 1e-12 * max(cost, 1e-30)
            x, f, cost, damping = trial, f_trial, trial_cost, max(damping / 3, 1e-9)
            J = jacobian(fun, x, f)
            if done:
                break
        else:
            damping *= 4
            if damping > 1e10:
                break
    return LsqResult(x, f, J)


def turning_points(y: np.ndarray, prominence: float) -> np.ndarray:
    """Indices of alternating maxima and minima of ``y``: an extremum counts once the signal has come back from it
    by ``prominence`` (noise smaller than that makes no extremum)."""
    if y.size < 3:
        return np.empty(0, int)
    hi = lo = 0
    i = 1
    while i < y.size and y[hi] - y[i] < prominence and y[i] - y[lo] < prominence:
        hi, lo = (i if y[i] > y[hi] else hi), (i if y[i] < y[lo] else lo)
        i += 1
    if i == y.size:
        return np.empty(0, int)
    direction = 1 if y[hi] - y[i] >= prominence else -1  # +1: the first extremum is a maximum
    best = hi if direction > 0 else lo
    out: list[int] = []
    for k in range(best + 1, y.size):
        if (y[k] - y[best]) * direction > 0:
            best = k
        elif abs(y[k] - y[best]) >= prominence:
            out.append(best)
            direction, best = -direction, k
    return np.asarray(out, int)
