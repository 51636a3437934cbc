"""The sea the companion would have seen: its ``WaveEstimator`` replayed over the log's motion samples.

The estimator is the companion's own (``make_wave_source``: the hull's response calibrated on the vessel
model, the roll sign and GPS lag of the companion's configuration), fed every motion sample in the log's order
and asked, once a second of log time, for its current fit (``latest``), whether it is confident
(``estimate``) and what it sees without a fit (``diagnostics``: the encounter frequency, the lock). Only its
public interface is used. The summary is what a field engineer asks first: was it ever confident, when, and
what did it say then (medians over the confident seconds; the direction as a circular mean).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mavbridge.waves.source import MotionSample

SERIES_KEYS = ("t_s", "confident", "confidence", "period_s", "dir_deg", "height_m", "length_m",
               "encounter_period_s", "lock")


@dataclass
class SeaWatch:
    """Feeds a wave source and samples what it says every ``every_s`` of log time."""

    source: Any
    every_s: float = 1.0
    samples: int = 0
    series: list[dict[str, float]] = field(default_factory=list)
    _next_t: float = -math.inf
    _last_t: float | None = None

    def observe(self, sample: MotionSample) -> None:
        """One motion sample (the log's order); a row of the series when one is due."""
        self.source.observe(sample)
        self.samples += 1
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
            return {**row, "confidence": 0.0, "period_s": math.nan, "dir_deg": math.nan, "height_m": math.nan,
                    "length_m": math.nan}
        return {**row, "confidence": float(latest.confidence), "period_s": float(latest.period_s),
                "dir_deg": math.degrees(latest.travel_dir_rad) % 360.0, "height_m": float(latest.height_m),
                "length_m": float(latest.length_m)}

    def column(self, key: str) -> np.ndarray:
        """One column of the series as floats."""
        return np.array([row[key] for row in self.series], float)

    def summary(self) -> dict[str, Any]:
        """Confident share, first confident time, and the medians of what it said while confident."""
        if not self.series:
            return {"samples": self.samples, "confident_fraction": None}
        confident = self.column("confident") > 0.5
        out: dict[str, Any] = {"samples": self.samples, "confident_fraction": round(float(confident.mean()), 4),
                               "solution_fraction": round(float(np.isfinite(self.column("period_s")).mean()), 4),
                               "confidence_max": round(float(np.max(self.column("confidence"))), 4),
                               "first_confident_s": None}
        for key in ("encounter_period_s", "lock"):
            values = self.column(key)
            if np.isfinite(values).any():
                out[f"{key}_median"] = round(float(np.nanmedian(values)), 3)
        if not confident.any():
            return out
        out["first_confident_s"] = round(float(self.column("t_s")[confident][0]), 2)
        for key in ("period_s", "height_m", "length_m", "confidence"):
            out[f"{key}_median"] = round(float(np.nanmedian(self.column(key)[confident])), 3)
        out.update(circular_mean(self.column("dir_deg")[confident]))
        return out


def circular_mean(degrees: np.ndarray) -> dict[str, float]:
    """Mean direction (deg, 0..360) and circular spread (deg: √(−2 ln R), R the mean resultant length)."""
    rad = np.radians(degrees[np.isfinite(degrees)])
    sin, cos = float(np.mean(np.sin(rad))), float(np.mean(np.cos(rad)))
    resultant = max(math.hypot(sin, cos), 1e-12)
    return {"dir_deg_mean": round(math.degrees(math.atan2(sin, cos)) % 360.0, 1),
            "dir_spread_deg": round(math.degrees(math.sqrt(max(-2.0 * math.log(resultant), 0.0))), 1)}


def sea_line(summary: dict[str, Any]) -> str:
    """One line of the summary for the terminal."""
    fraction = summary.get("confident_fraction")
    if fraction is None:
        return "sea: no motion sample with a position: the estimator saw nothing"
    seen = summary.get("encounter_period_s_median")
    encounter = f"; encounter period {seen:.2f} s (median of the tracker)" if seen is not None else ""
    if summary.get("first_confident_s") is None:
        return (f"sea: never confident (quiet: no wave to plan against; a wave solved in "
                f"{100 * summary['solution_fraction']:.0f} % of the seconds, confidence at most "
                f"{summary['confidence_max']:.2f}){encounter}")
    return (f"sea: confident {100 * fraction:.0f} % of the time (first at t = {summary['first_confident_s']:.1f} s): "
            f"period {summary['period_s_median']:.2f} s, towards {summary['dir_deg_mean']:.0f} deg "
            f"(spread {summary['dir_spread_deg']:.0f} deg), height {summary['height_m_median']:.2f} m, "
            f"length {summary['length_m_median']:.1f} m, confidence {summary['confidence_median']:.2f} "
            f"(medians while confident){encounter}")
