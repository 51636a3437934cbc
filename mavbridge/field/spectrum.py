"""The roll spectrum of a trial: Welch's average of Hann-windowed periodograms, over the stretches without gaps.

The attitude samples are put on a uniform grid at their median rate (linear interpolation) within each
stretch where no two samples are more than ``MAX_GAP_FACTOR`` median intervals (and ``MAX_GAP_S``) apart;
windows of up to ``WINDOW_S`` (never longer than the longest stretch, never shorter than ``MIN_WINDOW_S``)
overlap by half, each with its linear trend removed. The density is one-sided, in deg²/Hz, so that its
integral is the roll variance. The peak is looked for above ``MIN_PEAK_HZ`` (a period of 12.5 s: slower
"roll" is the boat's heel in its turns, not the sea).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

WINDOW_S = 64.0
MIN_WINDOW_S = 8.0
MAX_GAP_FACTOR = 3.0
MAX_GAP_S = 0.5  # a 9 Hz log repeats its last sample for a few tenths of a second: not a gap to break on
MIN_PEAK_HZ = 0.08


@dataclass(frozen=True)
class Spectrum:
    """One-sided roll power spectral density and its peak."""

    freq_hz: np.ndarray
    psd_deg2_hz: np.ndarray
    rate_hz: float
    window_s: float
    windows: int
    peak_hz: float | None

    def row(self) -> dict[str, object]:
        """For report.json."""
        return {"rate_hz": round(self.rate_hz, 3), "window_s": round(self.window_s, 2), "windows": self.windows,
                "peak_hz": None if self.peak_hz is None else round(self.peak_hz, 4),
                "peak_period_s": None if not self.peak_hz else round(1.0 / self.peak_hz, 3),
                "freq_hz": [round(float(f), 4) for f in self.freq_hz],
                "psd_deg2_hz": [float(f"{p:.4g}") for p in self.psd_deg2_hz]}


def stretches(t: np.ndarray, dt: float) -> list[tuple[int, int]]:
    """(start, stop) index ranges of ``t`` without a gap longer than MAX_GAP_FACTOR·dt and MAX_GAP_S."""
    breaks = np.flatnonzero(np.diff(t) > max(MAX_GAP_FACTOR * dt, MAX_GAP_S)) + 1
    edges = [0, *breaks.tolist(), t.size]
    return [(a, b) for a, b in itertools.pairwise(edges) if b - a > 1]


def roll_spectrum(t: np.ndarray, roll_deg: np.ndarray) -> Spectrum | None:
    """Welch's roll PSD (see the module docstring); None when no stretch is MIN_WINDOW_S long."""
    gaps = np.diff(t)
    gaps = gaps[gaps > 0]
    if gaps.size < 8:
        return None
    dt = float(np.median(gaps))
    parts = stretches(t, dt)
    longest = max(t[b - 1] - t[a] for a, b in parts)
    window_s = min(WINDOW_S, float(longest))
    if window_s < MIN_WINDOW_S:
        return None
    n = int(window_s / dt)
    taper = np.hanning(n)
    scale = 2.0 * dt / float(np.sum(taper**2))
    ramp = np.linspace(-1.0, 1.0, n)
    total, count = np.zeros(n // 2 + 1), 0
    for a, b in parts:
        if t[b - 1] - t[a] < window_s:
            continue
        grid = np.arange(t[a], t[b - 1], dt)
        series = np.interp(grid, t[a:b], roll_deg[a:b])
        for start in range(0, grid.size - n + 1, max(n // 2, 1)):
            chunk = series[start:start + n]
            trend = chunk.mean() + ramp * (np.dot(chunk, ramp) / np.dot(ramp, ramp))
            total += np.abs(np.fft.rfft((chunk - trend) * taper)) ** 2 * scale
            count += 1
    if not count:
        return None
    freq, psd = np.fft.rfftfreq(n, dt), total / count
    above = freq >= MIN_PEAK_HZ
    peak = float(freq[above][np.argmax(psd[above])]) if above.any() and psd[above].max() > 0 else None
    return Spectrum(freq, psd, 1.0 / dt, n * dt, count, peak)
