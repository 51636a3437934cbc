"""The earth-frame model of one regular wave as the boat's sensors see it: the data and maths ``window_fit`` fits.

The wave ζ(N, E, t) = a·sin(Φ + ε), Φ = ω t − k (N cos χ + E sin χ) (NED, t in seconds from the window's
end), written with α = a cos ε, β = a sin ε as ζ = α sin Φ + β cos Φ, is seen by the boat at its own
position p(t) (so the boat's speed and turns are inside Φ: no separate Doppler step, and a turn does not
break the fit) through four channels (``CHANNELS``), each with its own nuisance terms in the fit (an offset and,
where its samples allow, a second harmonic: ``window_fit``):

* ``along``  = pitch            ≈ G_p · slope·h(ψ) at phase Φ − φ_p   (slope = ∇ζ = −k d ζ'(Φ), d = (cos χ, sin χ))
* ``across`` = roll · roll_sign ≈ G_r · slope·h⊥(ψ) at phase Φ − φ_r  (h = (cos ψ, sin ψ), h⊥ = (−sin ψ, cos ψ))
* ``accel``  = the hull's down acceleration a_D (IMU) ≈ ω̄_e² ζ, ω̄_e = ω − k d·v̄ the encounter frequency at the
  velocity v̄ averaged over one encounter period around each sample (``Window.local_velocity``). Not the
  instantaneous one: a hull surging in head seas (the paper's hull swings between 1.3 and 2.9 m/s within a
  wave) does not heave as the kinematic ω_e(t)² would scale it, and modelling that modulation biased the period
  by +3 % and the wavelength by −7 % (with exact sensors). Not the whole window's mean either: a boat speeding up
  from drifting as the window fills heaved at another encounter frequency early on, which made its first
  confident answer late (16.5 s) and short (wavelength −10 %) in a following sea
* ``down``   = the GPS down position ≈ −ζ at phase Φ − ω_e·lag

G, φ are the hull's roll/pitch response to the slope (``calibration``). ``channel_models`` gives each channel's
model and its Jacobian in (ω, k, χ, α, β) at every sample, in closed form. Pure numpy; no state.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

CHANNELS = ("along", "across", "accel", "down")
NUISANCE = 3  # per channel at most, in the fit: its offset, then the second harmonic's sin 2Φ and cos 2Φ amplitudes
HARMONIC_MIN_SAMPLES = 8  # a channel's second harmonic is fitted only on this many samples or more


@dataclass(frozen=True)
class Window:
    """The samples of one window, arrays of equal length (NED, SI, rad), referred to its end: t in s from the
    window's last sample, north/east in m from the boat's position then (so the fitted phase and amplitude are
    the wave's where and when the boat is now, not extrapolated from home across the window's span).

    ``accel`` and ``down`` hold NaN where that channel had no sample.
    """

    t: np.ndarray
    north: np.ndarray
    east: np.ndarray
    v_north: np.ndarray
    v_east: np.ndarray
    psi: np.ndarray
    along: np.ndarray
    across: np.ndarray
    accel: np.ndarray
    down: np.ndarray
    velocity_smoothing_s: float = 0.0  # the encounter period the heave's local ω_e is averaged over (0: the mean)

    @property
    def span_s(self) -> float:
        """Seconds the window covers."""
        return float(self.t[-1] - self.t[0]) if self.t.size > 1 else 0.0

    @cached_property
    def channels(self) -> tuple[str, ...]:
        """The channels with samples, in ``CHANNELS`` order; the GPS height only without the IMU's heave (half the
        samples or more), whose acceleration sizes the heave far better than a height with 0.3 m of noise."""
        have = [name for name in CHANNELS if np.any(self.valid[name])]
        if "accel" in have and np.count_nonzero(self.valid["accel"]) >= self.t.size // 2:
            have = [name for name in have if name != "down"]
        return tuple(have)

    @cached_property
    def valid(self) -> dict[str, np.ndarray]:
        """Per channel, which samples hold a value."""
        return {name: np.isfinite(getattr(self, name)) for name in CHANNELS}

    @cached_property
    def counts(self) -> dict[str, int]:
        """Per channel, how many samples hold a value."""
        return {name: int(np.count_nonzero(mask)) for name, mask in self.valid.items()}

    def nuisance_columns(self, name: str) -> int:
        """How many nuisance terms the fit gives channel ``name``: its offset, and its second harmonic only where
        its samples (``HARMONIC_MIN_SAMPLES`` or more) span at least one encounter period (``velocity_smoothing_s``;
        0: never). A channel that has only just started (an IMU that comes back late in the window) would
        otherwise give its few samples to the harmonic rather than to the wave."""
        if self.counts[name] < HARMONIC_MIN_SAMPLES or self.velocity_smoothing_s <= 0:
            return 1
        times = self.t[self.valid[name]]
        return NUISANCE if times[-1] - times[0] >= self.velocity_smoothing_s else 1

    @cached_property
    def nuisance_layout(self) -> tuple[int, ...]:
        """The fit's first nuisance column of each channel in ``channels`` (after the wave's five), then the total
        column count."""
        firsts, column = [], 5
        for name in self.channels:
            firsts.append(column)
            column += self.nuisance_columns(name)
        return (*firsts, column)

    @cached_property
    def selectors(self) -> dict[str, slice | np.ndarray]:
        """Per channel what picks its samples out of a per-sample array: a whole slice where every sample holds a
        value (a view, no copy: the fit's hot path), else the ``valid`` mask."""
        return {name: slice(None) if bool(np.all(mask)) else mask for name, mask in self.valid.items()}

    @cached_property
    def cos_psi(self) -> np.ndarray:
        return np.cos(self.psi)

    @cached_property
    def sin_psi(self) -> np.ndarray:
        return np.sin(self.psi)

    @cached_property
    def mean_velocity(self) -> tuple[float, float]:
        """The window's mean NED velocity (m/s)."""
        return float(np.mean(self.v_north)), float(np.mean(self.v_east))

    @cached_property
    def local_velocity(self) -> tuple[np.ndarray, np.ndarray]:
        """Per sample the NED velocity (m/s) averaged over ``velocity_smoothing_s`` centred on it (fewer seconds at
        the window's ends); every sample the window's mean while that is 0. A whole encounter period's average
        has none of the surge a wave itself drives, but follows the boat speeding up or slowing down."""
        if self.velocity_smoothing_s <= 0 or self.t.size < 2:
            v_n, v_e = self.mean_velocity
            return np.full(self.t.size, v_n), np.full(self.t.size, v_e)
        half = 0.5 * self.velocity_smoothing_s
        lo = np.searchsorted(self.t, self.t - half, side="left")
        hi = np.searchsorted(self.t, self.t + half, side="right")
        count = hi - lo

        def boxed(values: np.ndarray) -> np.ndarray:
            sums = np.concatenate(([0.0], np.cumsum(values)))
            return (sums[hi] - sums[lo]) / count

        return boxed(self.v_north), boxed(self.v_east)


@dataclass(frozen=True)
class HullResponse:
    """The hull's roll/pitch per unit slope (gain) and lag (rad) near the encounter frequency; the GPS lag (s)."""

    roll_gain: float = 1.0
    roll_lag_rad: float = 0.0
    pitch_gain: float = 1.0
    pitch_lag_rad: float = 0.0
    down_lag_s: float = 0.0


@dataclass(frozen=True)
class WaveParams:
    """ω rad/s, k rad/m, χ rad (NED travel direction), α, β m (ζ = α sin Φ + β cos Φ at the window's end time)."""

    omega: float
    k: float
    chi: float
    alpha: float
    beta: float

    @property
    def amplitude(self) -> float:
        """a = |ζ|max, m."""
        return math.hypot(self.alpha, self.beta)

    def vector(self) -> np.ndarray:
        return np.array([self.omega, self.k, self.chi, self.alpha, self.beta])

    def shifted(self, dt_s: float) -> WaveParams:
        """The same wave with the time origin moved ``dt_s`` later (t' = t − dt): Φ' = Φ − ω·dt."""
        c, s = math.cos(self.omega * dt_s), math.sin(self.omega * dt_s)
        # ζ = α sin(Φ' + ω dt) + β cos(Φ' + ω dt)
        return WaveParams(self.omega, self.k, self.chi, self.alpha * c - self.beta * s, self.alpha * s + self.beta * c)


def phase_geometry(w: Window, p: WaveParams) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                      tuple[np.ndarray, np.ndarray]]:
    """(s = p·d, s⊥ = p·d⊥, Φ = ω t − k s, (sin Φ, cos Φ)) per sample."""
    d_n, d_e = math.cos(p.chi), math.sin(p.chi)
    s = w.north * d_n + w.east * d_e
    phi = p.omega * w.t - p.k * s
    return s, -w.north * d_e + w.east * d_n, phi, (np.sin(phi), np.cos(phi))


