"""The sea the companion would have seen: its ``WaveEstimator`` replayed over the log's motion samples.

The estimator is the companion's own (``make_wave_source``: the hull's response calibrated on the vessel
model, the roll sign and GPS lag of the companion's configuration), fed every motion sample in the log's order
and asked, once a second of log time, for its current fit (``latest``), whether it is confident
(``estimate``) and what it sees without a fit (``diagnostics``: the encounter frequency, the lock). Only its
public interface is used. The summary is what a field engineer asks first: was it ever confident, when, and
what did it say then (medians over the confident seconds; the direction as a circular mean).

Nothing is shown that the estimator did not say: without a fit its confidence is NaN (not 0); a log with no
heave (its height never changes) and no acceleration cannot show a sea, and the summary says so (``blind``)
instead of figures; the tracker's encounter period is given only from seconds where it sits clear of its
limits (``LIMIT_MARGIN`` inside the estimator's lowest and highest tracked frequency), and only when most of
them do: a tracker pinned at its ceiling has measured nothing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mavbridge.waves import EstimatorSettings
from mavbridge.waves.source import MotionSample

SERIES_KEYS = ("t_s", "confident", "confidence", "period_s", "dir_deg", "height_m", "length_m",
               "encounter_period_s", "lock")
LIMIT_MARGIN = 0.05  # an encounter frequency within 5 % of the tracker's bounds sits at its limit
HEAVE_SPAN_M = 1e-3  # a height that moves less than this over the log is no heave


@dataclass
class SeaWatch:
    """Feeds a wave source and samples what it says every ``every_s`` of log time."""

    source: Any
    every_s: float = 1.0
    samples: int = 0
    series: list[dict[str, float]] = field(default_factory=list)
    _next_t: float = -math.inf
    _last_t: float | None = None
    _with_accel: int = 0
    _down: list[float] = field(default_factory=lambda: [math.inf, -math.inf])  # lowest and highest down (m)

    def observe(self, sample: MotionSample) -> None:
        """One motion sample (the log's order); a row of the series when one is due."""
        self.source.observe(sample)
        self.samples += 1
        self._with_accel += sample.accel_body is not None
        down = float(sample.position_ned[2])
        self._down = [min(self._down[0], down), max(self._down[1], down)]
        self._last_t = sample.t_s
        if sample.t_s >= self._next_t:
            self._next_t = sample.t_s + self.every_s
            self.series.append(self._row(sample.t_s))

    def _row(self, t: float) -> dict[str, float]:
        latest = self.source.latest(t) if hasattr(self.source, "latest") else None
        confident = self.source.estimate(t) is not None
        seen = self.source.diagnostics() if hasattr(self.source, "diagnostics") else {}
        omega_e = float(seen.get("encounter_freq_rad_s", 0.0) or 0.0)
        row = {"t_s": t, "confident": float(confident), "encounter_period_s": 2 * math.pi / omega_e
               if omega_e > 0 else math.nan, "lock": float(seen.get("lock", math.nan))}
        if latest is None:
            return {**row, "confidence": math.nan, "period_s": math.nan, "dir_deg": math.nan, "height_m": math.nan,
                    "length_m": math.nan}
        return {**row, "confidence": float(latest.confidence), "period_s": float(latest.period_s),
                "dir_deg": math.degrees(latest.travel_dir_rad) % 360.0, "height_m": float(latest.height_m),
                "length_m": float(latest.length_m)}

    def blind(self) -> str | None:
        """Why this log cannot show a sea (None when it can): no heave and no acceleration among its samples."""
        if not self.samples or self._with_accel or self._down[1] - self._down[0] >= HEAVE_SPAN_M:
            return None
        return ("the log holds no heave (its height never changes) and no acceleration: nothing the wave estimator "
                "sees a sea by")

    def column(self, key: str) -> np.ndarray:
        """One column of the series as floats."""
        return np.array([row[key] for row in self.series], float)

    def summary(self) -> dict[str, Any]:
        """Confident share, first confident time, and the medians of what it said while confident."""
        if not self.series:
            return {"samples": self.samples, "confident_fraction": None}
        confident = self.column("confident") > 0.5
        confidence = self.column("confidence")
        out: dict[str, Any] = {"samples": self.samples, "blind": self.blind(),
                               "confident_fraction": round(float(confident.mean()), 4),
                               "solution_fraction": round(float(np.isfinite(self.column("period_s")).mean()), 4),
                               "confidence_max": round(float(np.nanmax(confidence)), 4)
                               if np.isfinite(confidence).any() else None, "first_confident_s": None}
        lock = self.column("lock")
        if np.isfinite(lock).any():
            out["lock_median"] = round(float(np.nanmedian(lock)), 3)
        out.update(tracker(self.column("encounter_period_s")))
        if not confident.any():
            return out
        out["first_confident_s"] = round(float(self.column("t_s")[confident][0]), 2)
        for key in ("period_s", "height_m", "length_m", "confidence"):
            out[f"{key}_median"] = round(float(np.nanmedian(self.column(key)[confident])), 3)
        out.update(circular_mean(self.column("dir_deg")[confident]))
        return out


def tracker(periods: np.ndarray) -> dict[str, Any]:
    """The tracker's encounter period: its median over the seconds clear of its limits, when most are; else
    the share at its limit (said, no period)."""
    settings = EstimatorSettings()
    lo, hi = 2 * math.pi / settings.omega_max_rad_s, 2 * math.pi / settings.omega_min_rad_s
    seen = periods[np.isfinite(periods)]
    if not seen.size:
        return {}
    clear = seen[(seen > lo * (1 + LIMIT_MARGIN)) & (seen < hi * (1 - LIMIT_MARGIN))]
    share = round(1.0 - clear.size / seen.size, 4)
    if clear.size * 2 <= seen.size:
        return {"encounter_at_limit_fraction": share, "encounter_limits_s": [round(lo, 2), round(hi, 2)]}
    return {"encounter_period_s_median": round(float(np.median(clear)), 3), "encounter_at_limit_fraction": share}


def circular_mean(degrees: np.ndarray) -> dict[str, float]:
    """Mean direction (deg, 0..360) and circular spread (deg: √(−2 ln R), R the mean resultant length)."""
    rad = np.radians(degrees[np.isfinite(degrees)])
    sin, cos = float(np.mean(np.sin(rad))), float(np.mean(np.cos(rad)))
    resultant = max(math.hypot(sin, cos), 1e-12)
    return {"dir_deg_mean": round(math.degrees(math.atan2(sin, cos)) % 360.0, 1),
            "dir_spread_deg": round(math.degrees(math.sqrt(max(-2.0 * math.log(resultant), 0.0))), 1)}


def sea_line(summary: dict[str, Any]) -> str:
    """One line of the summary for the terminal (and the page): why there is no sea, or what was seen."""
    fraction = summary.get("confident_fraction")
    if fraction is None:
        return "sea: no motion sample with a position: the estimator saw nothing"
    seen = summary.get("encounter_period_s_median")
    limits = summary.get("encounter_limits_s")
    encounter = (f"; encounter period {seen:.2f} s (median of the tracker)" if seen is not None else
                 f"; the tracker sat at its limits ({limits[0]:g}-{limits[1]:g} s) in "
                 f"{100 * summary['encounter_at_limit_fraction']:.0f} % of the seconds: no encounter period"
                 if limits else "")
    if summary.get("blind"):
        return f"sea: not shown: {summary['blind']}{encounter}"
    if summary.get("first_confident_s") is None:
        top = summary.get("confidence_max")
        return (f"sea: never confident (quiet: no wave to plan against; a wave solved in "
                f"{100 * summary['solution_fraction']:.0f} % of the seconds"
                + (f", confidence at most {top:.2f})" if top is not None else ")") + encounter)
    return (f"sea: confident {100 * fraction:.0f} % of the time (first at t = {summary['first_confident_s']:.1f} s): "
            f"period {summary['period_s_median']:.2f} s, towards {summary['dir_deg_mean']:.0f} deg "
            f"(spread {summary['dir_spread_deg']:.0f} deg), height {summary['height_m_median']:.2f} m, "
            f"length {summary['length_m_median']:.1f} m, confidence {summary['confidence_median']:.2f} "
            f"(medians while confident){encounter}")
