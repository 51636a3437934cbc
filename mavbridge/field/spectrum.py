"""The roll spectrum of a trial: Welch's average of Hann-windowed periodograms, over the stretches without gaps.

The attitude samples are put on a uniform grid at their median rate (linear interpolation) within each
stretch where no two samples are more than ``MAX_GAP_FACTOR`` median intervals (and ``MAX_GAP_S``) apart: a gap
is not interpolated across. The window is the longest of ``WINDOW_S``, its half, quarter ... (never shorter
than ``MIN_WINDOW_S``) that covers nearly as much of the log (``COVER_SHARE``) as the shortest would: a log cut
into short stretches by gaps is still used, at a coarser resolution. Windows overlap by half, the last one of a
stretch ends at its end, each has its linear trend removed. The density is one-sided, in deg²/Hz, so that its
integral is the roll variance. The peak is looked for above ``MIN_PEAK_HZ`` (a period of 12.5 s: slower
"roll" is the boat's heel in its turns, not the sea). ``Spectrum.used`` says which stretches were used, and
why the rest was not (gaps, stretches shorter than the window).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from mavbridge.field.logs import plural

WINDOW_S = 64.0
MIN_WINDOW_S = 8.0
MAX_GAP_FACTOR = 3.0
MAX_GAP_S = 0.5  # a 9 Hz log repeats its last sample for a few tenths of a second: not a gap to break on
MIN_PEAK_HZ = 0.08
COVER_SHARE = 0.9  # a longer window is taken while it covers at least this share of what the shortest covers


@dataclass(frozen=True)
class Spectrum:
    """One-sided roll power spectral density and its peak, and what of the log it is made of."""

    freq_hz: np.ndarray
    psd_deg2_hz: np.ndarray
    rate_hz: float
    window_s: float
    windows: int
    peak_hz: float | None
    stretches: tuple[tuple[float, float], ...] = ()  # (start, end) s of the stretches used
    log_s: float = 0.0  # from the first attitude sample to the last
    gaps: tuple[float, ...] = ()  # the gaps (s) the stretches are cut by
    short_s: float = 0.0  # time in stretches shorter than the window

    @property
    def used_s(self) -> float:
        """Seconds of the log the windows cover."""
        return float(sum(b - a for a, b in self.stretches))

    def used(self) -> str:
        """Which parts of the log the spectrum is made of, and why not the rest."""
        spans = ", ".join(f"{a:.1f}-{b:.1f}" for a, b in self.stretches[:4]) + (", ..." if len(self.stretches) > 4
                                                                                 else "")
        text = (f"{plural(self.windows, 'window')} of {self.window_s:.0f} s over "
                f"{plural(len(self.stretches), 'stretch', 'stretches')} (t {spans} s): "
                f"{self.used_s:.0f} s of {self.log_s:.0f} s")
        why = []
        if self.gaps:
            why.append(f"{plural(len(self.gaps), 'gap')} over {MAX_GAP_S:g} s between attitude samples "
                       f"({sum(self.gaps):.0f} s, the longest {max(self.gaps):.1f} s; not interpolated across)")
        if self.short_s > 0.05:
            why.append(f"{self.short_s:.0f} s in stretches shorter than the window")
        return text + ("; left out: " + " and ".join(why) if why else "")

    def row(self) -> dict[str, object]:
        """For report.json."""
        return {"rate_hz": round(self.rate_hz, 3), "window_s": round(self.window_s, 2), "windows": self.windows,
                "peak_hz": None if self.peak_hz is None else round(self.peak_hz, 4),
                "peak_period_s": None if not self.peak_hz else round(1.0 / self.peak_hz, 3),
                "stretches_s": [[round(a, 2), round(b, 2)] for a, b in self.stretches],
                "used_s": round(self.used_s, 2), "log_s": round(self.log_s, 2), "used": self.used(),
                "freq_hz": [round(float(f), 4) for f in self.freq_hz],
                "psd_deg2_hz": [float(f"{p:.4g}") for p in self.psd_deg2_hz]}


def stretches(t: np.ndarray, dt: float) -> list[tuple[int, int]]:
    """(start, stop) index ranges of ``t`` without a gap longer than MAX_GAP_FACTOR·dt and MAX_GAP_S."""
    breaks = np.flatnonzero(np.diff(t) > max(MAX_GAP_FACTOR * dt, MAX_GAP_S)) + 1
    edges = [0, *breaks.tolist(), t.size]
    return [(a, b) for a, b in itertools.pairwise(edges) if b - a > 1]


def choose_window(lengths: list[float]) -> float | None:
    """The longest window (WINDOW_S halved down to MIN_WINDOW_S) covering COVER_SHARE of what the shortest
    covers of stretches of ``lengths`` (s); None when no stretch is MIN_WINDOW_S long."""
    windows = []
    w = WINDOW_S
    while w >= MIN_WINDOW_S:
        windows.append(w)
        w /= 2
    cover = {w: sum(x for x in lengths if x >= w) for w in windows}
    best = max(cover.values())
    if best <= 0:
        return None
    return next(w for w in windows if cover[w] >= COVER_SHARE * best)


def _starts(size: int, n: int) -> list[int]:
    """Window starts over ``size`` grid points: every half window, and one ending at the stretch's end."""
    starts = list(range(0, size - n + 1, max(n // 2, 1)))
    if starts and starts[-1] != size - n:
        starts.append(size - n)
    return starts


def roll_spectrum(t: np.ndarray, roll_deg: np.ndarray) -> Spectrum | None:
    """Welch's roll PSD (see the module docstring); None when no stretch is MIN_WINDOW_S long."""
    gaps = np.diff(t)
    gaps = gaps[gaps > 0]
    if gaps.size < 8:
        return None
    dt = float(np.median(gaps))
    parts = stretches(t, dt)
    lengths = [float(t[b - 1] - t[a]) for a, b in parts]
    window_s = choose_window(lengths)
    if window_s is None:
        return None
    n = int(window_s / dt)
    taper = np.hanning(n)
    scale = 2.0 * dt / float(np.sum(taper**2))
    ramp = np.linspace(-1.0, 1.0, n)
    total, count, used = np.zeros(n // 2 + 1), 0, []
    for (a, b), length in zip(parts, lengths, strict=True):
        grid = np.arange(t[a], t[b - 1], dt)
        if length < window_s or grid.size < n:
            continue
        series = np.interp(grid, t[a:b], roll_deg[a:b])
        used.append((float(t[a]), float(t[b - 1])))
        for start in _starts(grid.size, n):
            chunk = series[start:start + n]
            trend = chunk.mean() + ramp * (np.dot(chunk, ramp) / np.dot(ramp, ramp))
            total += np.abs(np.fft.rfft((chunk - trend) * taper)) ** 2 * scale
            count += 1
    if not count:
        return None
    freq, psd = np.fft.rfftfreq(n, dt), total / count
    above = freq >= MIN_PEAK_HZ
    peak = float(freq[above][np.argmax(psd[above])]) if above.any() and psd[above].max() > 0 else None
    cuts = np.diff(t)[np.diff(t) > max(MAX_GAP_FACTOR * dt, MAX_GAP_S)]
    short = sum(x for x in lengths if x < window_s)
    return Spectrum(freq, psd, 1.0 / dt, n * dt, count, peak, tuple(used), float(t[-1] - t[0]),
                    tuple(float(g) for g in cuts), short)
