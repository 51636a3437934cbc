"""Phase-resolved prediction of the slope (and height) of an irregular sea the hull will meet, from its own motion.

``PhasePredictor`` is fed time-stamped samples on the autopilot's clock — the boat's NED position (m) and the
earth-frame surface slope (∂ζ/∂N, ∂ζ/∂E) it measures (or the roll/pitch/heading it is read from, as the window
estimator reads it: ``bank.slope_from_attitude``), optionally the heave ζ (m, up) or the IMU's down
acceleration — and every ``fit_interval_s`` fits the last ``window_s`` seconds (thinned to ``rate_hz``) with a bank
of long-crested components (``bank``): a frequency grid over ``band_rad_s`` fine enough for the window in the
encounter domain, deep-water (or finite-depth) wavenumbers, and directions around the sea's own: the principal
axis of the measured slope, both ways along it, then only the way that carries most of the fitted energy (an
opposite bank soaks up energy and spoils a following sea; at rest the two are alike and both are kept), fanned by
``fan_deg``. The fit is a Bayesian ridge with a Pierson–Moskowitz prior at ωp (given, e.g. the window estimator's
ω, or adapted from the fitted bank's mean frequency). The fitted bank is an ``IrregularWaves`` with absolute
phases, so it predicts the slope and the height at any future (t, N, E), e.g. along the NMPC's planned path, and
turns and speed changes cost nothing (the fit lives in the earth frame).

Why this and not an AR model of the slope or a Kalman filter on a spectral model: on the bench
(``bench/wave_prediction.py``) a 20-lag AR model of each slope channel matched the bank 1 s ahead in quartering and
following seas but fell well behind it in beam seas (r 0.5–0.6 against 0.86–0.89) and in the turn, and it lives in
the boat's frame (a turn or a change of speed changes its model) and gives no slope at a point away from the boat. The
bank's skill comes from its prior: with a flat ridge instead it lost most of it in head and beam seas. A Kalman
filter on the same components would be this fit made recursive; the window's least squares is simpler to bound and
to reset.

Confidence is measured, not modelled: every fit's prediction is scored against the slope that arrives over the next
``horizon_s`` seconds, per lead-time bin, and the skill (1 − error power / signal power, forgetting with
``skill_memory_s``) says how far ahead it can be trusted; ``confident(lead)`` is False (the controller keeps its
statistics term) before enough fits are scored, below ``min_skill`` or with a slope below ``min_slope_rad`` (calm
water, noise). Bad input (NaN, time not increasing) is skipped with a reason; a clock that goes back by more than
5 s, or a silence longer than the window, restarts the window.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from mavbridge.waves.phase.bank import (
    Bank,
    BankFit,
    Samples,
    fit_bank,
    frequencies_needed,
    make_bank,
    mean_velocity,
    slope_from_attitude,
    spectral_prior,
)
from mavbridge.waves.source import MotionSample
from mavbridge.waves.window_buffer import down_acceleration

FIELDS = ("t", "north", "east", "slope_n", "slope_e", "heave", "accel")
CLOCK_BACK_S = 5.0  # a clock going back by more than this is a reboot: the window belongs to the old clock
LEAD_BIN_S = 1.0  # the skill is kept per lead-time bin of this width
PEAK_RATIO = 0.8  # ωp ≈ this × the fitted mean frequency m1/m0 (0.77 Pierson–Moskowitz, 0.83 JONSWAP γ 3.3)


@dataclass(frozen=True)
class PredictorSettings:
    """What the predictor fits and when it is trusted (SI units, rad)."""

    window_s: float = 40.0  # seconds of samples a fit uses
    fit_interval_s: float = 1.0  # a new fit at most this often (autopilot time)
    rate_hz: float = 10.0  # samples a fit uses per second (thinned)
    # the bank's band (rad/s): its top must lie above every slope the hull feels (energy above it is aliased into
    # the bank and ruins its extrapolation): 4.5 rad/s (λ 3 m) holds a Tp 6 s sea synthesised up to 4 ωp
    band_rad_s: tuple[float, float] = (0.4, 4.5)
    max_frequencies: int = 140  # cap of the frequency grid (cost grows with its square)
    fan_deg: tuple[float, ...] = (0.0,)  # directions around the dominant one (short-crested seas: e.g. −30, 0, 30)
    peak_frequency_rad_s: float | None = None  # ωp when known (e.g. the window estimator's ω); else adapted
    initial_peak_rad_s: float = 2 * math.pi / 6.0  # the adapted ωp's start
    ridge: float = 1.0  # noise variance over prior variance, in units of the channel noise²
    slope_noise_rad: float = 0.01  # the slope channels' noise (attitude noise and what the bank cannot hold)
    depth_m: float | None = None  # water depth for dispersion (None: deep water)
    roll_sign: float = -1.0  # as ``slope_from_attitude``
    horizon_s: float = 4.0  # the longest lead time scored (and so trusted)
    min_skill: float = 0.5  # skill below this at a lead time is not confident there
    min_slope_rad: float = 0.01  # an RMS slope below this is no sea (``spread.NOISE_FLOOR_RAD``)
    skill_memory_s: float = 30.0  # the skill forgets with this time constant
    min_scored: int = 5  # fits scored before any confidence


@dataclass
class _Skill:
    """Forgetting sums of error and signal power per lead-time bin of past fits' predictions."""

    bins: int
    memory_s: float
    error: np.ndarray = field(init=False)
    signal: np.ndarray = field(init=False)
    scored: int = 0

    def __post_init__(self) -> None:
        self.error, self.signal = np.zeros(self.bins), np.zeros(self.bins)

    def add(self, lead: np.ndarray, err2: np.ndarray, sig2: np.ndarray, dt: float) -> None:
        """One scored fit: per sample its lead (s), squared error and squared signal (rad²)."""
        decay = math.exp(-dt / self.memory_s)
        index = np.minimum((lead / LEAD_BIN_S).astype(int), self.bins - 1)
        self.error = self.error * decay + np.bincount(index, err2, self.bins)
        self.signal = self.signal * decay + np.bincount(index, sig2, self.bins)
        self.scored += 1

    def at(self, lead_s: np.ndarray) -> np.ndarray:
        """Skill (≤ 1; 0 = no better than predicting zero) at lead times (s), −inf in an unscored bin."""
        index = np.clip((np.asarray(lead_s, float) / LEAD_BIN_S).astype(int), 0, self.bins - 1)
        with np.errstate(divide="ignore", invalid="ignore"):
            skill = np.where(self.signal > 0, 1.0 - self.error / self.signal, -np.inf)
        return skill[index]


