"""Natural period and damping ratio from free decays: large motion, then no excitation, fitted by least squares.

A decay is found as a run of alternating extrema of the angle whose half peak-to-peak heights shrink and whose
spacing stays about half a period, starting large (above ``min_amplitude`` and well above the record's own
motion) while nothing excites it (``quiet``: no turning, a steady command). Each decay is fitted with an
exponentially decaying cosine about an offset, x(t) = A e^(−ζω t) cos(ω√(1−ζ²) t + φ) + c (the smallest
damping uncertainty of the usual methods; the log decrement is only the starting guess). The reported period is
the natural (undamped) one, 2π/ω; a fit below MIN_R2 is not a decay.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mavbridge.identify.estimate import Estimate, covariance_interval, r_squared, weighted_mean
from mavbridge.identify.lsq import least_squares, turning_points

MIN_R2 = 0.9
MIN_EXTREMA = 4  # one and a half cycles: a lightly damped small hull rarely shows more above the noise
SPACING_TOLERANCE = 0.35  # each half period within ±35 % of the first one


@dataclass(frozen=True)
class DecayFit:
    """One fitted decay: over [start_s, end_s] of the log, with its parameters and their standard deviations."""

    start_s: float
    end_s: float
    amplitude: float
    zeta: float
    omega_n: float
    phase: float
    offset: float
    r2: float
    zeta_sd: float
    omega_sd: float

    @property
    def period_s(self) -> float:
        """Natural period 2π/ω (s)."""
        return 2 * math.pi / self.omega_n

    def curve(self, t: np.ndarray) -> np.ndarray:
        """The fitted decay at log times ``t``."""
        return decay_curve(np.array([self.amplitude, self.zeta, self.omega_n, self.phase, self.offset]),
                           np.asarray(t, float) - self.start_s)


def decay_curve(x: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """A e^(−ζω τ) cos(ω_d τ + φ) + c for x = (A, ζ, ω, φ, c)."""
    amp, zeta, omega, phase, offset = x
    omega_d = omega * math.sqrt(max(1.0 - zeta**2, 1e-9))
    return amp * np.exp(-zeta * omega * tau) * np.cos(omega_d * tau + phase) + offset


def extrema(y: np.ndarray, prominence: float) -> np.ndarray:
    """Indices of alternating maxima and minima of ``y`` standing out by ``prominence``."""
    return turning_points(np.asarray(y, float), prominence)


def _run_length(t: np.ndarray, y: np.ndarray, ext: np.ndarray, i: int, floor: float) -> int:
    """How many extrema from ``ext[i]`` on keep shrinking at a steady spacing."""
    first = t[ext[i + 1]] - t[ext[i]]
    n = 1
    while i + n < ext.size:
        j = i + n
        spacing = t[ext[j]] - t[ext[j - 1]]
        height = abs(y[ext[j]] - y[ext[j - 1]]) / 2
        if abs(spacing - first) > SPACING_TOLERANCE * first or height < floor:
            break
        if n >= 2 and height > 1.05 * abs(y[ext[j - 1]] - y[ext[j - 2]]) / 2:
            break
        n += 1
    return n


def find_decays(t: np.ndarray, y: np.ndarray, quiet: np.ndarray | None, min_amplitude: float,
                noise: float, floor_sigmas: float = 3.0, min_extrema: int = MIN_EXTREMA) -> list[tuple[int, int]]:
    """(first, last) sample indices of the free decays in a uniform series ``y`` (rad): runs of at least
    ``min_extrema`` shrinking extrema from a first half-height of ``min_amplitude`` or more, quiet throughout, each
    run going on while its half-heights stay above ``floor_sigmas`` times the ``noise``."""
    ext = extrema(y, prominence=max(3 * noise, 0.1 * min_amplitude))
    found: list[tuple[int, int]] = []
    i = 0
    while i < ext.size - min_extrema + 1:
        height = abs(y[ext[i + 1]] - y[ext[i]]) / 2
        if height < min_amplitude:
            i += 1
            continue
        n = _run_length(t, y, ext, i, floor=max(floor_sigmas * noise, 0.05 * height))
        while n >= min_extrema and not _quiet(quiet, *_span(ext, i, n, y.size)):
            n -= 1  # a run that outlasts the quiet is cut where the quiet ends
        if n >= min_extrema:
            found.append(_span(ext, i, n, y.size))
            i += n
        else:
            i += 1
    return found


def _span(ext: np.ndarray, i: int, n: int, size: int) -> tuple[int, int]:
    """(first, last) sample of the run of ``n`` extrema from ``ext[i]``, to half a period past its last extremum."""
    first, last = int(ext[i]), int(ext[i + n - 1])
    return first, min(size - 1, last + (last - int(ext[i + n - 2])))


def _quiet(quiet: np.ndarray | None, first: int, end: int) -> bool:
    return quiet is None or bool(np.all(quiet[first:end + 1]))


def _initial(tau: np.ndarray, y: np.ndarray) -> np.ndarray:
    """A starting guess from the decay's extrema: half-period spacing and log decrement."""
    offset = float(np.median(y[-max(3, y.size // 5):]))
    ext = extrema(y - offset, prominence=0.05 * float(np.ptp(y)))
    if ext.size >= 3:
        half = float(np.mean(np.diff(tau[ext])))
        heights = np.abs(y[ext] - offset)
        ratios = heights[:-1] / np.maximum(heights[1:], 1e-12)
        delta = 2 * float(np.mean(np.log(np.clip(ratios, 1.0001, 100))))
    else:
        half, delta = max(float(tau[-1]) / 3, 1e-3), 1.0
    zeta = delta / math.sqrt(4 * math.pi**2 + delta**2)
    omega = math.pi / half / math.sqrt(max(1 - zeta**2, 1e-6))
    return np.array([y[0] - offset, min(max(zeta, 0.01), 0.9), omega, 0.0, offset])


def fit_decay(t: np.ndarray, y: np.ndarray) -> DecayFit | None:
    """The decaying cosine fitted to one decay (times ``t`` s, angle ``y``); None when it does not fit (R² <
    MIN_R2), the fit fails, or its damping is within two standard deviations of zero (it does not decay)."""
    t, y = np.asarray(t, float), np.asarray(y, float)
    if t.size < 8:
        return None
    tau = t - t[0]
    x0 = _initial(tau, y)
    span = float(np.ptp(y)) or 1.0
    lower = [-4 * span, 0.0, 0.3 * x0[2], -math.pi, float(np.min(y)) - span]
    upper = [4 * span, 0.95, 3.0 * x0[2], math.pi, float(np.max(y)) + span]
    try:
        fit = least_squares(lambda x: decay_curve(x, tau) - y, x0, np.array(lower), np.array(upper))
    except np.linalg.LinAlgError:
        return None
    r2 = r_squared(y, decay_curve(fit.x, tau))
    if not math.isfinite(r2) or r2 < MIN_R2:
        return None
    dof = max(t.size - 5, 1)
    s2 = float(np.sum(fit.fun**2)) / dof
    try:
        cov = np.linalg.pinv(fit.jac.T @ fit.jac) * s2
    except np.linalg.LinAlgError:
        return None
    sd = np.sqrt(np.clip(np.diag(cov), 0, None))
    amp, zeta, omega, phase, offset = (float(v) for v in fit.x)
    if zeta - 2 * float(sd[1]) <= 0:
        return None  # a damping that cannot be told from zero: a sustained oscillation, not a free decay
    return DecayFit(float(t[0]), float(t[-1]), amp, zeta, omega, phase, offset, r2, float(sd[1]), float(sd[2]))


def decay_estimates(fits: list[DecayFit], what: str) -> tuple[Estimate, Estimate] | None:
    """(natural period s, damping ratio) from the decays' fits, weighted by their uncertainty."""
    if not fits:
        return None
    period_sd = [2 * math.pi * f.omega_sd / f.omega_n**2 for f in fits]
    period, p_sd = weighted_mean([f.period_s for f in fits], period_sd)
    zeta, z_sd = weighted_mean([f.zeta for f in fits], [f.zeta_sd for f in fits])
    r2 = float(np.mean([f.r2 for f in fits]))
    source = f"{what} free decay{'s' if len(fits) > 1 else ''} ({len(fits)}, decaying-cosine fit)"
    return (Estimate(period, *covariance_interval(period, p_sd), "s", source, r2),
            Estimate(zeta, *covariance_interval(zeta, z_sd), "", source, r2))
