"""Otter USV parameters (Fossen's published model) and the constant matrices derived from them.

Two named sets: ``published`` reproduces Fossen's Otter model with its known quirks, so results compare
with his toolbox and with the paper; ``corrected`` fixes the two quirks that are errors (payload weight
counted twice through the load term g_0, rigid-body inertia shifted to the origin twice). See
``vessel/README.md`` for the list of quirks. Body frame: x forward, y starboard, z down, origin CO
amidships on the centre line in the design waterline.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from vessel.config import ConfigError, bounded

PARAMETER_SETS = ("published", "corrected")


def skew(a: np.ndarray) -> np.ndarray:
    """S(a) with S(a) b = a × b."""
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def system_transform(r: np.ndarray) -> np.ndarray:
    """Fossen's H(r): moves a 6-DOF quantity from point r to the body origin, H = [[I, S(r)ᵀ], [0, I]]."""
    H = np.eye(6)
    H[0:3, 3:6] = skew(r).T
    return H


def parallel_axis(mass: float, r: np.ndarray) -> np.ndarray:
    """Inertia of a point mass at r about the origin: m (|r|² I − r rᵀ)."""
    return mass * (float(r @ r) * np.eye(3) - np.outer(r, r))


# Hoerner's 2-D cross-flow drag coefficient against B/(2T) is only needed at the Otter's one pontoon
# (B_pont/(2T) = 0.6406), where the published model interpolates C_D = 1.0042; kept as a parameter.