def _zeta(p: WaveParams, phase: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(ζ, dζ/dΦ, sin, cos) at the phases."""
    sin, cos = np.sin(phase), np.cos(phase)
    return p.alpha * sin + p.beta * cos, p.alpha * cos - p.beta * sin, sin, cos


def _lagged(p: WaveParams, trig: tuple[np.ndarray, np.ndarray], lag: float) -> tuple[np.ndarray, ...]:
    """``_zeta`` at the phases less a constant ``lag``, from their sin and cos (a rotation, no new sines)."""
    sin0, cos0 = trig
    c, s = math.cos(lag), math.sin(lag)
    sin, cos = sin0 * c - cos0 * s, cos0 * c + sin0 * s
    return p.alpha * sin + p.beta * cos, p.alpha * cos - p.beta * sin, sin, cos


def _slope_channel(w: Window, p: WaveParams, geo: tuple, gain: float, lag: float,
                   across: bool) -> tuple[np.ndarray, np.ndarray]:
    """Model and Jacobian (columns ω, k, χ, α, β) of the pitch (``across`` False) or roll channel."""
    s, s_perp, _, trig = geo
    zeta, dzeta, sin, cos = _lagged(p, trig, lag)
    d_n, d_e = math.cos(p.chi), math.sin(p.chi)
    cos_rel, sin_rel = d_n * w.cos_psi + d_e * w.sin_psi, d_e * w.cos_psi - d_n * w.sin_psi  # of χ − ψ
    f, f_chi = (sin_rel, cos_rel) if across else (cos_rel, -sin_rel)
    gk = gain * p.k
    model = -gk * f * dzeta
    jac = np.column_stack([gk * f * zeta * w.t, -gain * f * dzeta - gk * f * zeta * s,
                           -gk * f_chi * dzeta - gk * p.k * f * zeta * s_perp, -gk * f * cos, gk * f * sin])
    return model, jac


def _accel_channel(w: Window, p: WaveParams, geo: tuple) -> tuple[np.ndarray, np.ndarray]:
    """Model (ω̄_e² ζ, the hull's down acceleration) and its Jacobian (ω, k, χ, α, β); ω̄_e = ω − k d·v̄ at the
    window's local velocity v̄ (``Window.local_velocity``; see the module docstring for why not the
    instantaneous one)."""
    s, s_perp, _, trig = geo
    zeta, dzeta, sin, cos = _lagged(p, trig, 0.0)
    d_n, d_e = math.cos(p.chi), math.sin(p.chi)
    v_n, v_e = w.local_velocity
    v_d, v_perp = v_n * d_n + v_e * d_e, -v_n * d_e + v_e * d_n
    we = p.omega - p.k * v_d
    we2 = we * we
    jac = np.column_stack([2 * we * zeta + we2 * dzeta * w.t, -2 * we * v_d * zeta - we2 * dzeta * s,
                           -2 * we * p.k * v_perp * zeta - we2 * dzeta * p.k * s_perp, we2 * sin, we2 * cos])
    return we2 * zeta, jac


def _down_channel(w: Window, p: WaveParams, geo: tuple, lag_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Model (−ζ, the GPS down position, its lag as a phase) and its Jacobian (ω, k, χ, α, β)."""
    s, s_perp, phi, _ = geo
    we = p.omega - p.k * (w.v_north * math.cos(p.chi) + w.v_east * math.sin(p.chi))
    zeta, dzeta, sin, cos = _zeta(p, phi - we * lag_s)
    jac = np.column_stack([-dzeta * w.t, dzeta * s, dzeta * p.k * s_perp, -sin, -cos])
    return -zeta, jac


def channel_models(w: Window, p: WaveParams, hull: HullResponse,
                   geo: tuple | None = None) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Per channel the window uses (``Window.channels``): (model, Jacobian of the wave's five parameters) at
    every sample; ``geo`` is ``phase_geometry(w, p)`` when the caller has it already."""
    geo = phase_geometry(w, p) if geo is None else geo
    builders = {"along": lambda: _slope_channel(w, p, geo, hull.pitch_gain, hull.pitch_lag_rad, False),
                "across": lambda: _slope_channel(w, p, geo, hull.roll_gain, hull.roll_lag_rad, True),
                "accel": lambda: _accel_channel(w, p, geo),
                "down": lambda: _down_channel(w, p, geo, hull.down_lag_s)}
    return {name: builders[name]() for name in w.channels}
