"""Natural period and damping ratio from wave- or wake-excited motion: an autoregressive fit's poles.

The angle, on a uniform grid of about AR_STEP_S (averaged down from faster logs) with its slow part (a turn's
steady heel, drift) removed, is fitted by least squares with an AR(p) model over every gap-free stretch at once,
p = 2..MAX_ORDER chosen by BIC. Each complex pole pair z gives s = ln(z)/dt, ω = |s|, ζ = −Re(s)/|s|; the
hull's mode is the pair nearest the AR spectrum's peak in the band. The interval is the spread of the same fit
over independent blocks of the log. Damping from ambient motion assumes the excitation is broad (white about
the peak): a narrow sea or a turning rhythm near the hull's period makes it look less damped than it is.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mavbridge.identify.estimate import Estimate, spread_interval
from mavbridge.identify.series import Stretch, blocks, moving_average

AR_STEP_S = 0.1
MAX_ORDER = 12
BAND_HZ = (0.25, 2.5)  # where a small hull's roll or pitch lies
SLOW_S = 8.0  # what is slower than this is not the hull's oscillation
BLOCK_S = 60.0
MIN_S = 30.0  # less motion than this is not enough for a fit
MIN_R2 = 0.6  # a one-step prediction worse than this: the motion is mostly sensor noise, not the hull's


@dataclass(frozen=True)
class ArFit:
    """An AR(p) fit: coefficients a (x_k = Σ a_i x_{k−i} + e), innovation variance, step, and the chosen mode."""

    coeffs: np.ndarray
    sigma2: float
    dt: float
    omega_n: float
    zeta: float
    r2: float

    def spectrum(self, f_hz: np.ndarray) -> np.ndarray:
        """The model's one-sided power spectral density at ``f_hz`` (units² per Hz)."""
        k = np.arange(1, self.coeffs.size + 1)
        z = np.exp(-2j * math.pi * np.outer(f_hz, k) * self.dt)
        return 2 * self.sigma2 * self.dt / np.abs(1 - z @ self.coeffs) ** 2


def prepared(items: list[Stretch], column: int = 0) -> list[np.ndarray]:
    """Each stretch's column, averaged down to about AR_STEP_S and without its slow part."""
    out = []
    for s in items:
        y = s.y[:, column]
        step = max(1, round(AR_STEP_S / s.dt)) if s.dt > 0 else 1
        if step > 1:
            y = y[: y.size // step * step].reshape(-1, step).mean(axis=1)
        dt = s.dt * step
        if y.size * dt < 4 * SLOW_S / 4:
            continue
        out.append(y - moving_average(y, round(SLOW_S / dt)))
    return out


def _design(series: list[np.ndarray], p: int) -> tuple[np.ndarray, np.ndarray]:
    rows, targets = [], []
    for y in series:
        if y.size <= p + 1:
            continue
        rows.append(np.column_stack([y[p - i - 1: y.size - i - 1] for i in range(p)]))
        targets.append(y[p:])
    if not rows:
        return np.empty((0, p)), np.empty(0)
    return np.vstack(rows), np.concatenate(targets)


def ar_least_squares(series: list[np.ndarray], p: int) -> tuple[np.ndarray, float, int, float]:
    """(coefficients, innovation variance, rows, one-step R²) of AR(p) over the series."""
    X, y = _design(series, p)
    if y.size < 5 * p:
        return np.zeros(p), math.nan, 0, math.nan
    a, *_ = np.linalg.lstsq(X, y, rcond=None)
    resid = y - X @ a
    var = float(np.mean(resid**2))
    total = float(np.mean((y - y.mean()) ** 2))
    return a, var, int(y.size), 1 - var / total if total > 0 else math.nan


def modes(coeffs: np.ndarray, dt: float) -> list[tuple[float, float]]:
    """(ω rad/s, ζ) of the AR polynomial's complex pole pairs (one per pair)."""
    roots = np.roots(np.r_[1.0, -coeffs])
    out = []
    for z in roots:
        if z.imag <= 1e-9 or abs(z) <= 0:
            continue
        s = np.log(z) / dt
        omega = abs(s)
        out.append((float(omega), float(-s.real / omega)))
    return out


def fit_ar(series: list[np.ndarray], dt: float, order: int | None = None) -> ArFit | None:
    """The AR fit (order by BIC unless given) and its mode nearest the spectrum's peak in BAND_HZ."""
    best: tuple[float, np.ndarray, float, float] | None = None
    for p in ([order] if order else range(2, MAX_ORDER + 1)):
        a, var, n, r2 = ar_least_squares(series, p)
        if not n or not var > 0:
            continue
        bic = n * math.log(var) + p * math.log(n)
        if best is None or bic < best[0]:
            best = (bic, a, var, r2)
    if best is None:
        return None
    _, a, var, r2 = best
    fit = ArFit(a, var, dt, math.nan, math.nan, r2)
    f = np.linspace(*BAND_HZ, 400)
    peak = float(f[int(np.argmax(fit.spectrum(f)))])
    inside = [(w, z) for w, z in modes(a, dt) if BAND_HZ[0] <= w / (2 * math.pi) * math.sqrt(max(1 - z * z, 0))
              <= BAND_HZ[1] and 0 < z < 1]
    if not inside:
        return None
    omega, zeta = min(inside, key=lambda m: abs(m[0] * math.sqrt(1 - m[1] ** 2) / (2 * math.pi) - peak))
    return ArFit(a, var, dt, omega, zeta, r2)


def ambient_estimates(items: list[Stretch], what: str, column: int = 0) -> tuple[Estimate, Estimate, ArFit] | str:
    """(natural period s, damping ratio, the fit) of ``column`` of the stretches, or why there are none."""
    series = prepared(items, column)
    dt = next((s.dt * max(1, round(AR_STEP_S / s.dt)) for s in items if s.dt > 0), AR_STEP_S)
    seconds = sum(y.size for y in series) * dt
    if seconds < MIN_S:
        return f"{what}: {seconds:.0f} s of gap-free motion, {MIN_S:g} s needed for a fit"
    whole = fit_ar(series, dt)
    if whole is None:
        return f"{what}: no oscillation between {BAND_HZ[0]:g} and {BAND_HZ[1]:g} Hz in the motion"
    if not whole.r2 >= MIN_R2:
        return f"{what}: the motion is mostly noise (AR one-step R² {whole.r2:.2f}, {MIN_R2:g} needed)"
    block_s = max(min(BLOCK_S, seconds / 4), 15.0)
    parts = [fit_ar(prepared(b, column), dt, whole.coeffs.size) for b in blocks(items, block_s)]
    parts_ok = [p for p in parts if p is not None]
    period = 2 * math.pi / whole.omega_n
    p_low, p_high = spread_interval(period, [2 * math.pi / p.omega_n for p in parts_ok])
    z_low, z_high = spread_interval(whole.zeta, [p.zeta for p in parts_ok])
    source = f"{what} motion ({seconds:.0f} s, AR({whole.coeffs.size}) poles, {len(parts_ok)} blocks for the interval)"
    return (Estimate(period, p_low, p_high, "s", source, whole.r2),
            Estimate(whole.zeta, z_low, z_high, "", source, whole.r2), whole)
