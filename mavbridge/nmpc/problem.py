"""The paper's optimal control problem, written once in CasADi: discrete model, cost terms, NLP layout.

Decision vector (stage-wise, multiple shooting): w = [x_0, u_0, x_1, u_1, …, x_{P−1}, u_{P−1}, x_P],
x_k the 12 rigid-body states, u_k = (τ_X N, τ_N N·m). Parameters p = [x̂ (12), t (s), waypoint (north,
east m), u_prev (2), Q, R, S, W11, W22], so one built solver serves any run, time and tuning.

Cost (paper eq. 9, stage costs on the predicted states 1..P, input changes on the P inputs):
    J = Σ_{i=1..P} [Q·e_ψ,i² + R·φ_i² + S·d_i + w_min·max(0, u_min − u_i)²] + Σ_{k=0..P−1} ΔU_kᵀ W ΔU_k
with e_ψ = wrap(atan2(Δeast, Δnorth) − ψ), d = sqrt(Δnorth² + Δeast² + 1e-6), ΔU_k = U_k − U_{k−1}
(U_{−1} = the input applied in the previous period).
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from vessel import NX_RIGID, OceanCurrent, OtterParameters, WaveField, rigid_body_ode
from vessel.plant import rk4_step

from .config import NmpcConfig

NX = NX_RIGID
NU = 2
NP = NX + 1 + 2 + NU + 5  # x̂, t, waypoint, u_prev, weights
DIST_EPS = 1e-6


def wrap_angle(angle: ca.SX) -> ca.SX:
    """Angle wrapped to (−π, π] by atan2(sin a, cos a); works on CasADi symbols and numbers."""
    return ca.atan2(ca.sin(angle), ca.cos(angle))


def heading_error(x: ca.SX, waypoint: ca.SX) -> ca.SX:
    """Wrapped bearing-to-waypoint minus heading, rad (bearing = atan2(Δeast, Δnorth))."""
    bearing = ca.atan2(waypoint[1] - x[1], waypoint[0] - x[0])
    return wrap_angle(bearing - x[5])


def distance(x: ca.SX, waypoint: ca.SX) -> ca.SX:
    """Horizontal distance to the waypoint, m (smooth at zero)."""
    return ca.sqrt((waypoint[0] - x[0]) ** 2 + (waypoint[1] - x[1]) ** 2 + DIST_EPS)


def discrete_model(params: OtterParameters, waves: WaveField, current: OceanCurrent,
                   cfg: NmpcConfig) -> ca.Function:
    """One control period of the NMPC model: (x[12], u[2], t) -> x after period_s, held input."""
    ode = rigid_body_ode(params, waves, current)
    h = cfg.period_s / cfg.substeps
    x = ca.SX.sym("x", NX)
    u = ca.SX.sym("u", NU)
    t = ca.SX.sym("t")
    xk = x
    if cfg.integrator == "rk4":
        step = rk4_step(ode, h)
        for i in range(cfg.substeps):
            xk = step(xk, u, t + i * h)
    else:
        for i in range(cfg.substeps):
            xk = xk + h * ode(xk, u, t + i * h)
    return ca.Function("nmpc_step", [x, u, t], [xk], ["x", "u", "t"], ["x_next"])


@dataclass(frozen=True)
class Layout:
    """Where each stage's x and u live in the decision vector w."""

    horizon: int

    @property
    def n_w(self) -> int:
        """Number of decision variables."""
        return (self.horizon + 1) * NX + self.horizon * NU

    def x_index(self, k: int) -> slice:
        """Slice of x_k in w."""
        start = k * (NX + NU)
        return slice(start, start + NX)

    def u_index(self, k: int) -> slice:
        """Slice of u_k in w."""
        start = k * (NX + NU) + NX
        return slice(start, start + NU)

    def split(self, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(X (P+1)×12, U P×2) from a decision vector."""
        w = np.asarray(w, float).ravel()
        P = self.horizon
        stages = w[:P * (NX + NU)].reshape(P, NX + NU)
        X = np.vstack([stages[:, :NX], w[P * (NX + NU):][None, :]])
        return X, stages[:, NX:].copy()

    def join(self, X: np.ndarray, U: np.ndarray) -> np.ndarray:
        """Decision vector from X and U."""
        P = self.horizon
        return np.concatenate([np.hstack([X[:P], U]).ravel(), X[P]])

    def shift(self, w: np.ndarray) -> np.ndarray:
        """The plan one period later: stage k takes stage k+1, the last stage is repeated."""
        w = np.asarray(w, float)
        P, m = self.horizon, NX + NU
        out = np.empty_like(w)
        out[:(P - 1) * m] = w[m:P * m]
        out[(P - 1) * m:(P - 1) * m + NX] = w[P * m:]  # x_{P-1} <- x_P
        out[(P - 1) * m + NX:P * m] = w[(P - 1) * m + NX:P * m]  # u_{P-1} repeated
        out[P * m:] = w[P * m:]  # x_P repeated
        return out


def unpack_parameters(p: ca.SX) -> tuple[ca.SX, ca.SX, ca.SX, ca.SX, ca.SX]:
    """(x̂, t, waypoint, u_prev, weights) from the parameter vector."""
    return p[0:NX], p[NX], p[NX + 1:NX + 3], p[NX + 3:NX + 5], p[NX + 5:NX + 10]


def pack_parameters(x0: np.ndarray, t: float, waypoint: np.ndarray, u_prev: np.ndarray,
                    weights: tuple[float, ...]) -> np.ndarray:
    """The numeric parameter vector."""
    return np.concatenate([x0, [t], waypoint, u_prev, weights]).astype(float)


def state_cost(x: ca.SX, waypoint: ca.SX, weights: ca.SX, cfg: NmpcConfig) -> ca.SX:
    """Q·e_ψ² + R·φ² + S·d + soft minimum-speed penalty for one predicted state."""
    q, r, s = weights[0], weights[1], weights[2]
    e = heading_error(x, waypoint)
    shortfall = ca.fmax(0, cfg.min_speed_mps - x[6])
    return q * e**2 + r * x[3] ** 2 + s * distance(x, waypoint) + cfg.min_speed_weight * shortfall**2


def input_change_cost(u: ca.SX, u_before: ca.SX, weights: ca.SX) -> ca.SX:
    """ΔUᵀ W ΔU with W = diag(W11, W22)."""
    du = u - u_before
    return weights[3] * du[0] ** 2 + weights[4] * du[1] ** 2


def build_nlp(step: ca.Function, cfg: NmpcConfig) -> tuple[dict, Layout]:
    """The multiple-shooting NLP {x, p, f, g}; g = [x_0 − x̂, F(x_k, u_k, t_k) − x_{k+1} …] = 0."""
    layout = Layout(cfg.horizon)
    w = ca.SX.sym("w", layout.n_w)
    p = ca.SX.sym("p", NP)
    x_hat, t0, waypoint, u_prev, weights = unpack_parameters(p)
    g = [w[layout.x_index(0)] - x_hat]
    f = 0
    u_before = u_prev
    for k in range(cfg.horizon):
        xk, uk = w[layout.x_index(k)], w[layout.u_index(k)]
        x_next = w[layout.x_index(k + 1)]
        g.append(step(xk, uk, t0 + k * cfg.period_s) - x_next)
        f += input_change_cost(uk, u_before, weights) + state_cost(x_next, waypoint, weights, cfg)
        u_before = uk
    return {"x": w, "p": p, "f": f, "g": ca.vertcat(*g)}, layout


def input_bounds(cfg: NmpcConfig, layout: Layout) -> tuple[np.ndarray, np.ndarray]:
    """lbw, ubw: inputs within the τ bounds, states free."""
    lbw = np.full(layout.n_w, -np.inf)
    ubw = np.full(layout.n_w, np.inf)
    for k in range(cfg.horizon):
        lbw[layout.u_index(k)] = (cfg.tau_x_min_n, -cfg.tau_n_max_nm)
        ubw[layout.u_index(k)] = (cfg.tau_x_max_n, cfg.tau_n_max_nm)
    return lbw, ubw
