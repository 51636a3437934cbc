"""One regular wave fitted to a window of the boat's motion in the earth frame: the fit behind ``WindowEstimator``.

The model (``window_model``) is linear in the wave's (α, β) and in each channel's nuisance terms (an offset and a
second harmonic, ``_stack``) for fixed (ω, k, χ); all of them are found together by damped Gauss–Newton on the
residuals, each channel divided by its noise (its own residual RMS, floored). ``initial_guess`` starts it from the
window alone: the slope's dominant encounter frequency (an FFT of the slope along its principal axis), the channels'
phasors at it, and the pitch–roll-buoy algebra of ``solve`` (k = |slope|/|heave|, the direction from their
quadrature). Standard errors come from the Gauss–Newton normal matrix, widened because neighbouring samples are
correlated. A fit runs in stages (``refine_stages``, a generator) so the estimator can spread it over several
control steps. Pure numpy; no state.
"""

from __future__ import annotations

import math
from collections.abc import Generator
from dataclasses import dataclass, replace
from typing import TypeVar

import numpy as np

from mavbridge.waves.solve import solve_with_heave
from mavbridge.waves.window_model import (
    CHANNELS,
    NUISANCE,
    HullResponse,
    WaveParams,
    Window,
    channel_models,
    phase_geometry,
)

T = TypeVar("T")
Stages = Generator[None, None, T]  # a computation in stages: next() does one, StopIteration.value is the result
NOISE_FLOOR = {"along": 0.003, "across": 0.003, "accel": 0.03, "down": 0.15}  # rad, rad, m/s², m
MAX_CONDITION = 1e12  # of the normal matrix with unit diagonal: beyond it a parameter is undetermined
CORRELATION_S = 0.5  # residuals closer than this are not independent: standard errors widened by √(rate·this)


@dataclass(frozen=True)
class Fit:
    """A converged fit: the wave, its standard errors, how much of each channel it explains, the residual slope."""

    wave: WaveParams
    sigma: np.ndarray  # standard errors of (ω, k, χ, α, β)
    covariance: np.ndarray  # of (ω, k, χ, α, β), 5×5
    explained: dict[str, float]  # per channel with data: 1 − residual power / signal power
    slope_explained: float  # the same for pitch and roll together (their powers summed)
    residual_slope_cov: np.ndarray  # NED covariance (2×2, rad²) of the slope the wave leaves unexplained
    samples: int
    span_s: float
    iterations: int
    noise: dict[str, float]  # each channel's residual RMS (floored): the weights of a warm start
    @property
    def rel_sigma_omega(self) -> float:
        return float(self.sigma[0]) / max(self.wave.omega, 1e-9)

    @property
    def rel_sigma_k(self) -> float:
        return float(self.sigma[1]) / max(self.wave.k, 1e-9)

    @property
    def rel_sigma_amplitude(self) -> float:
        """σ(a)/a: the amplitude's own standard error (its phase's is ``sigma_phase``)."""
        a = max(self.wave.amplitude, 1e-9)
        g = np.array([0, 0, 0, self.wave.alpha / a, self.wave.beta / a])
        return math.sqrt(max(float(g @ self.covariance @ g), 0.0)) / a

    @property
    def sigma_phase(self) -> float:
        """Standard error (rad) of the wave's phase at the boat now."""
        a2 = max(self.wave.amplitude ** 2, 1e-18)
        h = np.array([0, 0, 0, -self.wave.beta / a2, self.wave.alpha / a2])
        return math.sqrt(max(float(h @ self.covariance @ h), 0.0))


def _has(values: np.ndarray) -> np.ndarray:
    return np.isfinite(values)


def dominant_encounter_frequency(w: Window, omega_min: float, omega_max: float) -> float | None:
    """ω_e (rad/s) of the slope along its principal NED axis: the peak of a Hann-windowed, zero-padded FFT of the
    slope resampled at 10 Hz, refined by a parabola through the peak's log magnitudes; None without a peak."""
    s_n = w.along * np.cos(w.psi) - w.across * np.sin(w.psi)
    s_e = w.along * np.sin(w.psi) + w.across * np.cos(w.psi)
    s_n, s_e = s_n - s_n.mean(), s_e - s_e.mean()
    axis = 0.5 * math.atan2(2 * float(np.dot(s_n, s_e)), float(np.dot(s_n, s_n) - np.dot(s_e, s_e)))
    y = s_n * math.cos(axis) + s_e * math.sin(axis)
    grid = np.arange(w.t[0], w.t[-1], 0.1)
    if grid.size < 16:
        return None
    series = np.interp(grid, w.t, y) * np.hanning(grid.size)
    n_fft = 1024  # 102 s at 10 Hz: bins of 0.06 rad/s, the parabola finds the peak within a few thousandths
    spectrum = np.abs(np.fft.rfft(series, n_fft))
    omegas = 2 * math.pi * np.fft.rfftfreq(n_fft, 0.1)
    band = np.flatnonzero((omegas >= omega_min) & (omegas <= omega_max))
    if band.size < 3:
        return None
    i = int(band[np.argmax(spectrum[band])])
    if i <= 0 or i >= spectrum.size - 1 or spectrum[i] <= 0:
        return None
    lo, mid, hi = (math.log(max(float(v), 1e-300)) for v in spectrum[i - 1:i + 2])
    curvature = lo - 2 * mid + hi
    shift = 0.5 * (lo - hi) / curvature if curvature < 0 else 0.0
    return float(omegas[i] + max(-0.5, min(0.5, shift)) * (omegas[1] - omegas[0]))