@dataclass(frozen=True)
class OtterParameters:
    """Primary parameters of the Otter model; every derived number comes from these (SI units)."""

    g: float = bounded(9.81, 9.7, 9.9, "m/s²", "gravity")
    rho: float = bounded(1025.0, 990.0, 1050.0, "kg/m³", "water density (hull, hydrostatics)")
    rho_crossflow: float = bounded(1026.0, 990.0, 1050.0, "kg/m³", "density used by cross-flow drag")
    length: float = bounded(2.0, 0.5, 10.0, "m", "hull length L")
    beam: float = bounded(1.08, 0.2, 5.0, "m", "beam overall B")
    hull_mass: float = bounded(55.0, 1.0, 1000.0, "kg", "hull mass m")
    payload_mass: float = bounded(25.0, 0.0, 1000.0, "kg", "payload mass m_p")
    payload_position: tuple[float, float, float] = bounded((0.05, 0.0, -0.35), -5.0, 5.0, "m",
                                                           "payload position from CO (body)")
    hull_cg: tuple[float, float, float] = bounded((0.2, 0.0, -0.2), -5.0, 5.0, "m",
                                                  "hull centre of gravity from CO (body)")
    gyration_roll: float = bounded(0.432, 0.01, 5.0, "m", "hull roll radius of gyration R44 (0.4 B)")
    gyration_pitch: float = bounded(0.5, 0.01, 5.0, "m", "hull pitch radius of gyration R55 (0.25 L)")
    gyration_yaw: float = bounded(0.5, 0.01, 5.0, "m", "hull yaw radius of gyration R66 (0.25 L)")
    sway_time_constant: float = bounded(1.0, 0.01, 100.0, "s", "T_sway, sizes sway damping")
    yaw_time_constant: float = bounded(1.0, 0.01, 100.0, "s", "T_yaw, sizes yaw damping")
    max_speed: float = bounded(6 * 0.5144, 0.1, 20.0, "m/s", "U_max, sizes surge damping")
    pontoon_beam: float = bounded(0.25, 0.01, 2.0, "m", "beam of one pontoon")
    pontoon_offset: float = bounded(0.395, 0.01, 3.0, "m", "centre line to pontoon centre (prop lever)")
    waterplane_coeff: float = bounded(0.75, 0.1, 1.0, "", "pontoon waterplane coefficient C_w")
    block_coeff: float = bounded(0.4, 0.1, 1.0, "", "pontoon block coefficient C_b")
    lcf: float = bounded(-0.2, -2.0, 2.0, "m", "longitudinal centre of flotation from CO")
    zeta_heave: float = bounded(0.3, 0.0, 2.0, "", "relative damping in heave")
    zeta_roll: float = bounded(0.2, 0.0, 2.0, "", "relative damping in roll")
    zeta_pitch: float = bounded(0.4, 0.0, 2.0, "", "relative damping in pitch")
    yaw_damping_nonlinear_factor: float = bounded(10.0, 0.0, 100.0, "", "N_r|r| = −factor·D66")
    crossflow_cd: float = bounded(1.0042, 0.0, 3.0, "", "2-D cross-flow drag coefficient (Hoerner)")
    crossflow_strips: int = bounded(20, 2, 200, "", "strips over L (stations = strips + 1, ends included)")
    prop_time_constant: float = bounded(0.1, 0.001, 10.0, "s", "T_n, first-order shaft dynamics")
    bollard_pull_forward_kgf: float = bounded(24.4, 0.1, 1000.0, "kgf", "total forward bollard pull")
    bollard_pull_reverse_kgf: float = bounded(13.6, 0.1, 1000.0, "kgf", "total reverse bollard pull")
    thrust_coeff_forward: float = bounded(0.01108, 1e-6, 10.0, "N/(rad/s)²", "k_pos per propeller")
    thrust_coeff_reverse: float = bounded(0.006445, 1e-6, 10.0, "N/(rad/s)²", "k_neg per propeller")
    added_mass_fractions: tuple[float, float, float, float, float, float] = bounded(
        (0.1, 1.5, 1.0, 0.2, 0.8, 1.7), 0.0, 10.0, "",
        "X_u̇/m, Y_v̇/m, Z_ẇ/m (hull mass), K_ṗ/Ig11, M_q̇/Ig22, N_ṙ/Ig33")
    propeller_scale: tuple[float, float] = bounded((1.0, 1.0), 0.1, 2.0, "",
                                                   "thrust of the port and starboard propeller against the law "
                                                   "above (1: as modelled; 0.85: a fouled or weaker motor)")
    shaft_speed_limit_rpm: float | None = bounded(None, 100.0, 5000.0, "rpm", "forward shaft-speed saturation of "
                                                  "the throttle map (null: where the bollard pull is reached, "
                                                  "992 rpm published); reverse scales with it")
    wind_area_front: float = bounded(0.15, 0.0, 50.0, "m²", "frontal projected area above water A_F")
    wind_area_side: float = bounded(0.35, 0.0, 100.0, "m²", "lateral projected area above water A_L")
    wind_coefficients: tuple[float, float, float] = bounded((0.5, 0.875, 0.15), -5.0, 5.0, "",
                                                            "C_X, C_Y, C_N of the wind load (vessel.sea.wind)")
    wind_pressure_height: float = bounded(0.3, 0.0, 5.0, "m", "height of the lateral wind load above CO (heel)")
    munk_moment: bool = True
    payload_load_term: bool = True
    inertia_double_shift: bool = True

    def __post_init__(self) -> None:
        if self.beam <= 2 * self.pontoon_offset - self.pontoon_beam:
            raise ConfigError(f"pontoon_offset: {self.pontoon_offset:g} m puts the pontoons outside the "
                              f"beam {self.beam:g} m; allowed (0, (beam + pontoon_beam)/2) m")

    def matrices(self) -> OtterMatrices:
        """The constant matrices and derived numbers of this parameter set (computed once, then kept on it: the
        cache's lookup hashed all the fields, 1.7 µs, twice in each RC command; issue 32)."""
        derived = self.__dict__.get("_derived")
        if derived is None:
            derived = derive_matrices(self)
            object.__setattr__(self, "_derived", derived)  # (not a field: equality, hash and replace ignore it)
        return derived

    def replace(self, **changes: object) -> OtterParameters:
        """A copy with some fields changed."""
        return dataclasses.replace(self, **changes)


@dataclass(frozen=True)
class OtterMatrices:
    """Derived constants: mass, damping, restoring matrices (6×6, body, about CO) and propeller limits."""

    m_total: float
    r_g: np.ndarray
    r_p: np.ndarray
    Ig: np.ndarray
    M_RB: np.ndarray
    M_A: np.ndarray
    M: np.ndarray
    M_inv: np.ndarray
    D: np.ndarray
    G: np.ndarray
    H_rg: np.ndarray
    draft: float
    volume: float
    gm_transverse: float
    gm_longitudinal: float
    n_max: float
    n_min: float
    k_pos: float
    k_neg: float


