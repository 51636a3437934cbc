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
``skill_memory_s`` of autopilot time) says how far ahead it can be trusted. A bin becomes trusted at ``min_skill`` +
``skill_margin`` and stays so until its skill falls below ``min_skill`` (a pooled skill near one threshold would
flicker), and a lead is trusted only when every shorter one is. ``confident(lead)`` is False (the controller keeps
its statistics term) before ``min_scored`` fits are scored, beyond the horizon, when the last fit is stale (the
later ones failed), when the slope less the channels' noise is below ``min_slope_rad`` (calm water) or when the
skill is not trusted. Bad input (NaN, time not increasing) is skipped with a reason; a clock that goes back by
more than 5 s, or a silence longer than the window, restarts the window. A fit costs tens of milliseconds (a
40 s window, up to 140 frequencies each way): a control loop runs it off its own thread.
"""

from __future__ import annotations

import math

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
from mavbridge.waves.phase.skill import LEAD_BIN_S, PredictorSettings, Skill
from mavbridge.waves.source import MotionSample
from mavbridge.waves.window_buffer import down_acceleration

FIELDS = ("t", "north", "east", "slope_n", "slope_e", "heave", "accel")
CLOCK_BACK_S = 5.0  # a clock going back by more than this is a reboot: the window belongs to the old clock
PEAK_RATIO = 0.8  # ωp ≈ this × the fitted mean frequency m1/m0 (0.77 Pierson–Moskowitz, 0.83 JONSWAP γ 3.3)


class PhasePredictor:
    """Short-term phase-resolved wave prediction from the boat's own motion (see the module docstring)."""

    def __init__(self, settings: PredictorSettings | None = None) -> None:
        self.s = settings or PredictorSettings()
        self._rows: dict[str, list[float]] = {key: [] for key in FIELDS}
        self._fit: BankFit | None = None
        self._fit_t = -math.inf  # the autopilot time the current fit ends at (its leads count from here)
        self._next_fit_t = -math.inf  # when the next fit is due
        self._pending: list[tuple[float, BankFit, tuple[float, float]]] = []  # fits not yet scored, with offsets
        self._skill = self._new_skill()
        self._last_sample_t = -math.inf
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
            self._skip(reason)
            return reason
        for key, value in zip(FIELDS, (t_s, north_m, east_m, slope_n, slope_e, heave_m, accel_down_mps2),
                              strict=True):
            self._rows[key].append(float(value))
        self._last_sample_t = t_s
        if t_s >= self._next_fit_t:
            self._next_fit_t = t_s + self.s.fit_interval_s
            self._refit(t_s)
        return None

    def _new_skill(self) -> Skill:
        return Skill(math.ceil(self.s.horizon_s / LEAD_BIN_S), self.s.skill_memory_s,
                      self.s.min_skill + self.s.skill_margin, self.s.min_skill)

    def _skip(self, reason: str) -> None:
        self.skipped[reason] = self.skipped.get(reason, 0) + 1

    def observe_attitude(self, t_s: float, north_m: float, east_m: float, roll: float, pitch: float, yaw: float,
                         heave_m: float = math.nan, accel_down_mps2: float = math.nan) -> str | None:
        """``observe`` with the slope read from the attitude (rad) as the window estimator reads it."""
        slope_n, slope_e = slope_from_attitude(roll, pitch, yaw, self.s.roll_sign)
        return self.observe(t_s, north_m, east_m, float(slope_n), float(slope_e), heave_m, accel_down_mps2)

    def observe_sample(self, sample: MotionSample) -> str | None:
        """``observe_attitude`` from what the autopilot streams (ATTITUDE, position, the IMU's heave if streamed)."""
        att, pos = np.asarray(sample.attitude, float), np.asarray(sample.position_ned, float)
        if att.shape != (3,) or pos.shape != (3,):
            self._skip("malformed sample")
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
        self._fit, self._fit_t, self._next_fit_t, self._pending = None, -math.inf, -math.inf, []
        self._skill = self._new_skill()

    # ------------------------------------------------------------------ fitting
    def _window(self, t_s: float) -> Samples | None:
        """The last ``window_s`` seconds up to ``t_s`` (older rows are dropped), thinned to ``rate_hz``; None with
        under 4 s of them."""
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

    def _refit(self, t: float) -> None:
        """A new fit on the window ending at ``t``; past fits whose horizon has passed are scored first."""
        s = self._window(t)
        if s is None:
            return
        self._score(s, t)
        fit, notes = fit_window(s, self.s, self._peak)
        for note in notes:
            self._skip(note)
        if fit is None:
            self._skip("fit failed (the last fit is kept and ages)")
            return
        self._fit, self._fit_t = fit, t
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
            self._skill.add(t_fit, s.t[after] - t_fit, (pn - mn) ** 2 + (pe - me) ** 2, mn**2 + me**2)
        self._pending = keep

    # ------------------------------------------------------------------ answers
    @property
    def fit_time_s(self) -> float:
        """The autopilot time (s) the current fit ends at: leads count from here (−inf before the first fit)."""
        return self._fit_t

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
        age = self._last_sample_t - self._fit_t
        if age > self.s.fit_interval_s + LEAD_BIN_S:
            return f"the last fit is {age:.1f} s old (later fits failed)"
        if self._skill.scored < self.s.min_scored:
            return f"{self._skill.scored} of {self.s.min_scored} fits scored"
        wave_rms = math.sqrt(max(fit.slope_rms**2 - 2 * self.s.slope_noise_rad**2, 0.0))  # less the channels' noise
        if wave_rms < self.s.min_slope_rad:
            return f"slope RMS {wave_rms:.4f} rad (less noise) below {self.s.min_slope_rad:g} rad: no sea"
        if not self._skill.trusted_to(lead_s):
            skill = float(np.min(self.skill(np.arange(0.0, lead_s + 1e-9, LEAD_BIN_S))))
            return (f"skill {skill:.2f} up to {lead_s:.1f} s not trusted (on at {self._skill.trust_on:.2f}, "
                    f"off below {self._skill.trust_off:.2f})")
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
        inside = (lead >= 0) & (lead <= self.s.horizon_s)  # the bin's start may be inside while the lead is not
        return slope_n, slope_e, zeta, ok[index.reshape(bins.shape)] & inside

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


