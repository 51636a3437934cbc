"""Oracle tests against the reference tables, and the production model against the numpy oracle."""

from __future__ import annotations

import itertools
from collections.abc import Callable
from types import SimpleNamespace

import numpy as np
import pytest

from tests.vessel import otter_oracle as o

PAPER_WAVES = (1.75, 35.0, 6.0, -np.pi / 2)  # H_w, λ, T_w, travel direction (West)
OBLIQUE_WAVES = (1.2, 22.0, 4.5, 2.3)  # a non-paper direction, exercises the general NED mapping


def assert_digits(value: float, text: str) -> None:
    """Assert that value rounds to the decimal string text (tolerance: half a unit of its last digit)."""
    decimals = len(text.split(".")[1]) if "." in text else 0
    tol = 0.5 * 10.0**-decimals * (1.0 + 1e-9)
    assert abs(value - float(text)) <= tol, f"{value!r} does not round to {text}"


def state(**kw: float) -> np.ndarray:
    """14-state vector with the named entries set, the rest zero."""
    names = ["north", "east", "down", "phi", "theta", "psi", "u", "v", "w", "p", "q", "r", "n1", "n2"]
    x = np.zeros(14)
    for key, val in kw.items():
        x[names.index(key)] = val
    return x


# =========================================================== oracle vs. the reference's numeric tables
def test_combined_cg_and_main_particulars() -> None:
    """Combined CG, displaced volume and draft match reference §2."""
    np.testing.assert_allclose(o.R_G, [0.153125, 0.0, -0.246875], rtol=0, atol=1e-15)
    assert o.M_TOT == 80.0
    hs = o.hydrostatics()
    assert_digits(hs["volume"], "0.078049")
    assert_digits(hs["draft"], "0.19512")
    assert_digits(o.U_MAX, "3.0864")


def test_published_ig_table() -> None:
    """Published Ig (hull shifted with the combined CG, payload about CO) matches reference §3."""
    ig = o.oracle_matrices("published")["Ig"]
    expected = [["16.679", "0", "2.517"], ["0", "21.517", "0"], ["2.517", "0", "15.102"]]
    for i, j in itertools.product(range(3), range(3)):
        assert_digits(ig[i, j], expected[i][j])
    np.testing.assert_allclose(np.diag(o.M_HULL * np.diag([o.R44**2, o.R55**2, o.R66**2])),
                               [10.264, 13.75, 13.75], atol=5e-4)


def test_published_m_rb_table() -> None:
    """Published M_RB about CO matches the reference §3 table entry by entry."""
    m_rb = o.oracle_matrices("published")["M_RB"]
    expected = [
        ["80", "0", "0", "0", "-19.75", "0"],
        ["0", "80", "0", "19.75", "0", "12.25"],
        ["0", "0", "80", "0", "-12.25", "0"],
        ["0", "19.75", "0", "21.555", "0", "5.541"],
        ["-19.75", "0", "-12.25", "0", "28.268", "0"],
        ["0", "12.25", "0", "5.541", "0", "16.978"],
    ]
    for i, j in itertools.product(range(6), range(6)):
        assert_digits(m_rb[i, j], expected[i][j])
    np.testing.assert_allclose(m_rb, m_rb.T, atol=1e-12)


def test_published_added_mass_and_mass_matrix() -> None:
    """Added-mass derivatives, diag(M), off-diagonals and eigenvalue range of M (reference §3)."""
    mats = o.oracle_matrices("published")
    added = -np.diag(mats["M_A"])  # X_u̇ ... N_ṙ
    for val, text in zip(added, ["-5.5", "-82.5", "-55.0", "-3.3358", "-17.2134", "-25.6736"], strict=True):
        assert_digits(val, text)
    m = mats["M"]
    for val, text in zip(np.diag(m), ["85.5", "162.5", "135.0", "24.890", "45.482", "42.651"], strict=True):
        assert_digits(val, text)
    off = ~np.eye(6, dtype=bool)
    np.testing.assert_array_equal(m[off], mats["M_RB"][off])
    eig = np.linalg.eigvalsh(m)
    assert eig.min() > 0
    assert_digits(eig.min(), "21.4")
    assert_digits(eig.max(), "166.6")