def _phasor(t: np.ndarray, values: np.ndarray, omega: float) -> complex | None:
    """X of values ≈ Re(X e^{iωt}) + offset by least squares (None when the channel is empty or too short)."""
    ok = _has(values)
    if np.count_nonzero(ok) < 8:
        return None
    tt, x = t[ok], values[ok]
    design = np.column_stack([np.cos(omega * tt), np.sin(omega * tt), np.ones_like(tt)])
    (a, b, _), *_ = np.linalg.lstsq(design, x, rcond=None)
    return complex(a, -b)


def initial_guess(w: Window, omega_min: float, omega_max: float, omega_e: float | None = None) -> WaveParams | None:
    """A first wave from the window alone (encounter-frame phasors at ``omega_e``, by default the slope's
    ``dominant_encounter_frequency``, then ``solve_with_heave``); None when the window shows no dominant frequency
    or no heave (IMU or GPS) to size k with."""
    if omega_e is None:
        omega_e = dominant_encounter_frequency(w, omega_min, omega_max)
    if omega_e is None:
        return None
    s_n = w.along * np.cos(w.psi) - w.across * np.sin(w.psi)
    s_e = w.along * np.sin(w.psi) + w.across * np.cos(w.psi)
    x_n, x_e = _phasor(w.t, s_n, omega_e), _phasor(w.t, s_e, omega_e)
    accel = _phasor(w.t, w.accel, omega_e)
    elevation = accel / omega_e**2 if accel is not None else None
    if elevation is None:
        down = _phasor(w.t, w.down, omega_e)
        elevation = -down if down is not None else None
    if x_n is None or x_e is None or elevation is None:
        return None
    sol = solve_with_heave(x_n, x_e, elevation, omega_e, float(np.mean(w.v_north)), float(np.mean(w.v_east)), 0.0)
    if sol is None or not (sol.omega > 0 and sol.wavenumber > 0):
        return None
    eps = sol.phase_now  # Φ + ε at t = 0 and the boat's position then, which is the window's origin
    return WaveParams(sol.omega, sol.wavenumber, sol.travel_dir_rad, sol.amplitude_m * math.cos(eps),
                      sol.amplitude_m * math.sin(eps))