@lru_cache(maxsize=32)
def derive_matrices(p: OtterParameters) -> OtterMatrices:
    """Compute M_RB, M_A, D, G and the propeller limits exactly as the published model does."""
    m, mp = p.hull_mass, p.payload_mass
    m_total = m + mp
    r_hull = np.array(p.hull_cg, float)
    r_p = np.array(p.payload_position, float)
    r_g = (m * r_hull + mp * r_p) / m_total

    I_hull_cg = m * np.diag([p.gyration_roll**2, p.gyration_pitch**2, p.gyration_yaw**2])
    if p.inertia_double_shift:
        # Published: shifted with the combined CG and the hull mass, then shifted again by H(r_g) below.
        Ig = I_hull_cg + parallel_axis(m, r_g) + parallel_axis(mp, r_p)
    else:
        # One correct shift: the true inertia about CO, expressed about the combined CG for H(r_g).
        I_co = I_hull_cg + parallel_axis(m, r_hull) + parallel_axis(mp, r_p)
        Ig = I_co - parallel_axis(m_total, r_g)
    H_rg = system_transform(r_g)
    M_RB = H_rg.T @ np.block([[m_total * np.eye(3), np.zeros((3, 3))], [np.zeros((3, 3)), Ig]]) @ H_rg

    fx, fy, fz, fk, fm, fn = p.added_mass_fractions
    M_A = np.diag([fx * m, fy * m, fz * m, fk * Ig[0, 0], fm * Ig[1, 1], fn * Ig[2, 2]])
    M = M_RB + M_A

    # Hydrostatics of two pontoons.
    volume = m_total / p.rho
    draft = volume / (2 * p.block_coeff * p.pontoon_beam * p.length)
    cw, bp, L = p.waterplane_coeff, p.pontoon_beam, p.length
    area_pont = cw * L * bp
    I_T = (2 * (L * bp**3 / 12) * (6 * cw**3 / ((1 + cw) * (1 + 2 * cw)))
           + 2 * area_pont * p.pontoon_offset**2)
    I_L = 0.8 * 2 * bp * L**3 / 12
    KB = (2.5 * draft - volume / (2 * L * bp)) / 3
    KG = draft - r_g[2]
    gm_t = KB + I_T / volume - KG
    gm_l = KB + I_L / volume - KG
    rho_g = p.rho * p.g
    G33, G44, G55 = rho_g * 2 * area_pont, rho_g * volume * gm_t, rho_g * volume * gm_l
    H_cf = system_transform(np.array([p.lcf, 0.0, 0.0]))
    G = H_cf.T @ np.diag([0.0, 0.0, G33, G44, G55, 0.0]) @ H_cf

    # Linear damping sized from the diagonal of M and G.
    w3 = math.sqrt(G33 / M[2, 2])
    w4 = math.sqrt(G44 / M[3, 3])
    w5 = math.sqrt(G55 / M[4, 4])
    D = np.diag([
        p.bollard_pull_forward_kgf * p.g / p.max_speed,
        M[1, 1] / p.sway_time_constant,
        2 * p.zeta_heave * w3 * M[2, 2],
        2 * p.zeta_roll * w4 * M[3, 3],
        2 * p.zeta_pitch * w5 * M[4, 4],
        M[5, 5] / p.yaw_time_constant,
    ])

    k_pos, k_neg = p.thrust_coeff_forward, p.thrust_coeff_reverse
    n_max = math.sqrt(0.5 * p.bollard_pull_forward_kgf * p.g / k_pos)
    n_min = -math.sqrt(0.5 * p.bollard_pull_reverse_kgf * p.g / k_neg)
    if p.shaft_speed_limit_rpm is not None:  # a throttle map that saturates elsewhere: both ends scale alike
        scale = p.shaft_speed_limit_rpm * math.pi / 30.0 / n_max
        n_max, n_min = n_max * scale, n_min * scale
    return OtterMatrices(m_total=m_total, r_g=r_g, r_p=r_p, Ig=Ig, M_RB=M_RB, M_A=M_A, M=M,
                         M_inv=np.linalg.inv(M), D=D, G=G, H_rg=H_rg, draft=draft, volume=volume,
                         gm_transverse=gm_t, gm_longitudinal=gm_l, n_max=n_max, n_min=n_min,
                         k_pos=k_pos, k_neg=k_neg)


def otter_parameters(name: str = "published") -> OtterParameters:
    """A named parameter set: 'published' (Fossen's model, quirks included) or 'corrected'."""
    if name == "published":
        return OtterParameters()
    if name == "corrected":
        return OtterParameters(payload_load_term=False, inertia_double_shift=False)
    raise ConfigError(f"vessel parameter set: {name!r} is not one of {', '.join(PARAMETER_SETS)}")


def load_parameters(path: str | Path) -> OtterParameters:
    """Read a YAML parameter file: an optional ``base`` set name plus any fields to override."""
    from vessel.vessel_spec import load_vessel  # (the one reader of vessel files; it builds on this module)

    if not Path(path).is_file():
        raise ConfigError(f"{path}: cannot read file (not found)")
    return load_vessel(str(path), str(path)).params()