@pytest.mark.parametrize(
    ("variant", "expected"),
    # published: the §3 table digits (§11.3 quotes them re-rounded from these as 21.56, 28.27, 16.98)
    [("published", ("21.555", "28.268", "16.978")), ("corrected", ("15.53", "21.28", "16.01"))],
)
def test_rigid_body_inertia_about_co(variant: str, expected: tuple[str, str, str]) -> None:
    """Rotational block of M_RB about CO: shifted twice (published) vs once (corrected), reference §11.3."""
    m_rb = o.oracle_matrices(variant)["M_RB"]
    for val, text in zip(np.diag(m_rb)[3:], expected, strict=True):
        assert_digits(val, text)


def test_corrected_inertia_construction() -> None:
    """Corrected M_RB rotational block = hull about own CG + Steiner with hull CG + payload point mass."""
    mats = o.oracle_matrices("corrected")
    i_co = (
        o.M_HULL * np.diag([o.R44**2, o.R55**2, o.R66**2])
        + o.M_HULL * (np.eye(3) * (o.R_G_HULL @ o.R_G_HULL) - np.outer(o.R_G_HULL, o.R_G_HULL))
        + o.M_PAYLOAD * (np.eye(3) * (o.R_PAYLOAD @ o.R_PAYLOAD) - np.outer(o.R_PAYLOAD, o.R_PAYLOAD))
    )
    np.testing.assert_allclose(mats["M_RB"][3:, 3:], i_co, rtol=1e-13, atol=1e-13)
    steiner = o.M_TOT * (np.eye(3) * (o.R_G @ o.R_G) - np.outer(o.R_G, o.R_G))
    np.testing.assert_allclose(mats["Ig"], i_co - steiner, rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(mats["M_RB"][:3, :3], 80.0 * np.eye(3))
    np.testing.assert_allclose(mats["M_RB"], mats["M_RB"].T, atol=1e-13)
    ig = mats["Ig"]
    np.testing.assert_allclose(
        -np.diag(mats["M_A"]), [-5.5, -82.5, -55.0, -0.2 * ig[0, 0], -0.8 * ig[1, 1], -1.7 * ig[2, 2]]
    )
    # rules re-applied to the corrected mass diagonal
    m, d, g = mats["M"], mats["D"], mats["G"]
    hs = o.hydrostatics()
    assert d[3, 3] == pytest.approx(2 * 0.2 * np.sqrt(hs["G44"] / m[3, 3]) * m[3, 3], rel=1e-12)
    assert d[4, 4] == pytest.approx(2 * 0.4 * np.sqrt(hs["G55"] / m[4, 4]) * m[4, 4], rel=1e-12)
    assert d[5, 5] == pytest.approx(m[5, 5], rel=1e-12)
    assert d[5, 5] < o.oracle_matrices("published")["D"][5, 5]
    np.testing.assert_array_equal(g, o.oracle_matrices("published")["G"])


def test_hydrostatics_table() -> None:
    """Waterplane moments, KB, BM, KG, GM and stiffnesses match reference §5."""
    hs = o.hydrostatics()
    expected = {
        "I_T": "0.12003", "I_L": "0.26667", "KB": "0.13659", "BM_T": "1.53791", "BM_L": "3.41667",
        "KG": "0.44200", "GM_T": "1.23250", "GM_L": "3.11126", "G33": "7541.44", "G44": "967.27",
        "G55": "2441.71", "Aw_pont": "0.375",
    }
    for key, text in expected.items():
        assert_digits(hs[key], text)
    transverse_own = hs["I_T"] - 2 * hs["Aw_pont"] * o.Y_PONT**2
    assert_digits(transverse_own, "0.0030")
    assert_digits(2 * hs["Aw_pont"] * o.Y_PONT**2, "0.1170")


def test_restoring_matrix_table() -> None:
    """G about CO: G33, G35 = G53 = −LCF·G33, G44, G55 + LCF²·G33, zeros elsewhere (reference §5)."""
    g = o.oracle_matrices("published")["G"]
    assert_digits(g[2, 2], "7541.44")
    assert_digits(g[2, 4], "1508.29")
    assert_digits(g[4, 2], "1508.29")
    assert_digits(g[3, 3], "967.27")
    assert_digits(g[4, 4], "2743.37")
    mask = np.ones((6, 6), dtype=bool)
    for i, j in [(2, 2), (2, 4), (4, 2), (3, 3), (4, 4)]:
        mask[i, j] = False
    assert np.all(g[mask] == 0.0)


@pytest.mark.parametrize("variant", o.VARIANTS)
def test_damping_table(variant: str) -> None:
    """Linear damping derivatives and nonlinear yaw damping (reference §6; published numbers)."""
    mats = o.oracle_matrices(variant)
    m, d = mats["M"], mats["D"]
    assert np.count_nonzero(d - np.diag(np.diag(d))) == 0
    hs = o.hydrostatics()
    if variant == "published":
        omegas = np.sqrt([hs["G33"] / m[2, 2], hs["G44"] / m[3, 3], hs["G55"] / m[4, 4]])
        for val, text in zip(omegas, ["7.4741", "6.2338", "7.3271"], strict=True):
            assert_digits(val, text)
        derivs = -np.diag(d)
        texts = ["-77.554", "-162.5", "-605.40", "-62.065", "-266.60", "-42.651"]
        for val, text in zip(derivs, texts, strict=True):
            assert_digits(val, text)
    # nonlinear yaw damping: moment −10·D66·|r|·r, visible in ṙ of the ODE at two yaw rates
    x1, x2 = state(r=0.2), state(r=0.4)
    kw = {"variant": variant}
    r1 = o.oracle_xdot(x1, [0, 0], **kw)[6:12]
    r2 = o.oracle_xdot(x2, [0, 0], **kw)[6:12]
    # N(r) = −(D66 + N_cf,lin)·r − (10·D66 + c_cf)·r² + Coriolis terms at zero linear velocity
    tau1, tau2 = m @ r1, m @ r2
    cf1, cf2 = o.crossflow_drag(0.0, 0.2)[5], o.crossflow_drag(0.0, 0.4)[5]
    n_quad = ((tau2[5] - cf2) - 2 * (tau1[5] - cf1)) / (0.4**2 - 2 * 0.2**2)
    if variant == "published":
        assert_digits(n_quad, "-426.51")
    assert n_quad == pytest.approx(-10.0 * d[5, 5], rel=1e-9)


def test_actuator_numbers() -> None:
    """Shaft-speed limits, bollard thrusts and the 70 % / 30 % operating points (reference §2, §7)."""
    assert_digits(o.K_POS, "0.01108")
    assert_digits(o.K_NEG, "0.006445")
    assert_digits(o.N_MAX, "103.931")
    assert_digits(o.N_MIN, "-101.737")
    assert_digits(o.N_MAX * 60 / (2 * np.pi), "992")
    assert_digits(o.propeller_thrust(o.N_MAX), "119.68")
    assert_digits(-o.propeller_thrust(o.N_MIN), "66.71")
    n70, n30 = 0.7 * o.N_MAX, 0.3 * o.N_MAX
    assert_digits(n70, "72.752")
    assert_digits(n70 * 60 / (2 * np.pi), "694.7")
    assert_digits(o.propeller_thrust(n70), "58.64")
    assert_digits(n30, "31.179")
    assert_digits(o.propeller_thrust(n30), "10.77")
    # saturation: beyond the limits thrust is that of the limit
    assert o.propulsion_force([500.0, -500.0])[0] == pytest.approx(119.682 - 66.708, abs=1e-3)
    tau = o.propulsion_force([80.0, 40.0])
    np.testing.assert_array_equal(tau[1:5], 0.0)
    assert tau[5] == pytest.approx(0.395 * (o.K_POS * 80.0**2 - o.K_POS * 40.0**2), rel=1e-12)


def test_actuator_dynamics_and_yaw_sign() -> None:
    """ṅ = (n_cmd − clip(n))/T_n, and more port thrust turns the bow to starboard (ṙ > 0)."""
    x = state(n1=120.0, n2=-150.0)
    xd = o.oracle_xdot(x, [50.0, 10.0], variant="corrected")
    np.testing.assert_allclose(xd[12:], [(50.0 - o.N_MAX) / 0.1, (10.0 - o.N_MIN) / 0.1], rtol=1e-14)
    xd = o.oracle_xdot(state(n1=90.0, n2=30.0), [90.0, 30.0], variant="corrected")
    assert xd[11] > 0.0
    assert xd[6] > 0.0
    np.testing.assert_array_equal(xd[12:], 0.0)


def test_crossflow_drag_coefficients() -> None:
    """Strip-sum cross-flow drag: Y_v|v| ≈ −211.1, N_r|r| ≈ −60.8, sign and quadratic scaling (§6)."""
    y_vv = o.crossflow_drag(1.0, 0.0)
    n_rr = o.crossflow_drag(0.0, 1.0)
    assert_digits(y_vv[1], "-211.1")
    assert_digits(n_rr[5], "-60.8")
    assert abs(y_vv[5]) < 1e-12 and abs(n_rr[1]) < 1e-12  # symmetric stations
    np.testing.assert_allclose(o.crossflow_drag(-2.0, 0.0)[1], -4.0 * y_vv[1], rtol=1e-13)
    assert np.count_nonzero(o.crossflow_drag(0.7, -0.3)[[0, 2, 3, 4]]) == 0


def test_payload_load_term() -> None:
    """g_0 at zero attitude: 245.25 N down and −12.26 N·m pitch (bow down); effective roll stiffness 881."""
    g0 = o.payload_load(0.0, 0.0, 1.3)
    np.testing.assert_allclose(g0[[0, 1, 3, 5]], 0.0, atol=1e-12)
    assert_digits(g0[2], "245.25")
    assert_digits(g0[4], "-12.26")
    # −G·η + g_0 in the roll row, linearised in φ: 967.27 → ≈ 881 N·m/rad
    eps = 1e-6
    k_roll = -(o.payload_load(eps, 0.0, 0.0)[3] - o.payload_load(-eps, 0.0, 0.0)[3]) / (2 * eps)
    k_eff = o.hydrostatics()["G44"] + k_roll
    assert_digits(k_roll, "-85.8")
    assert_digits(k_eff, "881")


def _straight_equilibrium(variant: str, n: float) -> tuple[np.ndarray, np.ndarray]:
    """Newton solve for the straight-line steady state (z, θ, u, w) at symmetric shaft speed n."""

    def full(y: np.ndarray) -> np.ndarray:
        return state(down=y[0], theta=y[1], u=y[2], w=y[3], n1=n, n2=n)

    def resid(y: np.ndarray) -> np.ndarray:
        xd = o.oracle_xdot(full(y), [n, n], variant=variant)
        return xd[[2, 6, 8, 10]]

    y = np.zeros(4)
    for _ in range(12):
        f0 = resid(y)
        jac = np.column_stack([(resid(y + 1e-7 * e) - f0) / 1e-7 for e in np.eye(4)])
        y = y - np.linalg.solve(jac, f0)
    assert np.max(np.abs(resid(y))) < 1e-10
    x0 = full(y)
    a = np.column_stack(
        [
            (o.oracle_xdot(x0 + 1e-6 * e, [n, n], variant=variant)
             - o.oracle_xdot(x0 - 1e-6 * e, [n, n], variant=variant))[:12] / 2e-6
            for e in np.eye(14)[:12]
        ]
    )
    return y, np.linalg.eigvals(a)


def test_published_rest_state_and_drift() -> None:
    """Props off, published: rest at z 0.0379 m, θ −0.0261 rad, forward drift u ≈ 0.083 m/s (§11.1–2)."""
    y, _ = _straight_equilibrium("published", 0.0)
    assert_digits(y[0], "0.0379")
    assert_digits(y[1], "-0.0261")
    assert_digits(y[2], "0.083")
    assert_digits(-o.M_PAYLOAD * o.G_ACC * np.sin(y[1]), "6.4")
    x0 = state(down=y[0], theta=y[1])
    np.testing.assert_allclose(o.oracle_xdot(state(), [0, 0], variant="corrected"), 0.0, atol=1e-14)
    assert abs(o.oracle_xdot(x0, [0, 0], variant="published")[6]) > 0.05  # drift force at rest


def test_coupled_linearisation_modes() -> None:
    """Coupled modes about the loaded rest state match the reference §10 table."""
    _, eig = _straight_equilibrium("published", 0.0)
    osc = sorted((ev for ev in eig if ev.imag > 1e-6), key=lambda ev: abs(ev))
    assert len(osc) == 3
    (hp2, roll, hp1) = osc
    for ev, wn, zeta, td in [(hp2, "5.885", "0.396", "1.163"), (roll, "6.424", "0.230", "1.005"),
                             (hp1, "9.866", "0.343", "0.678")]:
        assert_digits(abs(ev), wn)
        assert_digits(-ev.real / abs(ev), zeta)
        assert_digits(2 * np.pi / ev.imag, td)
    real = sorted(-ev.real for ev in eig if abs(ev.imag) < 1e-9 and abs(ev.real) > 1e-6)
    taus = sorted(1.0 / r for r in real)
    assert len(taus) == 3
    assert_digits(taus[0], "0.92")
    assert_digits(taus[1], "1.08")
    assert_digits(taus[2], "1.13")


@pytest.mark.parametrize(
    ("variant", "frac", "speed", "growth"),
    [("published", 0.6, None, "0.05"), ("published", 0.7, "1.608", "0.46"), ("published", 1.0, None, "2.06"),
     ("corrected", 0.7, "1.512", None)],
)
def test_straight_line_speed_and_instability(variant: str, frac: float, speed: str | None,
                                             growth: str | None) -> None:
    """Steady speeds and the sway–yaw divergence rate at symmetric thrust (reference §11.2, §11.4)."""
    y, eig = _straight_equilibrium(variant, frac * o.N_MAX)
    if speed is not None:
        assert_digits(y[2], speed)
    if growth is not None:
        assert_digits(max(eig.real), growth)
    assert max(eig.real) > 0.0  # directionally unstable above ≈ 58.5 % in both variants


def test_current_convention() -> None:
    """A hull drifting with the current feels no relative flow: ν̇ = 0 and η̇ = current vector in NED."""
    vc, beta_c, psi = 0.6, -0.5, 1.1
    u_c, v_c = vc * np.cos(beta_c - psi), vc * np.sin(beta_c - psi)
    x = state(psi=psi, u=u_c, v=v_c)
    xd = o.oracle_xdot(x, [0, 0], variant="corrected", current_speed=vc, current_dir=beta_c)
    np.testing.assert_allclose(xd[0:3], [vc * np.cos(beta_c), vc * np.sin(beta_c), 0.0], atol=1e-14)
    np.testing.assert_allclose(xd[6:12], 0.0, atol=1e-13)
    # turning: ν̇ gets d/dt(ν_c) = [r v_c, −r u_c, 0...] on top of the relative-velocity dynamics
    x_turn = state(psi=psi, u=u_c, v=v_c, r=0.3)
    calm = o.oracle_xdot(state(psi=psi, r=0.3), [0, 0], variant="corrected")
    with_c = o.oracle_xdot(x_turn, [0, 0], variant="corrected", current_speed=vc, current_dir=beta_c)
    np.testing.assert_allclose(with_c[6:12] - calm[6:12], [0.3 * v_c, -0.3 * u_c, 0, 0, 0, 0], atol=1e-12)


def test_waves_match_paper_formulas() -> None:
    """For χ = −π/2 the oracle's β and lateral force equal the paper's literal expressions."""
    rng = np.random.default_rng(7)
    h, lam, per, _ = PAPER_WAVES
    for _ in range(20):
        north, east, t = rng.uniform(-80, 80), rng.uniform(-80, 80), rng.uniform(0, 100)
        phi, theta, psi = rng.uniform(-0.5, 0.5, size=3) * [1, 1, 8]
        arg = 2 * np.pi * east / lam + 2 * np.pi * t / per
        alpha_p = np.arctan(h * np.pi / lam * np.cos(arg))
        eta = np.array([north, east, 0.0, phi, theta, psi])
        b_phi, b_theta, tau = o.wave_terms(PAPER_WAVES, eta, t, paper_roll_sign=True)
        assert b_phi == pytest.approx(phi - alpha_p * np.cos(psi), abs=1e-14)
        assert b_theta == pytest.approx(theta - alpha_p * np.sin(psi), abs=1e-14)
        f_ned = o.rot_zyx(phi, theta, psi) @ tau[0:3]
        np.testing.assert_allclose(f_ned, [0.0, -40.0 * 9.81 * np.sin(2 * alpha_p), 0.0], atol=1e-11)
        np.testing.assert_array_equal(tau[3:], 0.0)
        b_phi_geo, b_theta_geo, _ = o.wave_terms(PAPER_WAVES, eta, t, paper_roll_sign=False)
        assert b_phi_geo == pytest.approx(phi + alpha_p * np.cos(psi), abs=1e-14)
        assert b_theta_geo == b_theta
    assert_digits(np.degrees(np.arctan(np.pi * h / lam)), "8.9")


def test_wave_slope_is_elevation_gradient() -> None:
    """α is the arctangent of ∂ζ/∂s along the travel direction (numerical gradient of ζ), any χ."""
    h, lam, per, chi = OBLIQUE_WAVES

    def zeta(n: float, e: float, t: float) -> float:
        s = n * np.cos(chi) + e * np.sin(chi)
        return 0.5 * h * np.sin(2 * np.pi * t / per - 2 * np.pi / lam * s)

    n, e, t, ds = 3.0, -7.0, 2.2, 1e-6
    grad = (zeta(n + ds * np.cos(chi), e + ds * np.sin(chi), t)
            - zeta(n - ds * np.cos(chi), e - ds * np.sin(chi), t)) / (2 * ds)
    assert o.wave_slope(OBLIQUE_WAVES, n, e, t) == pytest.approx(np.arctan(grad), abs=1e-8)
    # heading along the travel direction: the slope is pure pitch, roll untouched
    eta = np.array([n, e, 0.0, 0.1, 0.05, chi])
    b_phi, b_theta, _ = o.wave_terms(OBLIQUE_WAVES, eta, t, paper_roll_sign=False)
    assert b_phi == pytest.approx(0.1, abs=1e-14)
    assert b_theta == pytest.approx(0.05 - np.arctan(grad), abs=1e-8)


def test_waves_drive_roll_in_oracle_ode() -> None:
    """Beam waves produce a roll moment −G44·(φ − α cos ψ) (corrected variant, otherwise at rest)."""
    t = 1.0
    x = state(east=3.0, psi=0.0)
    xd = o.oracle_xdot(x, [0, 0], t, variant="corrected", waves=PAPER_WAVES)
    alpha_p = np.arctan(1.75 * np.pi / 35.0 * np.cos(2 * np.pi * 3.0 / 35.0 + 2 * np.pi * t / 6.0))
    tau = np.zeros(6)
    tau[3] = o.hydrostatics()["G44"] * alpha_p
    tau[0:3] = [0.0, -40.0 * 9.81 * np.sin(2 * alpha_p), 0.0]
    m = o.oracle_matrices("corrected")["M"]
    np.testing.assert_allclose(xd[6:12], np.linalg.solve(m, tau), rtol=1e-12, atol=1e-12)


# =========================================================== production model vs. the oracle
@pytest.fixture(scope="module")
def production() -> SimpleNamespace:
    """The production model's public API (import errors surface as test errors, not skips)."""
    from vessel import CalmWater, OceanCurrent, RegularWaves, otter_parameters, plant_ode

    return SimpleNamespace(
        otter_parameters=otter_parameters,
        RegularWaves=RegularWaves,
        CalmWater=CalmWater,
        OceanCurrent=OceanCurrent,
        plant_ode=plant_ode,
    )


@pytest.mark.parametrize("variant", o.VARIANTS)
def test_production_matrices_match_oracle(production: SimpleNamespace, variant: str) -> None:
    """p.matrices() M_RB, M, D, G, Ig equal the oracle's (rtol = atol = 1e-9)."""
    mats = production.otter_parameters(variant).matrices()
    ref = o.oracle_matrices(variant)
    for key in ("M_RB", "M", "D", "G", "Ig"):
        got = np.asarray(getattr(mats, key), dtype=float)
        np.testing.assert_allclose(got, ref[key], rtol=1e-9, atol=1e-9, err_msg=f"{variant} {key}")


WAVE_CASES: list[tuple[str, tuple[float, float, float, float] | None, bool]] = [
    ("calm", None, True),
    ("paper+", PAPER_WAVES, True),
    ("paper-", PAPER_WAVES, False),
    ("oblique+", OBLIQUE_WAVES, True),
    ("oblique-", OBLIQUE_WAVES, False),
]
CASES = list(itertools.product(o.VARIANTS, (False, True), WAVE_CASES))
STATES_PER_CASE = 10  # 2 × 2 × 5 cases → 200 random states


def random_state(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, float]:
    """Random state, command and time: attitudes ±0.5 rad, realistic speeds, shaft speeds past saturation."""
    x = np.concatenate(
        [
            rng.uniform(-100, 100, 2),  # north, east
            rng.uniform(-0.3, 0.3, 1),  # down
            rng.uniform(-0.5, 0.5, 2),  # phi, theta
            rng.uniform(-3.5, 3.5, 1),  # psi (covers all headings and a bit beyond ±π)
            [rng.uniform(-1.0, 3.5), rng.uniform(-1.0, 1.0), rng.uniform(-0.5, 0.5)],  # u, v, w
            rng.uniform(-1.0, 1.0, 2),  # p, q
            rng.uniform(-0.7, 0.7, 1),  # r
            rng.uniform(-140, 140, 2),  # n1, n2 (limits are −101.7 / +103.9)
        ]
    )
    return x, rng.uniform(-140, 140, 2), float(rng.uniform(0, 200))


CASE_IDS = [f"{v}-{'cur' if c else 'nocur'}-{w[0]}" for v, c, w in CASES]


@pytest.mark.parametrize(("variant", "with_current", "wave_case"), CASES, ids=CASE_IDS)
def test_production_ode_matches_oracle(
    production: SimpleNamespace,
    variant: str,
    with_current: bool,
    wave_case: tuple[str, tuple[float, float, float, float] | None, bool],
) -> None:
    """plant_ode(p, waves, current)(x, n_cmd, t) equals oracle_xdot on random states (rtol = atol = 1e-9)."""
    name, waves, roll_sign = wave_case
    seed = CASES.index((variant, with_current, wave_case))
    rng = np.random.default_rng(1000 + seed)
    vc, beta_c = 0.0, 0.0
    if with_current:
        vc, beta_c = float(rng.uniform(0.2, 0.8)), float(rng.uniform(-np.pi, np.pi))
    if waves is None:
        wave_obj = production.CalmWater()
    else:
        h, lam, per, chi = waves
        wave_obj = production.RegularWaves(
            height_m=h, length_m=lam, period_s=per, travel_dir_rad=chi, paper_roll_sign=roll_sign
        )
    current = production.OceanCurrent(speed_mps=vc, direction_rad=beta_c)
    f: Callable = production.plant_ode(production.otter_parameters(variant), wave_obj, current)
    for k in range(STATES_PER_CASE):
        x, n_cmd, t = random_state(rng)
        got = np.array(f(x, n_cmd, t), dtype=float).ravel()
        want = o.oracle_xdot(
            x, n_cmd, t, variant=variant, current_speed=vc, current_dir=beta_c, waves=waves,
            paper_roll_sign=roll_sign,
        )
        assert got.shape == (14,)
        np.testing.assert_allclose(
            got, want, rtol=1e-9, atol=1e-9,
            err_msg=f"{variant} current={with_current} {name} state {k}: x={x!r} n_cmd={n_cmd!r} t={t!r}",
        )