class PhasePredictor:
    """Short-term phase-resolved wave prediction from the boat's own motion (see the module docstring)."""

    def __init__(self, settings: PredictorSettings | None = None) -> None:
        self.s = settings or PredictorSettings()
        self._rows: dict[str, list[float]] = {key: [] for key in FIELDS}
        self._fit: BankFit | None = None
        self._fit_t = -math.inf
        self._pending: list[tuple[float, BankFit, tuple[float, float]]] = []  # fits not yet scored, with offsets
        self._skill = _Skill(math.ceil(self.s.horizon_s / LEAD_BIN_S), self.s.skill_memory_s)
        self._peak = self.s.peak_frequency_rad_s or self.s.initial_peak_rad_s
        self._offset = (0.0, 0.0)
        self.skipped: dict[str, int] = {}
        self.fits = 0

    # ------------------------------------------------------------------ samples
    def observe(self, t_s: float, north_m: float, east_m: float, slope_n: float, slope_e: float,
                heave_m: float = math.nan, accel_down_mps2: float = math.nan) -> str | None:
        """Take one sample (autopilot time s; NED position m; earth-frame slope ∂ζ/∂N, ∂ζ/∂E; optional heave ζ m
        up, or the hull's down acceleration m/s²). None when taken, else why it was skipped (also counted in
        ``skipped``)."""
        reason = self._check(t_s, north_m, east_m, slope_n, slope_e)
        if reason is not None:
            self.skipped[reason] = self.skipped.get(reason, 0) + 1
            return reason
        for key, value in zip(FIELDS, (t_s, north_m, east_m, slope_n, slope_e, heave_m, accel_down_mps2),
                              strict=True):
            self._rows[key].append(float(value))
        if t_s - self._fit_t >= self.s.fit_interval_s:
            self._fit_t = t_s
            self._refit(t_s)
        return None

    def observe_attitude(self, t_s: float, north_m: float, east_m: float, roll: float, pitch: float, yaw: float,
                         heave_m: float = math.nan, accel_down_mps2: float = math.nan) -> str | None:
        """``observe`` with the slope read from the attitude (rad) as the window estimator reads it."""
        slope_n, slope_e = slope_from_attitude(roll, pitch, yaw, self.s.roll_sign)
        return self.observe(t_s, north_m, east_m, float(slope_n), float(slope_e), heave_m, accel_down_mps2)

    def observe_sample(self, sample: MotionSample) -> str | None:
        """``observe_attitude`` from what the autopilot streams (ATTITUDE, position, the IMU's heave if streamed)."""
        att, pos = np.asarray(sample.attitude, float), np.asarray(sample.position_ned, float)
        if att.shape != (3,) or pos.shape != (3,):
            self.skipped["malformed sample"] = self.skipped.get("malformed sample", 0) + 1
            return "malformed sample"
        accel = down_acceleration(tuple(att), sample.accel_body) if np.all(np.isfinite(att)) else math.nan
        return self.observe_attitude(sample.t_s, pos[0], pos[1], att[0], att[1], att[2], math.nan, accel)

    def _check(self, t: float, north: float, east: float, slope_n: float, slope_e: float) -> str | None:
        """Why a sample cannot be taken, or None; restarts the window on a reboot or a long silence."""
        if not all(math.isfinite(v) for v in (t, north, east, slope_n, slope_e)):
            return "non-finite time, position or slope"
        times = self._rows["t"]
        if times and t <= times[-1]:
            if t < times[-1] - CLOCK_BACK_S:
                self.reset()
                return None
            return "time not increasing"
        if times and t - times[-1] > self.s.window_s:
            self.reset()
        return None

    def reset(self) -> None:
        """Forget the window, the fit and its skill (a reboot of the autopilot clock, a long silence)."""
        for values in self._rows.values():
            values.clear()
        self._fit, self._fit_t, self._pending = None, -math.inf, []
        self._skill = _Skill(self._skill.bins, self.s.skill_memory_s)

    # ------------------------------------------------------------------ fitting
    def window(self, t_s: float) -> Samples | None:
        """The last ``window_s`` seconds up to ``t_s``, thinned to ``rate_hz``; None with under 4 s of them."""
        times = self._rows["t"]
        first = next((i for i, v in enumerate(times) if v >= t_s - self.s.window_s), len(times))
        if first > 0:
            for values in self._rows.values():
                del values[:first]
        if len(times) < 2 or times[-1] - times[0] < 4.0:
            return None
        rate = (len(times) - 1) / (times[-1] - times[0])
        step = max(1, round(rate / self.s.rate_hz))
        start = (len(times) - 1) % step
        return Samples(*(np.asarray(self._rows[key][start::step], float) for key in FIELDS))

    def _directions(self, s: Samples) -> list[float]:
        """The principal axis of the measured slope (rad NED), both ways along it."""
        sn, se = s.slope_n - s.slope_n.mean(), s.slope_e - s.slope_e.mean()
        axis = 0.5 * math.atan2(2 * float(sn @ se), float(sn @ sn - se @ se))
        return [axis, axis + math.pi]

    def _bank(self, s: Samples, directions: list[float]) -> Bank:
        band = self.s.band_rad_s
        speed = math.hypot(*mean_velocity(s))
        n = min(frequencies_needed(band, float(s.t[-1] - s.t[0]), speed), self.s.max_frequencies)
        return make_bank(band, n, directions, self.s.depth_m)

    def _fit_window(self, s: Samples) -> BankFit | None:
        """Both ways along the axis, then (when one way carries over three quarters of the energy) that way with
        its fan."""
        noise = {"slope_n": self.s.slope_noise_rad, "slope_e": self.s.slope_noise_rad}
        axis = self._directions(s)
        bank = self._bank(s, axis)
        fit = fit_bank(bank, s, self.s.ridge, noise=noise, prior=spectral_prior(bank, self._peak))
        if fit is None:
            return None
        energy = (fit.waves.amplitude_m * fit.waves.wavenumber_rad_m) ** 2
        ahead = float(energy[0::2].sum()) / max(float(energy.sum()), 1e-30)
        if 0.25 <= ahead <= 0.75 and len(self.s.fan_deg) == 1:
            return fit
        main = axis[0] if ahead > 0.5 else axis[1]
        sides = [main + math.radians(d) for d in self.s.fan_deg] if not 0.25 <= ahead <= 0.75 else \
            [a + math.radians(d) for a in axis for d in self.s.fan_deg]
        bank = self._bank(s, sides)
        return fit_bank(bank, s, self.s.ridge, noise=noise, prior=spectral_prior(bank, self._peak)) or fit

    def _refit(self, t: float) -> None:
        """A new fit on the window ending at ``t``; past fits whose horizon has passed are scored first."""
        s = self.window(t)
        if s is None:
            return
        self._score(s, t)
        fit = self._fit_window(s)
        if fit is None:
            return
        self._fit = fit
        self.fits += 1
        self._offset = (float(np.mean(s.slope_n)), float(np.mean(s.slope_e)))
        self._pending.append((t, fit, self._offset))
        if self.s.peak_frequency_rad_s is None:
            self._adapt_peak(fit)

    def _adapt_peak(self, fit: BankFit) -> None:
        """ωp from the fitted height spectrum's mean frequency, smoothed over fits and kept inside 2–20 s periods."""
        energy = fit.waves.amplitude_m**2
        if energy.sum() <= 0:
            return
        mean = float(np.sum(fit.waves.frequency_rad_s * energy) / energy.sum())
        target = min(max(PEAK_RATIO * mean, 2 * math.pi / 20), 2 * math.pi / 2)
        self._peak += 0.2 * (target - self._peak)

    def _score(self, s: Samples, t: float) -> None:
        """Score every pending fit whose whole horizon has arrived, on the samples after it."""
        keep = []
        for t_fit, fit, (off_n, off_e) in self._pending:
            if t - t_fit < self.s.horizon_s:
                keep.append((t_fit, fit, (off_n, off_e)))
                continue
            after = (s.t > t_fit) & (s.t <= t_fit + self.s.horizon_s)
            if np.count_nonzero(after) < 4:
                continue
            pn, pe, _ = fit.predict(s.t[after], s.north[after], s.east[after])
            mn, me = s.slope_n[after] - off_n, s.slope_e[after] - off_e
            self._skill.add(s.t[after] - t_fit, (pn - mn) ** 2 + (pe - me) ** 2, mn**2 + me**2,
                            self.s.fit_interval_s)
        self._pending = keep

    # ------------------------------------------------------------------ answers
    @property
    def peak_frequency_rad_s(self) -> float:
        """The ωp (rad/s) the prior is centred on."""
        return self._peak

    def skill(self, lead_s: np.ndarray | float) -> np.ndarray:
        """The measured skill of the predictions at lead times (s after the last fit), −inf where unknown."""
        return self._skill.at(np.asarray(lead_s, float))

    def not_confident_because(self, lead_s: float) -> str | None:
        """Why a prediction ``lead_s`` ahead of the last fit should not be used, or None when it may."""
        fit = self._fit
        if fit is None:
            return "no fit yet"
        if lead_s > self.s.horizon_s:
            return f"lead {lead_s:.1f} s beyond the scored horizon {self.s.horizon_s:g} s"
        if self._skill.scored < self.s.min_scored:
            return f"{self._skill.scored} of {self.s.min_scored} fits scored"
        if fit.slope_rms < self.s.min_slope_rad:
            return f"slope RMS {fit.slope_rms:.4f} rad below {self.s.min_slope_rad:g} rad: no sea"
        skill = float(self.skill(lead_s))
        if skill < self.s.min_skill:
            return f"skill {skill:.2f} at {lead_s:.1f} s below {self.s.min_skill:g}"
        return None

    def confident(self, lead_s: float) -> bool:
        """True when a prediction ``lead_s`` seconds ahead of the last fit may be used."""
        return self.not_confident_because(lead_s) is None

    def predict(self, t_s: np.ndarray, north_m: np.ndarray, east_m: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
        """(∂ζ/∂N, ∂ζ/∂E, ζ m, confident) at arrays of autopilot time (s) and NED position (m), e.g. the NMPC's
        planned path; ``confident`` per point (its lead after the last fit). None before the first fit."""
        fit = self._fit
        if fit is None:
            return None
        slope_n, slope_e, zeta = fit.predict(np.asarray(t_s, float), np.asarray(north_m, float),
                                             np.asarray(east_m, float))
        lead = np.broadcast_to(np.asarray(t_s, float), slope_n.shape) - self._fit_t
        bins = np.floor(np.clip(lead, 0.0, None) / LEAD_BIN_S)
        unique, index = np.unique(bins, return_inverse=True)
        ok = np.array([self.confident(float(b) * LEAD_BIN_S) for b in unique], bool)
        return slope_n, slope_e, zeta, ok[index.reshape(bins.shape)] & (lead >= 0)

    def bank_arrays(self, size: int | None = None) -> dict[str, np.ndarray]:
        """The fitted bank as fixed-size arrays for a sum-of-components model (e.g. CasADi parameters): the ``size``
        components of most slope energy — amplitude m, ω rad/s, k rad/m, direction rad NED, phase rad (absolute:
        ζ = Σ a cos(ω t − k (N cos μ + E sin μ) + ε), t in autopilot seconds) — zero-padded (None: all of them)."""
        size = (self._fit.waves.n_components if self._fit is not None else 0) if size is None else size
        out = {name: np.zeros(size) for name in ("amplitude_m", "frequency_rad_s", "wavenumber_rad_m",
                                                   "direction_rad", "phase_rad")}
        if self._fit is None:
            return out
        w = self._fit.waves
        order = np.argsort(-(w.amplitude_m * w.wavenumber_rad_m) ** 2)[:size]
        for name in out:
            out[name][: order.size] = getattr(w, name)[order]
        return out
