"""The paper's optimal control problem, written once in CasADi: discrete model, cost terms, NLP.

Decision vector (stage-wise, multiple shooting): w = [x_0, u_0, x_1, u_1, …, x_{P−1}, u_{P−1}, x_P],
x_k the 12 rigid-body states, u_k = (τ_X N, τ_N N·m), or the two propeller thrusts with τ_k = B·u_k in
the model (``NmpcConfig.inputs``, see ``inputs``). Parameters p: the named blocks of
``layout.PARAMS`` (x̂, t, waypoint, u_prev, weights, wave), so one built solver serves any run, time,
tuning and regular wave.

Cost (paper eq. 9, stage costs on the predicted states 1..P, input changes on the P inputs):
    J = Σ_{i=1..P} [Q·e_ψ,i² + R·φ_i² + S·d_i + w_min·max(0, u_min − u_i)²] + Σ_{k=0..P−1} ΔU_kᵀ W ΔU_k
with e_ψ = wrap(atan2(Δeast, Δnorth) − ψ), d = sqrt(Δnorth² + Δeast² + 1e-6), ΔU_k = U_k − U_{k−1}
(U_{−1} = the input applied in the previous period). A sea the wave model does not explain (an
irregular sea's unpredictable part) adds its expected roll to R·φ_i²: ‖Lᵀy_i‖², y_i = (−sin ψ_i, cos ψ_i)
the body y axis in NED and L the ``roll_spread`` block (zero: no term, the paper's cost).
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np

from mavbridge.nmpc.config import NmpcConfig
from mavbridge.nmpc.inputs import InputSpace, input_space, input_tau, model_matrix
from mavbridge.nmpc.layout import (
    DISTURBANCE_NAMES,
    NP,
    NU,
    NX,
    PARAMS,
    Layout,
    members,
    parameter_layout,
    wave_input_size,
)
from mavbridge.nmpc.wave_bank import model_field
from mavbridge.nmpc.wave_model import CALM_PARAMETERS
from vessel import OceanCurrent, OtterParameters, WaveField
from vessel.dynamics import NedCurrent, body_acceleration, kinematics
from vessel.sea.wind import Wind

__all__ = ["NP", "NU", "NX", "PARAMS", "Layout", "build_nlp", "discrete_model", "distance", "heading_error",
           "heading_excess", "input_bounds", "model_ode", "pack_parameters", "wrap_angle"]
DIST_EPS = 1e-6
HEADING_EPS = 1e-6  # rad²: smooths |e| and the limit's kink (a thousandth of a radian)


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


def model_ode(params: OtterParameters, waves: WaveField | None, current: OceanCurrent,
              components: int = 0, wind: Wind | None = None) -> ca.Function:
    """The paper's model (vessel ``rigid_body_ode``) with the wave as an input: (x, τ, t, wave) -> ẋ.

    ``waves`` None: the wave is the ``wave`` input (a ``ParametricRegularWaves``, 7 numbers; with ``components``
    K > 0 followed by the K-component bank, ``wave_bank``), so one Function predicts with any regular wave (and
    bank). A WaveField: that field is built in and only the input's last block is used: the ``disturbance``
    (a current added to ``current``, a surge force and a yaw moment added to τ; zeros: the model as before).
    ``wind``: a wind built into the model (simulation truth only, for a bound; None: still air, the paper's).
    """
    wave = ca.SX.sym("wave", wave_input_size(components))
    field = model_field(wave, components) if waves is None else waves
    x = ca.SX.sym("x", NX)
    tau = ca.SX.sym("tau", NU)
    t = ca.SX.sym("t")
    d = members("disturbance", wave[wave.numel() - len(DISTURBANCE_NAMES):])  # the last block of the input
    water = NedCurrent(current.speed_mps * math.cos(current.direction_rad) + d["current_north_mps"],
                       current.speed_mps * math.sin(current.direction_rad) + d["current_east_mps"])
    nu_dot = body_acceleration(params, field, water, x[0:6], x[6:12], tau[0] + d["surge_force_n"],
                               tau[1] + d["yaw_moment_nm"], t, wind=wind)
    xdot = ca.vertcat(kinematics(x[0:6], x[6:12]), nu_dot)
    return ca.Function("nmpc_ode", [x, tau, t, wave], [xdot], ["x", "tau", "t", "wave"], ["xdot"])


def discrete_model(params: OtterParameters, waves: WaveField | None, current: OceanCurrent,
                   cfg: NmpcConfig, wind: Wind | None = None) -> ca.Function:
    """One control period of the NMPC model: (x[12], u[2], t, wave) -> x after period_s, held input.

    ``waves`` as in ``model_ode`` (None: the wave is the run-time ``wave`` input, 7 numbers and the bank block
    of ``cfg.wave_components``). u is τ, or the propeller thrusts (``cfg.inputs``), τ = B·u.
    """
    ode = model_ode(params, waves, current, cfg.wave_components, wind)
    h = cfg.period_s / cfg.substeps
    x = ca.SX.sym("x", NX)
    u = ca.SX.sym("u", NU)
    t = ca.SX.sym("t")
    wave = ca.SX.sym("wave", wave_input_size(cfg.wave_components))
    xk = x
    u_model = u
    u = input_tau(u_model, model_matrix(cfg, params))
    for i in range(cfg.substeps):
        ti = t + i * h
        if cfg.integrator == "rk4":  # classical Runge–Kutta, as vessel.plant.rk4_step
            k1 = ode(xk, u, ti, wave)
            k2 = ode(xk + h / 2 * k1, u, ti + h / 2, wave)
            k3 = ode(xk + h / 2 * k2, u, ti + h / 2, wave)
            k4 = ode(xk + h * k3, u, ti + h, wave)
            xk = xk + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        else:
            xk = xk + h * ode(xk, u, ti, wave)
    return ca.Function("nmpc_step", [x, u_model, t, wave], [xk], ["x", "u", "t", "wave"], ["x_next"])


_BLOCKS = tuple(PARAMS.slice(name) for name in ("x0", "t", "waypoint", "u_prev", "weights", "wave", "roll_spread",
                                                "disturbance"))
NO_SPREAD = np.zeros(3)
NO_DISTURBANCE = np.zeros(len(DISTURBANCE_NAMES))


def pack_parameters(x0: np.ndarray, t: float, waypoint: np.ndarray, u_prev: np.ndarray,
                    weights: tuple[float, ...], wave: np.ndarray = CALM_PARAMETERS,
                    roll_spread: np.ndarray = NO_SPREAD, bank: np.ndarray | None = None,
                    disturbance: np.ndarray = NO_DISTURBANCE) -> np.ndarray:
    """The numeric parameter vector (``PARAMS`` layout); ``wave`` from ``wave_model.wave_parameters``; ``bank``
    (``wave_bank.bank_parameters``) appended as the last block of a layout with one (K > 0), None without.

    The per-step fast path of ``PARAMS.pack`` (slices computed once; numpy rejects wrong block sizes).
    """
    p = np.empty(NP if bank is None else NP + bank.size)
    for where, value in zip(_BLOCKS, (x0, t, waypoint, u_prev, weights, wave, roll_spread, disturbance), strict=True):
        p[where] = value
    if bank is not None:
        p[NP:] = bank
    return p


def expected_roll_residuals(x: ca.SX, roll_spread: ca.SX) -> ca.SX:
    """Lᵀy, y = (−sin ψ, cos ψ) the body y axis in NED: ‖Lᵀy‖² = R·E[φ²] of the unexplained sea."""
    y_n, y_e = -ca.sin(x[5]), ca.cos(x[5])
    return ca.vertcat(roll_spread[0] * y_n + roll_spread[1] * y_e, roll_spread[2] * y_e)


def min_speed(x: ca.SX, waypoint: ca.SX, cfg: NmpcConfig) -> ca.SX | float:
    """The soft minimum surge speed at predicted state ``x``, m/s: ``min_speed_mps``, fading linearly to 0 within
    ``min_speed_fade_m`` of the waypoint.

    Why it fades: the minimum speed keeps the boat from stopping in the waves to save roll, but within a turning
    circle of the waypoint it is what made the boat circle it at full yaw moment (truth runs, seeds 1 and 3 of
    ``scenarios/estimated.yaml``: 3.4 turns at 3 m before entering the 2 m acceptance circle, 156 s instead of
    96 s). Held at 0.5 m/s its tightest turn (≈ 3 m) is wider than the circle, so once beside the waypoint the
    bearing turns as fast as the hull can and the heading error stays near 90°; a boat that may slow down turns
    in on the spot, as a skipper would.
    """
    if cfg.min_speed_fade_m <= 0:
        return cfg.min_speed_mps
    return cfg.min_speed_mps * ca.fmin(1, distance(x, waypoint) / cfg.min_speed_fade_m)


def roll_fade(x: ca.SX, waypoint: ca.SX, cfg: NmpcConfig) -> ca.SX | float:
    """√ of the share of the roll terms at predicted state ``x``: d²/√(d⁴ + d₀⁴), d the distance to the waypoint and
    d₀ = ``roll_fade_m`` (1 when 0): about 1 beyond 2 d₀, 1/√2 at d₀ (its square, the share, is ½), 0 at the
    waypoint.

    Why: the last metres are seconds of roll in a run of minutes, and a plan that still dodges the beam sea there
    swings past the waypoint and hooks back (paced runs over MAVLink: a hook of 10-15 m at the end of most
    Balanced runs in the paper's sea); a skipper goes straight in. Smooth, so the Gauss-Newton residuals take it.
    """
    if cfg.roll_fade_m <= 0:
        return 1.0
    d2 = (waypoint[0] - x[0]) ** 2 + (waypoint[1] - x[1]) ** 2
    return d2 / ca.sqrt(d2 * d2 + cfg.roll_fade_m**4)


def heading_excess(x: ca.SX, waypoint: ca.SX, cfg: NmpcConfig) -> ca.SX:
    """How far (rad) the heading error's size exceeds ``heading_limit_deg`` at predicted state ``x``, smoothly
    (|e| as √(e² + ε), the kink of max(0, ·) as (z + √(z² + ε))/2): about 0 within the limit.

    Why: the cost's distance term is linear, so with a 4 s horizon a heading square to the bearing costs the
    distance nothing; in a beam sea the roll it saves then outweighs Q·e², and Balanced held into the waves for
    a minute while the waypoint stayed 83-91 m away (over MAVLink, the GUIDED path, a sea from the north-north-west:
    154.5 s to arrive against Direct's 60.2 s). A skipper tacks, but towards the mark: within the limit the paper's
    trade-off decides, beyond it the boat turns back towards the waypoint.
    """
    size = ca.sqrt(heading_error(x, waypoint) ** 2 + HEADING_EPS)
    excess = size - math.radians(cfg.heading_limit_deg)
    return 0.5 * (excess + ca.sqrt(excess**2 + HEADING_EPS))


def state_cost(x: ca.SX, waypoint: ca.SX, weights: ca.SX, cfg: NmpcConfig, roll_spread: ca.SX) -> ca.SX:
    """Q·e_ψ² + R·φ² + S·d + soft minimum-speed penalty + expected roll for one predicted state (the roll terms
    faded near the waypoint, ``roll_fade``)."""
    w = members("weights", weights)
    q, r, s = w["q"], w["r"], w["s"]
    e = heading_error(x, waypoint)
    shortfall = ca.fmax(0, min_speed(x, waypoint, cfg) - x[6])
    fade = roll_fade(x, waypoint, cfg)
    cost = (q * e**2 + r * (fade * x[3]) ** 2 + s * distance(x, waypoint) + cfg.min_speed_weight * shortfall**2
            + ca.sumsqr(fade * expected_roll_residuals(x, roll_spread)))
    if cfg.heading_limit_deg > 0:
        cost += cfg.heading_limit_weight * heading_excess(x, waypoint, cfg) ** 2
    return cost


def input_change_cost(u: ca.SX, u_before: ca.SX, weights: ca.SX, matrix: np.ndarray | None = None) -> ca.SX:
    """ΔUᵀ W ΔU with W = diag(W11, W22), ΔU the change of τ (B·Δu for propeller-thrust inputs)."""
    du = input_tau(u - u_before, matrix)
    w = members("weights", weights)
    return w["w_dtau_x"] * du[0] ** 2 + w["w_dtau_n"] * du[1] ** 2


def build_nlp(step: ca.Function, cfg: NmpcConfig, matrix: np.ndarray | None = None) -> tuple[dict, Layout]:
    """The multiple-shooting NLP {x, p, f, g}; g = [x_0 − x̂, F(x_k, u_k, t_k, wave) − x_{k+1} …] = 0.

    ``matrix``: B of propeller-thrust inputs (``inputs.model_matrix``), None when u is τ."""
    layout = Layout(cfg.horizon)
    w = ca.SX.sym("w", layout.n_w)
    blocks = parameter_layout(cfg.wave_components)
    p = ca.SX.sym("p", blocks.size)
    par = blocks.unpack(p)
    wave = blocks.wave_input(p)
    g = [w[layout.x_index(0)] - par.x0]
    f = 0
    u_before = par.u_prev
    for k in range(cfg.horizon):
        xk, uk = w[layout.x_index(k)], w[layout.u_index(k)]
        x_next = w[layout.x_index(k + 1)]
        g.append(step(xk, uk, par.t + k * cfg.period_s, wave) - x_next)
        f += (input_change_cost(uk, u_before, par.weights, matrix)
              + state_cost(x_next, par.waypoint, par.weights, cfg, par.roll_spread))
        u_before = uk
    return {"x": w, "p": p, "f": f, "g": ca.vertcat(*g)}, layout


def input_bounds(cfg: NmpcConfig, layout: Layout, space: InputSpace | None = None) -> tuple[np.ndarray, np.ndarray]:
    """lbw, ubw: inputs within their box (``space``; default the τ box, for τ inputs only), states free."""
    space = space or input_space(cfg, None)
    lbw = np.full(layout.n_w, -np.inf)
    ubw = np.full(layout.n_w, np.inf)
    for k in range(cfg.horizon):
        lbw[layout.u_index(k)] = space.low
        ubw[layout.u_index(k)] = space.high
    return lbw, ubw
