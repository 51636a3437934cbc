"""A bank of long-crested wave components fitted by regularised linear least squares: the maths of ``predictor``.

The sea near the boat is written as K·D linear components on fixed frequencies ω_j (a grid over a band, rad/s),
each with the wavenumber of the dispersion relation (deep water k = ω²/g unless a depth is given,
``vessel.sea.spectra.wavenumber``) and one of D travel directions μ_d (NED, rad, 0 = towards North):

    ζ(t, N, E) = Σ_j a_j cos φ_j + b_j sin φ_j,   φ_j = ω_j (t − t0) − k_j ((N − N0) cos μ_j + (E − E0) sin μ_j)

(m, up positive; t in s, N/E in m NED; (t0, N0, E0) the window's end). For fixed (ω, k, μ) every channel the boat
measures is linear in (a, b): the surface slope (∂ζ/∂N, ∂ζ/∂E) = Σ k_j (cos μ_j, sin μ_j)(a_j sin φ_j − b_j cos φ_j),
the elevation ζ, and the hull's down acceleration a_D = −d²ζ/dt² ≈ Σ ω_e,j² ζ_j at the encounter frequency of the
window's mean velocity v̄ (ω_e,j = ω_j − k_j (cos μ_j, sin μ_j)·v̄). Because the boat's own track is inside φ, speed,
surges and turns need no separate treatment: the fit is in the earth frame and in time.

Neighbouring frequencies are nearly collinear over a window of a few wave periods, so the fit is a ridge
(Tikhonov) regression: minimise Σ w_c (y − X c)² + λ·tr(XᵀWX)/n · Σ c² with each channel weighted by its noise.
The solution is the bank's amplitudes and phases, returned as a ``vessel.sea.irregular.IrregularWaves`` with
absolute phases (the same convention as the simulator's sea: ζ = Σ A cos(ω t − k (N cos μ + E sin μ) + ε)), so
the prediction at any future (t, N, E) — and a CasADi sum-of-components model — comes from one object of fixed
size K·D. Pure numpy; no state.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vessel.sea.irregular import IrregularWaves
from vessel.sea.spectra import wavenumber

GRAVITY = 9.81


def slope_from_attitude(roll: np.ndarray, pitch: np.ndarray, yaw: np.ndarray,
                        roll_sign: float = -1.0) -> tuple[np.ndarray, np.ndarray]:
    """The earth-frame surface gradient (∂ζ/∂N, ∂ζ/∂E) a hull that lies along the surface shows by its attitude (rad).

    As the window estimator reads it: pitch is the slope angle along the hull, roll × ``roll_sign`` the one across
    it (−1 the geometric surface-relative roll of ``vessel.sea``, +1 the paper's sign); rotated by the heading ψ
    into NED that is the slope-angle vector (α_N, α_E), whose magnitude atan|∇ζ| is undone (tan) to give the
    gradient (0.8 % at a 9° slope)."""
    along, across = np.asarray(pitch, float), np.asarray(roll, float) * roll_sign
    c, s = np.cos(yaw), np.sin(yaw)
    a_n, a_e = along * c - across * s, along * s + across * c
    angle = np.hypot(a_n, a_e)
    scale = np.where(angle > 1e-9, np.tan(np.minimum(angle, 1.4)) / np.maximum(angle, 1e-9), 1.0)
    return a_n * scale, a_e * scale


@dataclass(frozen=True)
class Bank:
    """Fixed components: ω (rad/s), k (rad/m) and μ (rad NED, direction of travel), one entry each."""

    omega: np.ndarray
    k: np.ndarray
    direction: np.ndarray

    @property
    def size(self) -> int:
        """Number of components (K·D)."""
        return int(self.omega.size)


def make_bank(band_rad_s: tuple[float, float], n_frequencies: int, directions_rad: np.ndarray | list[float],
              depth_m: float | None = None) -> Bank:
    """K frequencies evenly spaced over ``band_rad_s`` (both ends in), each at every direction (rad NED); components
    ordered frequency-major (all directions of ω_0, then of ω_1, …)."""
    omega = np.linspace(band_rad_s[0], band_rad_s[1], n_frequencies)
    dirs = np.asarray(directions_rad, float).ravel()
    w, d = np.meshgrid(omega, dirs, indexing="ij")
    return Bank(w.ravel(), wavenumber(w.ravel(), depth_m, GRAVITY), d.ravel())


def frequencies_needed(band_rad_s: tuple[float, float], window_s: float, speed_mps: float) -> int:
    """Frequencies a window needs: spacing at most π/window in encounter frequency, where the bank is widest (head
    seas at the band's top, dω_e/dω = 1 + 2 U ω/g). A coarser grid cannot hold a component lying between two of its
    lines over the whole window, and the fit then invents ones that do not extrapolate."""
    stretch = 1.0 + 2.0 * abs(speed_mps) * band_rad_s[1] / GRAVITY
    return max(2, math.ceil((band_rad_s[1] - band_rad_s[0]) * stretch * window_s / math.pi) + 1)


def spectral_prior(bank: Bank, peak_rad_s: float) -> np.ndarray:
    """The prior variance (m²) of each component's cos and sin coefficient: a Pierson–Moskowitz shape at the peak
    ``peak_rad_s`` times the bin width, shared among the directions. Only its shape matters (the fit's ``ridge``
    scales it): it tells the fit that short waves carry little height, so that it does not explain the slope with
    them (a flat prior does, because a short wave's slope per metre of height is large), and that is what keeps
    its extrapolation sane."""
    freqs = np.unique(bank.omega)
    width = float(freqs[-1] - freqs[0]) / max(freqs.size - 1, 1) if freqs.size > 1 else 1.0
    x = bank.omega / peak_rad_s
    shape = 5 / 16 * x**-5 * np.exp(-1.25 * x**-4) / peak_rad_s  # PM per unit Hs², m²·s/rad
    return np.maximum(shape * width * freqs.size / bank.size, 1e-12 * float(shape.max()))


@dataclass(frozen=True)
class Samples:
    """Measured samples, arrays of equal length: t (s), N/E (m NED), slope (∂ζ/∂N, ∂ζ/∂E), elevation ζ (m, up) and
    the hull's down acceleration a_D (m/s²); NaN where a channel has no value."""

    t: np.ndarray
    north: np.ndarray
    east: np.ndarray
    slope_n: np.ndarray
    slope_e: np.ndarray
    heave: np.ndarray
    accel: np.ndarray

    def subset(self, keep: np.ndarray) -> Samples:
        """The samples where ``keep`` (a boolean mask or index array)."""
        return Samples(*(getattr(self, name)[keep] for name in self.__dataclass_fields__))


def _phases(bank: Bank, t: np.ndarray, north: np.ndarray, east: np.ndarray) -> np.ndarray:
    """φ (samples × components) for t, N, E already referred to the origin."""
    return (np.multiply.outer(t, bank.omega) - np.multiply.outer(north, bank.k * np.cos(bank.direction))
            - np.multiply.outer(east, bank.k * np.sin(bank.direction)))


def _channel_rows(bank: Bank, s: Samples, origin: tuple[float, float, float],
                  velocity: tuple[float, float]) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Per channel with data: (measured values, design rows [cos-coefficients | sin-coefficients], sample mask)."""
    phase = _phases(bank, s.t - origin[0], s.north - origin[1], s.east - origin[2])
    cos, sin = np.cos(phase), np.sin(phase)
    kn, ke = bank.k * np.cos(bank.direction), bank.k * np.sin(bank.direction)
    omega_e = bank.omega - kn * velocity[0] - ke * velocity[1]
    rows = {"slope_n": lambda: np.hstack([kn * sin, -kn * cos]), "slope_e": lambda: np.hstack([ke * sin, -ke * cos]),
            "heave": lambda: np.hstack([cos, sin]), "accel": lambda: np.hstack([omega_e**2 * cos, omega_e**2 * sin])}
    out = []
    for name, build in rows.items():
        values = getattr(s, name)
        ok = np.isfinite(values)
        if np.count_nonzero(ok) >= 4:
            out.append((values[ok], build()[ok], ok))
    return out


@dataclass(frozen=True)
class BankFit:
    """A fitted bank: its components with absolute phases (``waves``), the share of the slope it explains over the
    window (0..1), the window's slope RMS (rad) and its span (s)."""

    waves: IrregularWaves
    slope_explained: float
    slope_rms: float
    span_s: float

    def predict(self, t: np.ndarray, north: np.ndarray, east: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(∂ζ/∂N, ∂ζ/∂E, ζ m) at arrays of autopilot time t (s) and NED position (m), broadcast together."""
        slope_n, slope_e = self.waves.gradient(north, east, t)
        return np.asarray(slope_n), np.asarray(slope_e), np.asarray(self.waves.elevation(north, east, t))


def mean_velocity(s: Samples) -> tuple[float, float]:
    """The window's mean NED velocity (m/s): its displacement over its span."""
    span = float(s.t[-1] - s.t[0])
    if span <= 0:
        return 0.0, 0.0
    return float(s.north[-1] - s.north[0]) / span, float(s.east[-1] - s.east[0]) / span


def fit_bank(bank: Bank, s: Samples, ridge: float = 1e-2, weights: np.ndarray | None = None,
             noise: dict[str, float] | None = None, prior: np.ndarray | None = None) -> BankFit | None:
    """Ridge fit of the bank's cos/sin coefficients to the samples (see the module docstring); None when the window has
    no slope samples (more unknowns than rows are fine: the penalty holds them). ``weights`` (per sample, ≥ 0)
    favour recent samples; ``noise`` (per channel, in its unit) scales the channels against each other (default:
    slope 0.01 rad, heave 0.3 m, acceleration 0.1 m/s²). With a ``prior`` shape (``spectral_prior``), scaled so that
    its slope variance is the window's (less the noise), the fit is the Bayesian MAP estimate with noise σ² =
    ``ridge`` × the channel noise²; without one a plain ridge relative to the normal matrix's mean diagonal."""
    noise = {"slope_n": 0.01, "slope_e": 0.01, "heave": 0.3, "accel": 0.1, **(noise or {})}
    origin = (float(s.t[-1]), float(s.north[-1]), float(s.east[-1]))
    channels = _channel_rows(bank, s, origin, mean_velocity(s))
    if not channels:
        return None
    w_all = np.ones(s.t.size) if weights is None else np.asarray(weights, float)
    names = [n for n in ("slope_n", "slope_e", "heave", "accel") if np.count_nonzero(np.isfinite(getattr(s, n))) >= 4]
    ys, xs, ws = [], [], []
    for column, (name, (values, rows, ok)) in enumerate(zip(names, channels, strict=True)):
        offset = np.zeros((values.size, len(names)))
        offset[:, column] = 1.0  # an attitude or height offset is not a wave: one free column per channel
        ys.append(values)
        xs.append(np.hstack([rows, offset]))
        ws.append(w_all[ok] / noise[name] ** 2)
    y, x, w = np.concatenate(ys), np.vstack(xs), np.concatenate(ws)
    normal = x.T @ (x * w[:, None])
    slope = names[:2] == ["slope_n", "slope_e"]
    if prior is None:
        penalty = np.full(2 * bank.size, float(np.trace(normal)) / normal.shape[0])
    else:
        variance = sum(float(np.var(v)) for v in ys[:2]) if slope else 0.0
        signal = max(variance - 2 * noise["slope_n"] ** 2, 0.25 * variance, 1e-12)  # the slope's wave part, rad²
        scaled = prior * signal / max(float(np.sum(bank.k**2 * prior)), 1e-30)  # the prior's slope variance = it
        penalty = np.tile(1.0 / np.maximum(scaled, 1e-30), 2)
    penalty = np.concatenate([ridge * penalty, np.full(len(names), 1e-9 * float(np.mean(penalty)))])
    try:
        coef = np.linalg.solve(normal + np.diag(penalty), x.T @ (w * y))
    except np.linalg.LinAlgError:
        return None
    return _result(bank, coef, origin, s, ys[:2] if slope else [], xs[:2] if slope else [])


def _result(bank: Bank, coef: np.ndarray, origin: tuple[float, float, float], s: Samples, ys: list[np.ndarray],
            xs: list[np.ndarray]) -> BankFit:
    """The fit as absolute-phase components and its explained share of the slope."""
    a, b = coef[: bank.size], coef[bank.size: 2 * bank.size]
    amplitude = np.hypot(a, b)
    t0, n0, e0 = origin
    s0 = bank.k * (n0 * np.cos(bank.direction) + e0 * np.sin(bank.direction))
    # a cos φ + b sin φ = A cos(φ − θ), θ = atan2(b, a); φ = ω(t − t0) − k(s − s0) → ε = −ω t0 + k s0 − θ
    phase = np.remainder(-bank.omega * t0 + s0 - np.arctan2(b, a) + math.pi, 2 * math.pi) - math.pi
    waves = IrregularWaves(amplitude, bank.omega, bank.k, bank.direction, phase)
    explained, rms = 0.0, 0.0
    if ys:
        y, x = np.concatenate(ys), np.vstack(xs)
        residual = y - x @ coef
        y = y - np.concatenate([np.full(v.size, v.mean()) for v in ys])
        power = float(y @ y)
        explained = 1.0 - float(residual @ residual) / power if power > 0 else 0.0
        rms = math.sqrt(power / ys[0].size)  # of the slope vector, less its offsets
    return BankFit(waves, explained, rms, float(s.t[-1] - s.t[0]))