def principal_axis(s: Samples) -> list[float]:
    """The principal axis of the measured slope (rad NED), both ways along it."""
    sn, se = s.slope_n - s.slope_n.mean(), s.slope_e - s.slope_e.mean()
    axis = 0.5 * math.atan2(2 * float(sn @ se), float(sn @ sn - se @ se))
    return [axis, axis + math.pi]


def window_bank(s: Samples, settings: PredictorSettings, directions: list[float], notes: list[str]) -> Bank:
    """The bank for the window: as many frequencies as its span resolves in the encounter domain at its speed
    (capped at ``max_frequencies``: a coarser grid, said in ``notes``), at each of ``directions``."""
    band = settings.band_rad_s
    needed = frequencies_needed(band, float(s.t[-1] - s.t[0]), math.hypot(*mean_velocity(s)))
    if needed > settings.max_frequencies:
        notes.append("frequency grid capped (coarser than the window resolves)")
    return make_bank(band, min(needed, settings.max_frequencies), directions, settings.depth_m)


def fit_window(s: Samples, settings: PredictorSettings, peak_rad_s: float) -> tuple[BankFit | None, list[str]]:
    """Both ways along the slope's axis, then (when one way carries over three quarters of the energy) that way with
    its fan; with what went wrong on the way (for the predictor's ``skipped``)."""
    notes: list[str] = []
    noise = {"slope_n": settings.slope_noise_rad, "slope_e": settings.slope_noise_rad}
    axis = principal_axis(s)
    bank = window_bank(s, settings, axis, notes)
    fit = fit_bank(bank, s, settings.ridge, noise=noise, prior=spectral_prior(bank, peak_rad_s))
    if fit is None:
        return None, notes
    energy = (fit.waves.amplitude_m * fit.waves.wavenumber_rad_m) ** 2
    ahead = float(energy[0::2].sum()) / max(float(energy.sum()), 1e-30)
    mixed = 0.25 <= ahead <= 0.75
    if mixed and len(settings.fan_deg) == 1:
        return fit, notes
    main = axis[0] if ahead > 0.5 else axis[1]
    sides = [a + math.radians(d) for a in (axis if mixed else [main]) for d in settings.fan_deg]
    bank = window_bank(s, settings, sides, notes)
    one_way = fit_bank(bank, s, settings.ridge, noise=noise, prior=spectral_prior(bank, peak_rad_s))
    if one_way is None:
        notes.append("one-way fit failed (both ways kept)")
    return one_way or fit, notes
