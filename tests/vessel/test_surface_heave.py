"""Surface-relative heave: with the option on, the hull rises and falls with a long wave; off, it does not.

A long regular wave (λ = 150 m ≫ the 2 m hull, period from deep-water dispersion) meets the boat at rest
at 45° off the bow, so roll and pitch are both excited. Heave is compared with the elevation at the
boat, roll and pitch with the slope (geometric sign), by least-squares phasors at the wave frequency.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from vessel import Plant, RegularWaves, otter_parameters

LENGTH_M = 150.0
PERIOD_S = math.sqrt(2 * math.pi * LENGTH_M / 9.81)  # deep water: ω² = g k
WAVES = RegularWaves(height_m=1.75, length_m=LENGTH_M, period_s=PERIOD_S, travel_dir_rad=-math.pi / 2,
                     paper_roll_sign=False)
HEADING = math.pi / 4  # waves travel West: 135° between the bow and the travel direction
DT, SETTLE_S, RECORD_S = 0.02, 20.0, 4 * PERIOD_S


def _phasor(t: np.ndarray, signal: np.ndarray, omega: float) -> complex:
    """Complex amplitude c of signal ≈ mean + Re(c·e^{iωt}) by least squares."""
    basis = np.column_stack([np.ones_like(t), np.cos(omega * t), -np.sin(omega * t)])
    coef, *_ = np.linalg.lstsq(basis, signal, rcond=None)
    return complex(coef[1], coef[2])


def _run(surface_heave: bool) -> dict[str, np.ndarray]:
    """Record heave, roll, pitch and the sea at the boat over whole wave periods after settling."""
    plant = Plant(otter_parameters(), WAVES, dt=DT, surface_heave=surface_heave)
    x0 = np.zeros(14)
    x0[5] = HEADING
    plant.reset(x0)
    plant.advance((0.0, 0.0), round(SETTLE_S / DT))
    rows = []
    for _ in range(round(RECORD_S / DT)):
        x = plant.step((0.0, 0.0))
        a_n, a_e = WAVES.slope_angles(x[0], x[1], plant.time)
        psi = x[5]
        rows.append((plant.time, x[2], x[3], x[4], WAVES.elevation(x[0], x[1], plant.time),
                     a_n * math.cos(psi) + a_e * math.sin(psi),  # pitch the surface imposes
                     WAVES.roll_sign * (a_e * math.cos(psi) - a_n * math.sin(psi))))  # roll it imposes
    data = np.array(rows, dtype=float)
    return dict(zip(("t", "z", "phi", "theta", "zeta", "theta_sea", "phi_sea"), data.T, strict=True))


@pytest.fixture(scope="module")
def following() -> dict[str, np.ndarray]:
    return _run(surface_heave=True)


def _ratio_and_phase_deg(rec: dict[str, np.ndarray], boat: np.ndarray, sea: np.ndarray) -> tuple[float, float]:
    omega = 2 * math.pi / PERIOD_S
    b, s = _phasor(rec["t"], boat, omega), _phasor(rec["t"], sea, omega)
    ratio = b / s
    return abs(ratio), math.degrees(math.atan2(ratio.imag, ratio.real))


def test_heave_follows_the_elevation(following: dict[str, np.ndarray]) -> None:
    ratio, phase = _ratio_and_phase_deg(following, -following["z"], following["zeta"])  # z down, ζ up
    print(f"heave/elevation: amplitude ratio {ratio:.4f}, phase {phase:+.2f} deg")
    assert abs(ratio - 1) < 0.10, f"heave/elevation amplitude ratio {ratio:.3f}"
    assert abs(phase) < 15, f"heave lags the elevation by {phase:.1f} deg"


@pytest.mark.parametrize(("boat", "sea"), [("phi", "phi_sea"), ("theta", "theta_sea")])
def test_roll_and_pitch_still_follow_the_slope(following: dict[str, np.ndarray], boat: str, sea: str) -> None:
    ratio, phase = _ratio_and_phase_deg(following, following[boat], following[sea])
    print(f"{boat}/{sea}: amplitude ratio {ratio:.4f}, phase {phase:+.2f} deg")
    assert abs(ratio - 1) < 0.10, f"{boat}/{sea} amplitude ratio {ratio:.3f}"
    assert abs(phase) < 15, f"{boat} off the slope by {phase:.1f} deg"


def test_without_the_option_heave_ignores_the_sea() -> None:
    rec = _run(surface_heave=False)
    ratio, _ = _ratio_and_phase_deg(rec, -rec["z"], rec["zeta"])
    print(f"paper heave/elevation: amplitude ratio {ratio:.4f}")
    assert ratio < 0.05, f"paper model: heave/elevation ratio {ratio:.3f} (expected almost none)"
