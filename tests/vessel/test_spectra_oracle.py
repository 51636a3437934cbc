"""Our JONSWAP / Pierson–Moskowitz against wavespectra's, a well-kept wave library (test-only oracle).

wavespectra is heavy (xarray, pandas, SciPy; ≈ 2 min and 470 MB to install here), so it is not in the test
extra: this module is skipped unless it is installed. wavespectra works in hertz (m²/Hz) and rescales to
the requested Hs over the frequency grid it is given; S(ω) = S(f) / 2π.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from vessel.sea.spectra import jonswap

frequency = pytest.importorskip("wavespectra.construct.frequency")

FREQ_HZ = np.linspace(0.005, 10.0, 200_000)


@pytest.mark.parametrize(("hs", "tp", "gamma"), [(1.75, 6.0, 3.3), (1.75, 6.0, 1.0), (4.0, 10.0, 2.0),
                                                 (0.5, 3.0, 7.0)])
def test_jonswap_matches_wavespectra(hs: float, tp: float, gamma: float) -> None:
    theirs = np.asarray(frequency.jonswap(FREQ_HZ, fp=1 / tp, gamma=gamma, hs=hs)) / (2 * math.pi)
    ours = jonswap(2 * math.pi * FREQ_HZ, hs, tp, gamma)
    near = ours > 1e-3 * ours.max()
    np.testing.assert_allclose(ours[near], theirs[near], rtol=1e-6)  # agreed to 5e-8 with wavespectra 4.9.0
