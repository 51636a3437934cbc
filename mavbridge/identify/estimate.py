"""One identified quantity: a value, the interval it lies in, its unit, where it came from and how well it fit.

Intervals are about the estimate (roughly 95 %): the spread of the same estimator over independent stretches of
the log (``block_interval``), or the fit's own covariance when there is one stretch. Every estimator returns
``Estimate`` or ``None`` (with a one-line reason kept by the caller): a missing quantity is a line, never an error.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

Z95 = 1.96


@dataclass(frozen=True)
class Estimate:
    """``value`` in ``unit`` with the interval [low, high]; ``fit`` is the fit figure (R², 1 is perfect)."""

    value: float
    low: float
    high: float
    unit: str
    source: str
    fit: float = math.nan

    def row(self, digits: int = 4) -> dict[str, Any]:
        """For identify.json: {value, low, high, unit, source, fit_r2}."""
        def rounded(x: float) -> float | None:
            return None if not math.isfinite(x) else float(f"{x:.{digits}g}")
        return {"value": rounded(self.value), "low": rounded(self.low), "high": rounded(self.high),
                "unit": self.unit, "source": self.source, "fit_r2": rounded(self.fit)}

    def scaled(self, factor: float, unit: str) -> Estimate:
        """The same estimate in another unit (a positive factor: degrees from radians, rpm from rad/s)."""
        return Estimate(self.value * factor, self.low * factor, self.high * factor, unit, self.source, self.fit)

    def text(self) -> str:
        """'1.23 s [1.18, 1.29]'."""
        return f"{self.value:.3g} {self.unit} [{self.low:.3g}, {self.high:.3g}]"


def spread_interval(value: float, parts: Sequence[float]) -> tuple[float, float]:
    """An interval about ``value`` from estimates over independent stretches: ±1.96 standard errors of their mean
    (never narrower than the stretches' own standard error allows); (nan, nan) with fewer than two."""
    finite = np.asarray([p for p in parts if math.isfinite(p)], float)
    if finite.size < 2:
        return math.nan, math.nan
    half = Z95 * float(np.std(finite, ddof=1)) / math.sqrt(finite.size)
    return value - half, value + half


def covariance_interval(value: float, sd: float) -> tuple[float, float]:
    """value ± 1.96 sd (sd from a fit's covariance)."""
    return value - Z95 * sd, value + Z95 * sd


def weighted_mean(values: Sequence[float], sds: Sequence[float]) -> tuple[float, float]:
    """Inverse-variance mean and its standard deviation, widened by the scatter of the values when that is larger
    (estimates of one quantity that disagree more than their own errors say)."""
    v, s = np.asarray(values, float), np.maximum(np.asarray(sds, float), 1e-12)
    w = 1.0 / s**2
    mean = float(np.sum(w * v) / np.sum(w))
    sd = math.sqrt(1.0 / float(np.sum(w)))
    if v.size > 1:
        scatter = float(np.std(v, ddof=1)) / math.sqrt(v.size)
        sd = max(sd, scatter)
    return mean, sd


def r_squared(y: np.ndarray, fitted: np.ndarray) -> float:
    """1 − SS_res / SS_tot (nan for a constant ``y``)."""
    total = float(np.sum((y - np.mean(y)) ** 2))
    return 1.0 - float(np.sum((y - fitted) ** 2)) / total if total > 0 else math.nan