def _stack(w: Window, p: WaveParams, hull: HullResponse, extras: np.ndarray, noise: dict[str, float]
           ) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Weighted residuals (measured − model)/σ, their Jacobian (five wave columns, then per channel the window uses,
    in ``CHANNELS`` order, its nuisance columns: ``Window.nuisance_layout``), the raw residuals per channel and, per
    channel, the second harmonic the fit took out of them.

    Each channel has, besides the wave, an offset and a second harmonic of the wave's phase at the boat (a hull
    under way heaves and pitches with one: its speed, and so its encounter frequency, swing within each wave; in a
    head sea at 1.6 m/s it is most of what the heave's acceleration leaves unexplained). Fitted, it is no longer
    counted as noise, and the wave's own standard errors shrink to what the data say of it. It is not part of the
    wave the NMPC plans with, so what the fit reports as unexplained (``_fit_result``) keeps it."""
    geo = phase_geometry(w, p)
    models = channel_models(w, p, hull, geo)
    active = list(models)
    layout = w.nuisance_layout
    sizes = [w.counts[name] for name in active]
    res = np.empty(sum(sizes))
    jac = np.zeros((res.size, layout[-1]))
    s_along, s_perp, _, (sin1, cos1) = geo
    sin2, cos2 = 2.0 * sin1 * cos1, cos1 * cos1 - sin1 * sin1
    raw, harmonics, row = {}, {}, 0
    for column, (name, size) in enumerate(zip(active, sizes, strict=True)):
        model, jacobian = models[name]
        ok = w.selectors[name]
        rows, first = slice(row, row + size), layout[column]
        offset, h_sin, h_cos = extras[CHANNELS.index(name)]
        harmonic = h_sin * sin2[ok] + h_cos * cos2[ok]
        raw[name] = getattr(w, name)[ok] - model[ok] - harmonic - offset
        harmonics[name] = harmonic
        res[rows] = raw[name] / noise[name]
        jac[rows, 0:5] = jacobian[ok] / noise[name]
        if h_sin != 0.0 or h_cos != 0.0:  # d/dΦ of the harmonic; Φ's own derivatives: t, −s, −k s⊥
            d_harmonic = 2.0 * (h_sin * cos2[ok] - h_cos * sin2[ok]) / noise[name]
            jac[rows, 0] += d_harmonic * w.t[ok]
            jac[rows, 1] -= d_harmonic * s_along[ok]
            jac[rows, 2] -= d_harmonic * p.k * s_perp[ok]
        jac[rows, first] = 1.0 / noise[name]
        if layout[column + 1] - first == NUISANCE:
            jac[rows, first + 1] = sin2[ok] / noise[name]
            jac[rows, first + 2] = cos2[ok] / noise[name]
        row += size
    return res, jac, raw, harmonics


def _apply(w: Window, p: WaveParams, extras: np.ndarray, step: np.ndarray,
           active: list[str]) -> tuple[WaveParams, np.ndarray]:
    """Parameters after a step (the ``active`` channels' nuisance terms too, as ``Window.nuisance_layout``); a
    negative k is the same wave travelling the other way (k·s, and so Φ, unchanged)."""
    omega, k, chi, alpha, beta = p.vector() + step[0:5]
    moved = extras.copy()
    layout = w.nuisance_layout
    for column, name in enumerate(active):
        terms = step[layout[column]:layout[column + 1]]
        moved[CHANNELS.index(name), 0:terms.size] += terms
    if k < 0:
        k, chi = -k, chi + math.pi
    return WaveParams(float(omega), float(k), float(math.remainder(chi, 2 * math.pi)), float(alpha),
                      float(beta)), moved


def _noise(raw: dict[str, np.ndarray]) -> dict[str, float]:
    """Each channel's noise: its residual RMS, floored."""
    noise = dict(NOISE_FLOOR)
    for name, res in raw.items():
        noise[name] = max(NOISE_FLOOR[name], float(np.sqrt(np.mean(res * res))))
    return noise


def _gauss_newton(w: Window, p: WaveParams, offsets: np.ndarray, hull: HullResponse, noise: dict[str, float],
                  max_iterations: int) -> Stages[tuple[WaveParams, np.ndarray, int] | None]:
    """Damped Gauss–Newton (Levenberg–Marquardt) steps at fixed channel weights, one stage per evaluation;
    None when it leaves the physical range."""
    res, jac, raw, _ = _stack(w, p, hull, offsets, noise)
    yield
    active = [name for name in CHANNELS if name in raw]
    cost, damping, done = float(res @ res), 1e-3, 0
    for done in range(1, max_iterations + 1):  # noqa: B007 (the count is reported)
        normal = jac.T @ jac
        step = np.linalg.solve(normal + damping * np.diag(np.diag(normal) + 1e-12), jac.T @ res)
        trial, trial_offsets = _apply(w, p, offsets, step, active)
        if not (0 < trial.omega < 50 and 0 < trial.k < 50):
            return None
        res_t, jac_t, _, _ = _stack(w, trial, hull, trial_offsets, noise)
        yield
        cost_t = float(res_t @ res_t)
        if cost_t > cost:
            damping *= 10
            continue
        p, offsets, res, jac, cost = trial, trial_offsets, res_t, jac_t, cost_t
        damping = max(damping / 10, 1e-9)
        if np.max(np.abs(step[0:3]) / np.array([0.002 * p.omega, 0.002 * p.k, 0.002])) < 1:
            break
    return p, offsets, done


def refine_stages(w: Window, start: WaveParams, hull: HullResponse, max_iterations: int = 8,
                  noise: dict[str, float] | None = None) -> Stages[Fit | None]:
    """Gauss–Newton from ``start`` on all channels, each weighted by its noise: ``noise`` when given (a warm
    start: the last fit's), else first as the start's residuals show it, then (two more iterations) as the
    converged residuals do; None when it leaves the physical range. A generator of stages (each about one
    evaluation of the model over the window), so that a caller can spread a fit over several control steps;
    ``refine`` runs it whole."""
    offsets = np.zeros((len(CHANNELS), NUISANCE))
    done_before = 0
    w = with_encounter_smoothing(w, start)
    if noise is None:
        _, _, raw, _ = _stack(w, start, hull, offsets, NOISE_FLOOR)
        yield
        first = yield from _gauss_newton(w, start, offsets, hull, _noise(raw), max_iterations)
        if first is None:
            return None
        _, _, raw, _ = _stack(w, first[0], hull, first[1], NOISE_FLOOR)
        yield
        start, offsets, max_iterations, done_before, noise = first[0], first[1], 2, first[2], _noise(raw)
    result = yield from _gauss_newton(w, start, offsets, hull, noise, max_iterations)
    if result is None:
        return None
    p, offsets, done = result
    res, jac, raw, harmonics = _stack(w, p, hull, offsets, noise)
    yield
    unexplained = {name: raw[name] + harmonics[name] for name in raw}  # the NMPC's wave has no second harmonic
    return _fit_result(w, p, hull, res, jac, unexplained, done_before + done, _noise(raw))


def with_encounter_smoothing(w: Window, wave: WaveParams) -> Window:
    """The window with its heave's local velocity averaged over one encounter period of ``wave`` (at the window's
    mean velocity), so that a boat speeding up or slowing down within the window heaves as fast as it then
    meets the waves."""
    v_n, v_e = w.mean_velocity
    omega_e = abs(wave.omega - wave.k * (v_n * math.cos(wave.chi) + v_e * math.sin(wave.chi)))
    period = 2 * math.pi / omega_e if omega_e > 1e-3 else 0.0
    return replace(w, velocity_smoothing_s=min(period, w.span_s))


def run_stages(stages: Stages[T]) -> T:
    """Run a generator of stages to its end; its result."""
    while True:
        try:
            next(stages)
        except StopIteration as end:
            return end.value


def refine(w: Window, start: WaveParams, hull: HullResponse, max_iterations: int = 8,
           noise: dict[str, float] | None = None) -> Fit | None:
    """``refine_stages`` run whole."""
    return run_stages(refine_stages(w, start, hull, max_iterations, noise))


def _fit_result(w: Window, p: WaveParams, hull: HullResponse, res: np.ndarray, jac: np.ndarray,
                raw: dict[str, np.ndarray], iterations: int, noise: dict[str, float]) -> Fit | None:
    """Standard errors (reduced χ², widened for correlated neighbours), explained shares, residual slope."""
    m, n_params = res.size, jac.shape[1]
    if m <= n_params:
        return None
    normal = jac.T @ jac
    scale_columns = 1.0 / np.sqrt(np.maximum(np.diag(normal), 1e-300))
    if np.linalg.cond(normal * np.outer(scale_columns, scale_columns)) > MAX_CONDITION:
        return None  # some parameter is not determined by this window: no standard errors to trust
    try:
        cov = np.linalg.inv(normal)
    except np.linalg.LinAlgError:
        return None
    rate = w.t.size / max(w.span_s, 1e-9)
    scale = float(res @ res) / (m - n_params) * max(1.0, rate * CORRELATION_S)
    cov5 = cov[0:5, 0:5] * scale
    sigma = np.sqrt(np.maximum(np.diag(cov5), 0.0))
    explained, sums = {}, {}
    for name, r in raw.items():
        values = getattr(w, name)
        values = values[_has(values)]
        sums[name] = (float(r @ r), float(np.sum((values - values.mean()) ** 2)))
        explained[name] = 1.0 - sums[name][0] / sums[name][1] if sums[name][1] > 0 else 0.0
    slope = [sums[k] for k in ("along", "across") if k in sums]
    power = sum(signal for _, signal in slope)
    slope_explained = 1.0 - sum(residual for residual, _ in slope) / power if power > 0 else 0.0
    return Fit(p, sigma, cov5, explained, slope_explained, _residual_slope(w, raw, hull), w.t.size, w.span_s,
               iterations, noise)


def _residual_slope(w: Window, raw: dict[str, np.ndarray], hull: HullResponse) -> np.ndarray:
    """NED covariance of the slope residual (the hull's gains undone), rad²."""
    along, across = raw.get("along"), raw.get("across")
    if along is None or across is None or along.size != w.psi.size or across.size != w.psi.size:
        return np.zeros((2, 2))
    along, across = along / hull.pitch_gain, across / hull.roll_gain
    c, s = np.cos(w.psi), np.sin(w.psi)
    r_n, r_e = along * c - across * s, along * s + across * c
    return np.array([[np.mean(r_n * r_n), np.mean(r_n * r_e)], [np.mean(r_n * r_e), np.mean(r_e * r_e)]])
