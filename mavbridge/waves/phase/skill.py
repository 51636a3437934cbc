"""What the phase predictor fits and when it is trusted: its settings (checked against their ranges) and the
measured skill of its past predictions per lead-time bin, with hysteresis (see ``predictor``'s docstring)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

LEAD_BIN_S = 1.0  # the skill is kept per lead-time bin of this width


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
    skill_margin: float = 0.1  # hysteresis: a lead bin becomes trusted at min_skill + this, stops below min_skill

    def __post_init__(self) -> None:
        """Every number inside the range it works in; one ValueError naming the field and the range."""
        for name, low, high in RANGES:
            value = getattr(self, name)
            if not low <= value <= high:
                raise ValueError(f"PredictorSettings.{name} = {value!r}: allowed {low:g} to {high:g}")
        low, high = self.band_rad_s
        if not 0.0 < low < high <= 20.0:
            raise ValueError(f"PredictorSettings.band_rad_s = {self.band_rad_s!r}: allowed 0 < low < high <= 20 rad/s")
        if self.window_s < 2 * self.horizon_s:
            raise ValueError(f"PredictorSettings.window_s = {self.window_s!r}: allowed at least twice horizon_s")


RANGES = (("window_s", 8.0, 600.0), ("fit_interval_s", 0.1, 60.0), ("rate_hz", 1.0, 100.0),
          ("max_frequencies", 2, 1000), ("ridge", 1e-12, 1e6), ("slope_noise_rad", 1e-6, 1.0),
          ("horizon_s", LEAD_BIN_S, 60.0), ("min_skill", -1.0, 1.0), ("min_slope_rad", 0.0, 1.0),
          ("skill_memory_s", 1.0, 3600.0), ("min_scored", 1, 1000), ("skill_margin", 0.0, 1.0))


@dataclass
class Skill:
    """Forgetting sums of error and signal power per lead-time bin of past fits' predictions."""

    bins: int
    memory_s: float
    trust_on: float  # a bin becomes trusted when its skill reaches this ...
    trust_off: float  # ... and stays so until it falls below this (no flicker around one threshold)
    error: np.ndarray = field(init=False)
    signal: np.ndarray = field(init=False)
    trusted: np.ndarray = field(init=False)
    scored: int = 0
    last_t: float | None = None

    def __post_init__(self) -> None:
        self.error, self.signal = np.zeros(self.bins), np.zeros(self.bins)
        self.trusted = np.zeros(self.bins, bool)

    def add(self, t_fit: float, lead: np.ndarray, err2: np.ndarray, sig2: np.ndarray) -> None:
        """One scored fit (made at ``t_fit``): per sample its lead (s), squared error and squared signal (rad²).
        The sums decay by the time since the previous scored fit (a gap ages them as much as it lasted)."""
        decay = 1.0 if self.last_t is None else math.exp(-max(t_fit - self.last_t, 0.0) / self.memory_s)
        self.last_t = t_fit
        index = np.minimum((lead / LEAD_BIN_S).astype(int), self.bins - 1)
        self.error = self.error * decay + np.bincount(index, err2, self.bins)
        self.signal = self.signal * decay + np.bincount(index, sig2, self.bins)
        self.scored += 1
        skill = self.at(np.arange(self.bins) * LEAD_BIN_S)
        self.trusted = np.where(self.trusted, skill >= self.trust_off, skill >= self.trust_on)

    def trusted_to(self, lead_s: float) -> bool:
        """Every bin from 0 to ``lead_s`` trusted (a prediction is no better far ahead than nearer)."""
        last = min(int(lead_s / LEAD_BIN_S), self.bins - 1)
        return bool(np.all(self.trusted[: last + 1]))

    def at(self, lead_s: np.ndarray) -> np.ndarray:
        """Skill (≤ 1; 0 = no better than predicting zero) at lead times (s), −inf in an unscored bin."""
        index = np.clip((np.asarray(lead_s, float) / LEAD_BIN_S).astype(int), 0, self.bins - 1)
        with np.errstate(divide="ignore", invalid="ignore"):
            skill = np.where(self.signal > 0, 1.0 - self.error / self.signal, -np.inf)
        return skill[index]
