"""The model's input space: (τ_X, τ_N) in a box (the paper's), or the two propeller thrusts in theirs.

``NmpcConfig.inputs``:

* ``tau`` — u = (τ_X N, τ_N N·m) within the box ``tau_x_min_n..tau_x_max_n`` × ±``tau_n_max_nm``, the
  paper's setting (Table III). The box is larger than what the propellers give at its corners: on the
  propeller plant the allocation saturates there, and the plant does not do what the model planned.
* ``propellers`` — u = (left, right thrust, N), each within [−k_neg·n_min², k_pos·n_max²] (the thrust
  law at the saturated shaft speeds), and τ = B·u inside the prediction model, B from
  ``vessel.allocation.thrust_to_tau``. The box on u is the allocation's envelope (a parallelogram in
  (τ_X, τ_N)), so every backend keeps its plain input bounds and a planned input is one the propellers
  can give.

The controller converts u back to τ at its boundary (``to_tau``), so its answers, logs and plants see
(τ_X, τ_N) whatever the setting. The input-change weights W keep acting on Δτ = B·Δu: the cost is the
paper's in both settings, only the feasible set differs.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from mavbridge.nmpc.config import NmpcConfig
from vessel import OtterParameters
from vessel.allocation import thrust_to_tau


def allocation_matrix(params: OtterParameters) -> np.ndarray:
    """B (2×2) with (τ_X, τ_N) = B·(left, right thrust): the columns of ``thrust_to_tau`` (single source)."""
    return np.array([thrust_to_tau(params, 1.0, 0.0), thrust_to_tau(params, 0.0, 1.0)], float).T


def thrust_limits(params: OtterParameters) -> tuple[float, float]:
    """(most reverse thrust (negative), most forward thrust) of one propeller, N, at the saturated shafts."""
    mats = params.matrices()
    return -mats.k_neg * mats.n_min**2, mats.k_pos * mats.n_max**2


def model_matrix(cfg: NmpcConfig, params: OtterParameters) -> np.ndarray | None:
    """B for the prediction model, or None when u is τ itself (the model is then built exactly as before)."""
    return allocation_matrix(params) if cfg.inputs == "propellers" else None


def input_tau(u: ca.SX, matrix: np.ndarray | None) -> ca.SX:
    """τ for the model input u (symbolic): u itself, or B·u."""
    if matrix is None:
        return u
    return ca.vertcat(matrix[0, 0] * u[0] + matrix[0, 1] * u[1], matrix[1, 0] * u[0] + matrix[1, 1] * u[1])


@dataclass(frozen=True, eq=False)  # eq=False: compared and hashed by identity (its arrays are not hashable)
class InputSpace:
    """The controller's view of u: its box, and the conversions to and from (τ_X, τ_N)."""

    kind: str
    matrix: np.ndarray | None  # B, or None for u = τ
    low: np.ndarray  # per element of u
    high: np.ndarray

    def to_tau(self, u: np.ndarray) -> np.ndarray:
        """(τ_X, τ_N) of one input, or of a plan's inputs (rows); u itself when u is τ."""
        u = np.asarray(u, float)
        return u if self.matrix is None else u @ self.matrix.T

    def from_tau(self, tau: np.ndarray) -> np.ndarray:
        """The input giving τ exactly (B⁻¹·τ; τ itself when u is τ); not clipped."""
        tau = np.asarray(tau, float)
        return tau.copy() if self.matrix is None else np.linalg.solve(self.matrix, tau)

    def clip(self, u: np.ndarray) -> np.ndarray:
        """u within its box (one input in plain floats: np.clip's own cost is most of it, every step)."""
        if type(u) is np.ndarray and u.shape == self.low.shape == (2,):
            (a, b), (low_a, low_b), (high_a, high_b) = u.tolist(), self.low.tolist(), self.high.tolist()
            return np.array([_clip(a, low_a, high_a), _clip(b, low_b, high_b)], float)
        return np.clip(u, self.low, self.high)


def _clip(x: float, low: float, high: float) -> float:
    """np.clip of one number, bit for bit: a bound on a tie (0.0 for −0.0 at a bound of 0.0), NaN stays NaN."""
    x = x if x > low or x != x else low
    return x if x < high or x != x else high


def input_space(cfg: NmpcConfig, params: OtterParameters | None) -> InputSpace:
    """The input space of this configuration and vessel (see the module docstring); ``params`` may be None
    for the τ inputs only."""
    if cfg.inputs == "tau":
        return InputSpace("tau", None, np.array([cfg.tau_x_min_n, -cfg.tau_n_max_nm]),
                          np.array([cfg.tau_x_max_n, cfg.tau_n_max_nm]))
    if params is None:
        raise ValueError("input_space: propeller-thrust inputs need the vessel parameters")
    reverse, forward = thrust_limits(params)
    return InputSpace("propellers", allocation_matrix(params), np.array([reverse, reverse]),
                      np.array([forward, forward]))
