"""Fossen's 6-DOF Otter equations of motion, written once as CasADi expressions.

M·ν̇_r + C(ν_r)·ν_r + D·ν_r + N_nl(ν_r) + G·β = τ + τ_cf(ν_r) + g_0(β) + τ_wave, ν̇ = ν̇_r + d/dt ν_c,
η̇ = J(η)·ν, with β the attitude relative to the wave surface (the paper's restoring input).
With ``surface_heave`` (off by default: the paper's model) the heave entry of β is z + ζ(N, E, t), the
depth below the local surface (NED z down, ζ up), and the vertical motion of the surface is treated the
way Fossen treats a current: the water's velocity ν_w = Rᵀ·(0, 0, −∂ζ/∂t) (body axes) is taken out of the
relative velocity ν_r used by damping, cross-flow drag and added-mass Coriolis terms, and its rate
(Rᵀ·(0, 0, −∂²ζ/∂t²) − ω × ν_w) is added to ν̇. The second part is the long-wave Froude–Krylov and
added-mass force (the pressure of an accelerating water column): without it the hull would need a draft
error to be accelerated, which the heave–pitch coupling of G turns into a spurious pitch of the same size
as the wave slope. With both, a hull in a wave much longer than itself rides the surface (z ≈ −ζ).
Off, heave restoring acts on z alone as in the paper.
The same expressions become the simulator's numeric plant (``vessel.plant``) and the NMPC's
prediction model (``rigid_body_ode``), so the two can never drift apart.

State conventions: η = [north, east, down, φ, θ, ψ] (NED, m and rad), ν = [u, v, w, p, q, r]
(body, m/s and rad/s), n = [n1, n2] actual shaft speeds of the left (port) and right (starboard)
propellers in rad/s. Plant state x = [η, ν, n] (14); rigid-body state x = [η, ν] (12).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from vessel.allocation import saturate_shaft_speed, shaft_speeds_to_tau
from vessel.config import bounded
from vessel.params import OtterParameters
from vessel.sea.waves import CalmWater, WaveField, surface_relative_attitude
from vessel.sea.wind import Wind, wind_force

NX_PLANT = 14
NX_RIGID = 12
STATE_NAMES = ("north", "east", "down", "phi", "theta", "psi", "u", "v", "w", "p", "q", "r", "n1", "n2")
# The same states as every CSV names them, with their SI unit: NED position (m), Euler angles (rad), body
# velocities (m/s) and rates (rad/s), shaft speeds (rad/s).
STATE_COLUMNS = ("north_m", "east_m", "down_m", "roll_rad", "pitch_rad", "yaw_rad", "u_m_s", "v_m_s", "w_m_s",
                 "p_rad_s", "q_rad_s", "r_rad_s", "n1_rad_s", "n2_rad_s")


@dataclass(frozen=True)
class OceanCurrent:
    """A uniform horizontal current: speed and the NED direction it flows towards (0 = North)."""

    speed_mps: float = bounded(0.0, 0.0, 5.0, "m/s", "current speed V_c")
    direction_rad: float = bounded(0.0, -2 * np.pi, 2 * np.pi, "rad", "direction the current flows to")


@dataclass(frozen=True)
class NedCurrent:
    """A uniform current as its NED components (m/s; numbers or CasADi symbols): the form an estimate takes."""

    north_mps: Any = 0.0
    east_mps: Any = 0.0


def current_in_body(current: OceanCurrent | NedCurrent, psi: ca.SX) -> tuple[ca.SX, ca.SX]:
    """(u_c, v_c): the current's velocity in body axes at heading ψ (roll and pitch ignored, as Fossen's)."""
    if isinstance(current, NedCurrent):
        c, s = ca.cos(psi), ca.sin(psi)
        return c * current.north_mps + s * current.east_mps, -s * current.north_mps + c * current.east_mps
    return (current.speed_mps * ca.cos(current.direction_rad - psi),
            current.speed_mps * ca.sin(current.direction_rad - psi))


def skew(a: ca.SX) -> ca.SX:
    """S(a) with S(a) b = a × b, symbolic."""
    return ca.vertcat(ca.horzcat(0, -a[2], a[1]), ca.horzcat(a[2], 0, -a[0]), ca.horzcat(-a[1], a[0], 0))


def rotation_body_to_ned(phi: ca.SX, theta: ca.SX, psi: ca.SX) -> ca.SX:
    """R_zyx(φ, θ, ψ): body-fixed vectors to NED."""
    cphi, sphi, cth, sth, cpsi, spsi = ca.cos(phi), ca.sin(phi), ca.cos(theta), ca.sin(theta), ca.cos(
        psi), ca.sin(psi)
    return ca.vertcat(
        ca.horzcat(cpsi * cth, -spsi * cphi + cpsi * sth * sphi, spsi * sphi + cpsi * cphi * sth),
        ca.horzcat(spsi * cth, cpsi * cphi + sphi * sth * spsi, -cpsi * sphi + sth * spsi * cphi),
        ca.horzcat(-sth, cth * sphi, cth * cphi),
    )


def euler_rate_transform(phi: ca.SX, theta: ca.SX) -> ca.SX:
    """T_zyx(φ, θ): body angular velocity to Euler-angle rates (singular at θ = ±90°)."""
    cphi, sphi, cth, tth = ca.cos(phi), ca.sin(phi), ca.cos(theta), ca.tan(theta)
    return ca.vertcat(
        ca.horzcat(1, sphi * tth, cphi * tth),
        ca.horzcat(0, cphi, -sphi),
        ca.horzcat(0, sphi / cth, cphi / cth),
    )


def kinematics(eta: ca.SX, nu: ca.SX) -> ca.SX:
    """η̇ = J(η)·ν: NED position rates and Euler-angle rates."""
    R = rotation_body_to_ned(eta[3], eta[4], eta[5])
    T = euler_rate_transform(eta[3], eta[4])
    return ca.vertcat(R @ nu[0:3], T @ nu[3:6])


def _coriolis(params: OtterParameters, nu_r: ca.SX) -> ca.SX:
    """C(ν_r) = C_RB + C_A: rigid-body part in the CG form moved to CO, added-mass part with Munk terms."""
    mats = params.matrices()
    w = nu_r[3:6]
    Ig = ca.DM(mats.Ig)
    zeros = ca.SX.zeros(3, 3)
    C_cg = ca.vertcat(ca.horzcat(mats.m_total * skew(w), zeros), ca.horzcat(zeros, -skew(Ig @ w)))
    H = ca.DM(mats.H_rg)
    C_rb = H.T @ C_cg @ H
    ma = np.diag(mats.M_A)
    a = ma[0:3] * nu_r[0:3]
    b = ma[3:6] * nu_r[3:6]
    C_a = ca.vertcat(ca.horzcat(zeros, -skew(a)), ca.horzcat(-skew(a), -skew(b)))
    if not params.munk_moment:
        for i, j in ((5, 0), (5, 1), (0, 5), (1, 5)):
            C_a[i, j] = 0
    return C_rb + C_a


def _crossflow(params: OtterParameters, v_r: ca.SX, r: ca.SX) -> tuple[ca.SX, ca.SX]:
    """Strip-theory cross-flow drag (sway force N, yaw moment N·m) over the hull length."""
    mats = params.matrices()
    L, strips = params.length, params.crossflow_strips
    dx = L / strips
    coeff = 0.5 * params.rho_crossflow * mats.draft * params.crossflow_cd * dx
    y_cf, n_cf = 0, 0
    for i in range(strips + 1):
        x_i = -L / 2 + i * dx
        v_strip = v_r + x_i * r
        drag = -coeff * ca.fabs(v_strip) * v_strip
        y_cf += drag
        n_cf += x_i * drag
    return y_cf, n_cf


def _surface_heave_terms(waves: WaveField, eta: ca.SX, nu: ca.SX, t: ca.SX) -> tuple[ca.SX, ca.SX, ca.SX]:
    """For surface heave: (z + ζ at the boat in m, water velocity ν_w and its body-frame rate, 6-vectors).

    ∂ζ/∂t and ∂²ζ/∂t² are differentiated symbolically at the boat's position, so ``t`` must be a CasADi
    symbol (it is in every ODE builder).
    """
    zeta = waves.elevation(eta[0], eta[1], t)
    zeta_rate = ca.jacobian(zeta, t)
    zeta_accel = ca.jacobian(zeta_rate, t)
    R_t = rotation_body_to_ned(eta[3], eta[4], eta[5]).T
    water = R_t @ ca.vertcat(0, 0, -zeta_rate)
    water_rate = R_t @ ca.vertcat(0, 0, -zeta_accel) - ca.cross(nu[3:6], water)
    return eta[2] + zeta, ca.vertcat(water, 0, 0, 0), ca.vertcat(water_rate, 0, 0, 0)


def body_acceleration(params: OtterParameters, waves: WaveField, current: OceanCurrent | NedCurrent,
                      eta: ca.SX, nu: ca.SX, tau_x: ca.SX, tau_n: ca.SX, t: ca.SX,
                      surface_heave: bool = False, wind: Wind | None = None) -> ca.SX:
    """ν̇ (body frame) for generalised surge force τ_X (N) and yaw moment τ_N (N·m) at time t (s).

    ``surface_heave``: heave restoring on z + ζ at the boat (follows the sea) instead of z (the paper).
    ``wind``: its load on the topsides (``vessel.sea.wind``); None: still air, the paper's model.
    """
    mats = params.matrices()
    phi, theta, psi = eta[3], eta[4], eta[5]

    u_c, v_c = current_in_body(current, psi)
    nu_r = nu - ca.vertcat(u_c, v_c, 0, 0, 0, 0)
    nu_c_dot = ca.vertcat(nu[5] * v_c, -nu[5] * u_c, 0, 0, 0, 0)

    heave = eta[2]
    if surface_heave:  # off: the paper's model, expressions unchanged
        heave, nu_water, nu_water_dot = _surface_heave_terms(waves, eta, nu, t)
        nu_r = nu_r - nu_water
        nu_c_dot = nu_c_dot + nu_water_dot

    alpha_n, alpha_e = waves.slope_angles(eta[0], eta[1], t)
    beta_phi, beta_theta = surface_relative_attitude(waves, phi, theta, psi, alpha_n, alpha_e)
    beta = ca.vertcat(eta[0], eta[1], heave, beta_phi, beta_theta, psi)

    D = ca.DM(mats.D)
    damping = -(D @ nu_r)
    damping[5] -= params.yaw_damping_nonlinear_factor * mats.D[5, 5] * ca.fabs(nu_r[5]) * nu_r[5]
    y_cf, n_cf = _crossflow(params, nu_r[1], nu_r[5])

    tau = ca.vertcat(tau_x, y_cf, 0, 0, 0, tau_n + n_cf)
    if wind is not None:
        w_x, w_y, w_k, w_n = wind_force(params, wind, psi, nu[0], nu[1], t)
        tau += ca.vertcat(w_x, w_y, 0, w_k, 0, w_n)
    if params.payload_load_term:
        R_beta = rotation_body_to_ned(beta_phi, beta_theta, psi)
        f_payload = R_beta.T @ ca.DM([0, 0, params.payload_mass * params.g])
        tau += ca.vertcat(f_payload, ca.cross(ca.DM(mats.r_p), f_payload))
    f_n, f_e = waves.force_per_weight(eta[0], eta[1], t)
    weight = mats.m_total * params.g
    f_body = rotation_body_to_ned(phi, theta, psi).T @ ca.vertcat(weight * f_n, weight * f_e, 0)
    tau += ca.vertcat(f_body, 0, 0, 0)

    rhs = tau + damping - _coriolis(params, nu_r) @ nu_r - ca.DM(mats.G) @ beta
    return ca.DM(mats.M_inv) @ rhs + nu_c_dot


def plant_ode(params: OtterParameters, waves: WaveField | None = None,
              current: OceanCurrent | None = None, surface_heave: bool = False,
              wind: Wind | None = None) -> ca.Function:
    """The simulator's plant: (x[14], n_cmd[2] rad/s, t s) -> ẋ[14], with first-order shaft dynamics.

    ``surface_heave`` makes heave follow the sea (see the module docstring); off is the paper's model.
    """
    waves = waves or CalmWater()
    current = current or OceanCurrent()
    x = ca.SX.sym("x", NX_PLANT)
    n_cmd = ca.SX.sym("n_cmd", 2)
    t = ca.SX.sym("t")
    n = x[12:14]
    tau_x, tau_n = shaft_speeds_to_tau(params, n[0], n[1])
    nu_dot = body_acceleration(params, waves, current, x[0:6], x[6:12], tau_x, tau_n, t, surface_heave, wind)
    n_sat = saturate_shaft_speed(params, n)
    n_dot = (n_cmd - n_sat) / params.prop_time_constant
    xdot = ca.vertcat(kinematics(x[0:6], x[6:12]), nu_dot, n_dot)
    if surface_heave:
        xdot = ca.cse(xdot)  # merge the trig terms ∂ζ/∂t, ∂²ζ/∂t² repeat (≈ 20 % fewer VM instructions)
    return ca.Function("plant_ode", [x, n_cmd, t], [xdot], ["x", "n_cmd", "t"], ["xdot"])


def rigid_body_ode(params: OtterParameters, waves: WaveField | None = None,
                   current: OceanCurrent | None = None, surface_heave: bool = False,
                   wind: Wind | None = None) -> ca.Function:
    """The NMPC's model, as in the paper: (x[12], tau[2] = (τ_X N, τ_N N·m), t s) -> ẋ[12].

    ``surface_heave`` makes heave follow the sea (see the module docstring); off is the paper's model.
    """
    waves = waves or CalmWater()
    current = current or OceanCurrent()
    x = ca.SX.sym("x", NX_RIGID)
    tau = ca.SX.sym("tau", 2)
    t = ca.SX.sym("t")
    nu_dot = body_acceleration(params, waves, current, x[0:6], x[6:12], tau[0], tau[1], t, surface_heave, wind)
    xdot = ca.vertcat(kinematics(x[0:6], x[6:12]), nu_dot)
    if surface_heave:
        xdot = ca.cse(xdot)  # merge the trig terms ∂ζ/∂t, ∂²ζ/∂t² repeat
    return ca.Function("rigid_body_ode", [x, tau, t], [xdot], ["x", "tau", "t"], ["xdot"])
