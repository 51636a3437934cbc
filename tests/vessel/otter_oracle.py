"""Independent numpy test oracle for the Otter USV 6-DOF model (Fossen matrix form).

Derived only from ``/work/shared/reference/otter-model.md`` and the wave section of the
paper ("Vessel's Response to Waves"); it deliberately shares no code with ``vessel/``.
Everything is built from the PRIMARY parameters (masses, positions, gyration radii,
pontoon geometry, damping ratios, thrust coefficients); none of the derived numbers of the
reference are hard-coded, so the reference tables can be used to test this file.

Variants:
  * ``"published"`` — the upstream model as published, quirks included (payload load term
    g_0, inertia shifted twice).
  * ``"corrected"`` — g_0 removed and the inertia about CO built with a single parallel-axis
    shift (hull about its own CG + payload as a point mass); added mass and damping rules
    re-applied to the corrected inertia.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import numpy as np

# ---------------------------------------------------------------- primary parameters (reference §2)
G_ACC = 9.81  # m/s²
RHO = 1025.0  # kg/m³, hull / hydrostatics
RHO_CF = 1026.0  # kg/m³, cross-flow drag routine (quirk §11.5)
L_HULL = 2.0  # m
B_HULL = 1.08  # m, beam overall
M_HULL = 55.0  # kg
M_PAYLOAD = 25.0  # kg
R_PAYLOAD = np.array([0.05, 0.0, -0.35])  # m from CO
R_G_HULL = np.array([0.2, 0.0, -0.2])  # m from CO
R44 = 0.4 * B_HULL  # m, roll radius of gyration (hull)
R55 = 0.25 * L_HULL  # m
R66 = 0.25 * L_HULL  # m
T_SWAY = 1.0  # s
T_YAW = 1.0  # s
U_MAX = 6.0 * 0.5144  # m/s (6 kn)
B_PONT = 0.25  # m, beam of one pontoon
Y_PONT = 0.395  # m, centre line to pontoon centroid (also propeller lever arm)
C_W = 0.75  # pontoon waterplane coefficient
C_B = 0.4  # pontoon block coefficient
LCF = -0.2  # m, longitudinal centre of flotation
ZETA3, ZETA4, ZETA5 = 0.3, 0.2, 0.4  # relative damping heave / roll / pitch
T_N = 0.1  # s, propeller time constant
K_POS = 0.02216 / 2.0  # N/(rad/s)², forward thrust coefficient per propeller
K_NEG = 0.01289 / 2.0  # N/(rad/s)², reverse
BOLLARD_FWD_KGF = 24.4  # kgf total forward bollard pull
BOLLARD_REV_KGF = 13.6  # kgf total reverse bollard pull
N_MAX = float(np.sqrt(0.5 * BOLLARD_FWD_KGF * G_ACC / K_POS))  # rad/s
N_MIN = -float(np.sqrt(0.5 * BOLLARD_REV_KGF * G_ACC / K_NEG))  # rad/s
L1, L2 = -Y_PONT, Y_PONT  # m, y positions of left / right propeller
C_D_CROSSFLOW = 1.0042  # Hoerner 2-D cross-flow coefficient at B_pont/(2T) (reference value)
N_STRIPS = 21  # cross-flow stations (both ends included)
NONLIN_YAW_FACTOR = 10.0  # N_{r|r|} = -10·D66

M_TOT = M_HULL + M_PAYLOAD
R_G = (M_HULL * R_G_HULL + M_PAYLOAD * R_PAYLOAD) / M_TOT  # combined CG

VARIANTS = ("published", "corrected")


# ---------------------------------------------------------------- small matrix helpers
def skew(a: np.ndarray) -> np.ndarray:
    """Skew-symmetric S(a) with S(a)·b = a × b."""
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def transform_h(r: np.ndarray) -> np.ndarray:
    """System transformation H(r) = [[I, S(r)ᵀ], [0, I]] (Fossen)."""
    h = np.eye(6)
    h[0:3, 3:6] = skew(r).T
    return h


def parallel_axis(mass: float, r: np.ndarray) -> np.ndarray:
    """Parallel-axis (Steiner) term mass·(|r|² I − r rᵀ)."""
    r = np.asarray(r, dtype=float)
    return mass * (float(r @ r) * np.eye(3) - np.outer(r, r))


def rot_zyx(phi: float, theta: float, psi: float) -> np.ndarray:
    """Body-to-NED rotation matrix R_zyx(φ, θ, ψ)."""
    cf, sf = np.cos(phi), np.sin(phi)
    ct, st = np.cos(theta), np.sin(theta)
    cp, sp = np.cos(psi), np.sin(psi)
    return np.array(
        [
            [cp * ct, -sp * cf + cp * st * sf, sp * sf + cp * cf * st],
            [sp * ct, cp * cf + sf * st * sp, -cp * sf + st * sp * cf],
            [-st, ct * sf, ct * cf],
        ]
    )


def t_zyx(phi: float, theta: float) -> np.ndarray:
    """Angular-velocity transformation T_zyx(φ, θ) mapping (p, q, r) to Euler-angle rates."""
    cf, sf = np.cos(phi), np.sin(phi)
    ct, tt = np.cos(theta), np.tan(theta)
    return np.array([[1.0, sf * tt, cf * tt], [0.0, cf, -sf], [0.0, sf / ct, cf / ct]])


# ---------------------------------------------------------------- hydrostatics (reference §5)
def hydrostatics() -> dict[str, float]:
    """Waterplane-derived hydrostatic quantities (volume, draft, I_T, I_L, KB, BM, GM, stiffnesses)."""
    volume = M_TOT / RHO
    draft = volume / (2.0 * C_B * B_PONT * L_HULL)
    aw_pont = C_W * L_HULL * B_PONT
    shape = 6.0 * C_W**3 / ((1.0 + C_W) * (1.0 + 2.0 * C_W))
    i_t = 2.0 * (L_HULL * B_PONT**3 / 12.0) * shape + 2.0 * aw_pont * Y_PONT**2
    i_l = 0.8 * 2.0 * B_PONT * L_HULL**3 / 12.0
    kb = (2.5 * draft - volume / (2.0 * L_HULL * B_PONT)) / 3.0
    bm_t = i_t / volume
    bm_l = i_l / volume
    kg = draft - R_G[2]
    gm_t = kb + bm_t - kg
    gm_l = kb + bm_l - kg
    return {
        "volume": volume,
        "draft": draft,
        "Aw_pont": aw_pont,
        "I_T": i_t,
        "I_L": i_l,
        "KB": kb,
        "BM_T": bm_t,
        "BM_L": bm_l,
        "KG": kg,
        "GM_T": gm_t,
        "GM_L": gm_l,
        "G33": RHO * G_ACC * 2.0 * aw_pont,
        "G44": RHO * G_ACC * volume * gm_t,
        "G55": RHO * G_ACC * volume * gm_l,
    }


def restoring_matrix() -> np.ndarray:
    """G = Hᵀ(r_LCF)·diag(0, 0, G33, G44, G55, 0)·H(r_LCF) about CO."""
    hs = hydrostatics()
    g_cf = np.diag([0.0, 0.0, hs["G33"], hs["G44"], hs["G55"], 0.0])
    h = transform_h(np.array([LCF, 0.0, 0.0]))
    return h.T @ g_cf @ h


# ---------------------------------------------------------------- inertia (reference §3, quirk §11.3)
def inertia_about_cg(variant: str) -> np.ndarray:
    """The "Ig" matrix fed to M_RB = Hᵀ blockdiag(m_tot I, Ig) H for the given variant."""
    i_hull_cg = M_HULL * np.diag([R44**2, R55**2, R66**2])
    if variant == "published":
        # upstream: hull shifted with the COMBINED CG, payload about CO, then shifted again by H
        return i_hull_cg + parallel_axis(M_HULL, R_G) + parallel_axis(M_PAYLOAD, R_PAYLOAD)
    if variant == "corrected":
        i_co = i_hull_cg + parallel_axis(M_HULL, R_G_HULL) + parallel_axis(M_PAYLOAD, R_PAYLOAD)
        return i_co - parallel_axis(M_TOT, R_G)
    raise ValueError(f"unknown variant {variant!r}")


@dataclass(frozen=True)
class _Model:
    """Constant matrices and scalars of one model variant."""

    variant: str
    Ig: np.ndarray
    H: np.ndarray
    M_RB: np.ndarray
    M_A: np.ndarray
    M: np.ndarray
    D: np.ndarray
    G: np.ndarray
    n_rr: float  # nonlinear yaw damping coefficient (positive), moment = -n_rr·|r|·r
    payload_load: bool  # whether g_0 is applied


def damping_matrix(M: np.ndarray) -> np.ndarray:
    """Linear diagonal damping D from the mass-matrix diagonal and the design rules of reference §6."""
    hs = hydrostatics()
    w3 = np.sqrt(hs["G33"] / M[2, 2])
    w4 = np.sqrt(hs["G44"] / M[3, 3])
    w5 = np.sqrt(hs["G55"] / M[4, 4])
    x_u = -BOLLARD_FWD_KGF * G_ACC / U_MAX
    y_v = -M[1, 1] / T_SWAY
    z_w = -2.0 * ZETA3 * w3 * M[2, 2]
    k_p = -2.0 * ZETA4 * w4 * M[3, 3]
    m_q = -2.0 * ZETA5 * w5 * M[4, 4]
    n_r = -M[5, 5] / T_YAW
    return -np.diag([x_u, y_v, z_w, k_p, m_q, n_r])


@cache
def _model(variant: str) -> _Model:
    """Build (once) the constant matrices of a variant."""
    ig = inertia_about_cg(variant)
    h = transform_h(R_G)
    m_rb_cg = np.zeros((6, 6))
    m_rb_cg[0:3, 0:3] = M_TOT * np.eye(3)
    m_rb_cg[3:6, 3:6] = ig
    m_rb = h.T @ m_rb_cg @ h
    added = np.array(
        [-0.1 * M_HULL, -1.5 * M_HULL, -1.0 * M_HULL, -0.2 * ig[0, 0], -0.8 * ig[1, 1], -1.7 * ig[2, 2]]
    )  # X_u̇, Y_v̇, Z_ẇ, K_ṗ, M_q̇, N_ṙ
    m_a = -np.diag(added)
    m = m_rb + m_a
    d = damping_matrix(m)
    for arr in (ig, h, m_rb, m_a, m, d):
        arr.setflags(write=False)
    g = restoring_matrix()
    g.setflags(write=False)
    return _Model(
        variant=variant,
        Ig=ig,
        H=h,
        M_RB=m_rb,
        M_A=m_a,
        M=m,
        D=d,
        G=g,
        n_rr=NONLIN_YAW_FACTOR * d[5, 5],
        payload_load=(variant == "published"),
    )


def oracle_matrices(variant: str) -> dict[str, np.ndarray]:
    """Constant model matrices M_RB, M_A, M, D, G, Ig (copies) for "published" or "corrected"."""
    if variant not in VARIANTS:
        raise ValueError(f"unknown variant {variant!r}")
    mdl = _model(variant)
    return {k: np.array(getattr(mdl, k), dtype=float) for k in ("M_RB", "M_A", "M", "D", "G", "Ig")}


# ---------------------------------------------------------------- velocity-dependent terms
def coriolis_rb(variant: str, nu: np.ndarray) -> np.ndarray:
    """C_RB(ν) = Hᵀ blockdiag(m_tot S(ω), −S(Ig ω)) H (linear-velocity-independent form)."""
    mdl = _model(variant)
    w = np.asarray(nu[3:6], dtype=float)
    c_cg = np.zeros((6, 6))
    c_cg[0:3, 0:3] = M_TOT * skew(w)
    c_cg[3:6, 3:6] = -skew(mdl.Ig @ w)
    return mdl.H.T @ c_cg @ mdl.H


def coriolis_added(variant: str, nu_r: np.ndarray) -> np.ndarray:
    """C_A(ν_r) from the symmetrised added-mass matrix (Munk terms kept)."""
    ma = _model(variant).M_A
    ma = 0.5 * (ma + ma.T)
    nu1, nu2 = np.asarray(nu_r[0:3], dtype=float), np.asarray(nu_r[3:6], dtype=float)
    a = ma[0:3, 0:3] @ nu1 + ma[0:3, 3:6] @ nu2
    b = ma[3:6, 0:3] @ nu1 + ma[3:6, 3:6] @ nu2
    c = np.zeros((6, 6))
    c[0:3, 3:6] = -skew(a)
    c[3:6, 0:3] = -skew(a)
    c[3:6, 3:6] = -skew(b)
    return c


def crossflow_drag(v_r: float, r: float) -> np.ndarray:
    """Strip-theory cross-flow drag τ_cf (sway force and yaw moment only), 21 stations, ρ = 1026."""
    draft = hydrostatics()["draft"]
    dx = L_HULL / (N_STRIPS - 1)
    x = -L_HULL / 2.0 + dx * np.arange(N_STRIPS)
    u_cf = v_r + x * r
    mag = np.abs(u_cf) * u_cf
    coef = -0.5 * RHO_CF * draft * C_D_CROSSFLOW * dx
    tau = np.zeros(6)
    tau[1] = coef * float(np.sum(mag))
    tau[5] = coef * float(np.sum(x * mag))
    return tau


def propeller_thrust(n: float) -> float:
    """Thrust of one propeller from its (already clipped) shaft speed."""
    k = K_POS if n > 0.0 else K_NEG
    return k * n * abs(n)


def propulsion_force(n: np.ndarray) -> np.ndarray:
    """Generalised propeller force τ from actual shaft speeds (clipped to [n_min, n_max])."""
    n_c = np.clip(np.asarray(n, dtype=float), N_MIN, N_MAX)
    t1, t2 = propeller_thrust(float(n_c[0])), propeller_thrust(float(n_c[1]))
    return np.array([t1 + t2, 0.0, 0.0, 0.0, 0.0, -L1 * t1 - L2 * t2])


def payload_load(phi: float, theta: float, psi: float) -> np.ndarray:
    """Payload load term g_0 = [f; r_p × f] with f = Rᵀ(φ,θ,ψ)·[0, 0, m_p g]."""
    f = rot_zyx(phi, theta, psi).T @ np.array([0.0, 0.0, M_PAYLOAD * G_ACC])
    return np.concatenate([f, np.cross(R_PAYLOAD, f)])


# ---------------------------------------------------------------- waves
def wave_slope(waves: tuple[float, float, float, float], north: float, east: float, t: float) -> float:
    """Slope angle α = atan(∂ζ/∂s) of ζ = (H/2)·sin(ωt − k·s), s along the travel direction."""
    height, length, period, chi = waves
    k = 2.0 * np.pi / length
    omega = 2.0 * np.pi / period
    s = north * np.cos(chi) + east * np.sin(chi)
    return float(np.arctan(-0.5 * height * k * np.cos(omega * t - k * s)))


def wave_terms(
    waves: tuple[float, float, float, float] | None,
    eta: np.ndarray,
    t: float,
    paper_roll_sign: bool = True,
) -> tuple[float, float, np.ndarray]:
    """Surface-relative roll/pitch (β_φ, β_θ) and the wave force τ_wave (6) in body axes."""
    phi, theta, psi = float(eta[3]), float(eta[4]), float(eta[5])
    if waves is None:
        return phi, theta, np.zeros(6)
    chi = waves[3]
    alpha = wave_slope(waves, float(eta[0]), float(eta[1]), t)
    a_n, a_e = alpha * np.cos(chi), alpha * np.sin(chi)
    sigma = 1.0 if paper_roll_sign else -1.0
    beta_theta = theta - (a_n * np.cos(psi) + a_e * np.sin(psi))
    beta_phi = phi - sigma * (a_e * np.cos(psi) - a_n * np.sin(psi))
    f_ned = -0.5 * M_TOT * G_ACC * np.sin(2.0 * alpha) * np.array([np.cos(chi), np.sin(chi), 0.0])
    tau = np.zeros(6)
    tau[0:3] = rot_zyx(phi, theta, psi).T @ f_ned
    return float(beta_phi), float(beta_theta), tau


# ---------------------------------------------------------------- full ODE
def oracle_xdot(
    x: np.ndarray,
    n_cmd: np.ndarray,
    t: float = 0.0,
    *,
    variant: str = "published",
    current_speed: float = 0.0,
    current_dir: float = 0.0,
    waves: tuple[float, float, float, float] | None = None,
    paper_roll_sign: bool = True,
) -> np.ndarray:
    """Time derivative of x = [N, E, D, φ, θ, ψ, u, v, w, p, q, r, n1, n2] (14)."""
    if variant not in VARIANTS:
        raise ValueError(f"unknown variant {variant!r}")
    x = np.asarray(x, dtype=float).reshape(14)
    n_cmd = np.asarray(n_cmd, dtype=float).reshape(2)
    mdl = _model(variant)
    eta, nu, n = x[0:6], x[6:12], x[12:14]
    phi, theta, psi = eta[3], eta[4], eta[5]

    # current (2-D, rotated with ψ only)
    u_c = current_speed * np.cos(current_dir - psi)
    v_c = current_speed * np.sin(current_dir - psi)
    nu_c = np.array([u_c, v_c, 0.0, 0.0, 0.0, 0.0])
    nu_r = nu - nu_c
    dnu_c = np.array([nu[5] * v_c, -nu[5] * u_c, 0.0, 0.0, 0.0, 0.0])

    # waves: surface-relative attitude β and lateral force
    beta_phi, beta_theta, tau_wave = wave_terms(waves, eta, t, paper_roll_sign)
    beta = np.array([eta[0], eta[1], eta[2], beta_phi, beta_theta, psi])

    tau = propulsion_force(n)
    tau_cf = crossflow_drag(float(nu_r[1]), float(nu_r[5]))
    g0 = payload_load(beta_phi, beta_theta, psi) if mdl.payload_load else np.zeros(6)
    c = coriolis_rb(variant, nu_r) + coriolis_added(variant, nu_r)
    n_nl = np.zeros(6)
    n_nl[5] = mdl.n_rr * abs(nu_r[5]) * nu_r[5]

    rhs = tau + tau_cf + g0 + tau_wave - c @ nu_r - mdl.D @ nu_r - n_nl - mdl.G @ beta
    nu_r_dot = np.linalg.solve(mdl.M, rhs)
    nu_dot = nu_r_dot + dnu_c

    eta_dot = np.concatenate([rot_zyx(phi, theta, psi) @ nu[0:3], t_zyx(phi, theta) @ nu[3:6]])
    n_dot = (n_cmd - np.clip(n, N_MIN, N_MAX)) / T_N
    return np.concatenate([eta_dot, nu_dot, n_dot])
