"""What a wave record says about its sea: Hm0, an averaged periodogram (Welch), the peak period, autocorrelation.

numpy only (no SciPy dependency). Spectra are one-sided in angular frequency, S(ω) in m²·s/rad, the
same convention as ``vessel.sea.spectra``, so a record's spectrum can be laid over its target directly.
"""

from __future__ import annotations

import math

import numpy as np


def hm0(record: np.ndarray) -> float:
    """Spectral significant height 4·√m0 in m, m0 the variance of the (mean-removed) record."""
    return 4.0 * math.sqrt(float(np.var(np.asarray(record, float))))


def default_segment(samples: int) -> int:
    """Welch segment length: the largest power of two not above a quarter of the record (at least 16)."""
    return max(16, 1 << (max(samples // 4, 16).bit_length() - 1))


def welch(record: np.ndarray, dt: float, segment: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(ω in rad/s, S(ω) in m²·s/rad): mean of Hann-windowed periodograms of half-overlapping segments.

    One-sided (DC and Nyquist bins not doubled) and scaled so that Σ S·Δω equals the record's variance
    (up to the window's leakage). The frequency bins are Δω = 2π/(segment·dt) apart.
    """
    x = np.asarray(record, float)
    n = segment or default_segment(x.size)
    if n > x.size:
        raise ValueError(f"record of {x.size} samples is shorter than one Welch segment of {n}")
    window = np.hanning(n + 1)[:-1]  # periodic Hann
    step = n // 2
    starts = range(0, x.size - n + 1, step)
    power = np.zeros(n // 2 + 1)
    for start in starts:
        seg = x[start:start + n]
        spectrum = np.fft.rfft((seg - seg.mean()) * window)
        power += np.abs(spectrum) ** 2
    power /= len(starts)
    density_hz = power * dt / np.sum(window**2)  # two-sided density per Hz
    density_hz[1:-1 if n % 2 == 0 else None] *= 2.0
    omega = 2 * math.pi * np.fft.rfftfreq(n, dt)
    return omega, density_hz / (2 * math.pi)


def peak_period(omega: np.ndarray, density: np.ndarray) -> float:
    """2π / (the frequency of the largest density value), in s (ω = 0 excluded)."""
    i = 1 + int(np.argmax(density[1:]))
    return 2 * math.pi / float(omega[i])


def autocorrelation(record: np.ndarray) -> np.ndarray:
    """Normalised autocorrelation R(τ)/R(0) for lags 0 … n−1 samples (biased estimator, via FFT)."""
    x = np.asarray(record, float) - float(np.mean(record))
    size = 1 << (2 * x.size - 1).bit_length()
    f = np.fft.rfft(x, size)
    acf = np.fft.irfft(np.abs(f) ** 2, size)[:x.size]
    return acf / acf[0]
