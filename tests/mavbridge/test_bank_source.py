"""The phase bank's source side: compressing a fitted bank into the NMPC's K components, and the smoothed track."""

from __future__ import annotations

import math

import numpy as np

from mavbridge.waves.phase.bank_compress import compress, dominant_direction
from mavbridge.waves.phase.bank_source import DeadReckonedTrack, strongest
from vessel.sea.irregular import IrregularWaves, synthesise


def _field(arrays: dict[str, np.ndarray]) -> IrregularWaves:
    return IrregularWaves(arrays["amplitude_m"], arrays["frequency_rad_s"], arrays["wavenumber_rad_m"],
                          arrays["direction_rad"], arrays["phase_rad"])


def _skill(model: IrregularWaves, truth: IrregularWaves, n: np.ndarray, e: np.ndarray, t: np.ndarray) -> float:
    g, want = np.stack(model.gradient(n, e, t)), np.stack(truth.gradient(n, e, t))
    return 1.0 - float(np.sum((g - want) ** 2) / np.sum(want**2))


def test_twelve_compressed_components_hold_a_broad_sea_over_the_horizon_where_the_strongest_twelve_do_not() -> None:
    """A 200-component JONSWAP sea, a 4 s path at 1.5 m/s 50° off the waves: the compressed 12 predict its slope,
    the 12 of most slope energy barely."""
    sea = synthesise("jonswap", 1.75, 6.0, 3.3, math.radians(-90.0), 0.0, 200, seed=3)
    assert abs(dominant_direction(sea) - math.radians(-90.0)) < 1e-9
    t0, north, east = 120.0, 30.0, 12.0
    tau = np.arange(0.0, 4.01, 0.1)
    heading = math.radians(220.0)
    n, e = north + 1.5 * tau * math.cos(heading), east + 1.5 * tau * math.sin(heading)
    squeezed = compress(sea, 12, t0, north, east, 1.5, 4.0, (0.4, 4.5))
    assert squeezed is not None
    arrays, share = squeezed
    assert arrays["amplitude_m"].shape == (12,) and share > 0.98
    assert _skill(_field(arrays), sea, n, e, t0 + tau) > 0.95
    assert _skill(_field(strongest(sea, 12)), sea, n, e, t0 + tau) < 0.5


def test_the_dead_reckoned_track_is_smoother_than_the_fixes() -> None:
    """Straight at 1.5 m/s with 0.3 m white noise on each fix: three pull times on, the track is within a third of
    it (the first fix it was anchored on is forgotten, the fixes are averaged)."""
    rng = np.random.default_rng(5)
    track = DeadReckonedTrack(lag_s=0.0)
    errors = []
    for i in range(2400):
        t = i * 0.05
        true = np.array([1.5 * t, 0.2 * t])
        fix = true + rng.normal(0.0, 0.3, 2)
        north, east = track.update(t, fix, np.array([1.5, 0.2]))
        if t > 90.0:
            errors.append(math.hypot(north - true[0], east - true[1]))
    assert float(np.sqrt(np.mean(np.square(errors)))) < 0.1
