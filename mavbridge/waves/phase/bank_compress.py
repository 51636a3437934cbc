"""A fitted wave bank of many components squeezed into the K the NMPC's model carries, over its horizon only.

``PhasePredictor`` fits a bank of 50–280 components; the NMPC's model holds K (8–32) of them. The K of most slope
energy (``bank_arrays``) hold only a small share of an irregular sea's slope: in the 200-component JONSWAP sea of
``scenarios/jonswap_estimated.yaml`` the 12 strongest true components carry 14 % of the slope variance, 64 carry
52 %, because the slope spectrum ω⁴S(ω) is broad. But the model needs the sea only over its horizon (a few
seconds) and near the path it can sail in that time, and over so short a stretch of time and space neighbouring
components cannot be told apart: K free waves on an even frequency grid, in the sea's dominant direction, fitted
by least squares to the bank's own predicted slope over that region, reproduce nearly all of it.

``compress(waves, K, t0, north, east, speed, horizon)``: the region is times t0 … t0 + horizon (every
``STEP_S``) and, along the dominant direction μ, the positions the boat could reach by then (s0 ± (speed·τ + 1 m)),
the same everywhere across μ (long-crested). Returns ``bank_arrays``-style arrays with absolute phases and the
share of the predicted slope variance over the region the K components explain.
"""

from __future__ import annotations

import math

import numpy as np

from mavbridge.waves.phase.bank import Samples, fit_bank, make_bank
from vessel.sea.irregular import IrregularWaves

STEP_S = 0.1  # the region's time step (the NMPC's period)
OFFSETS = 7  # positions across the reachable stretch at each time
MARGIN_M = 1.0  # reach beyond speed × lead (the hull's own length, a turn's sway)
RIDGE = 1e-6  # relative ridge of the compression fit (the grid is well conditioned; this only guards it)


def dominant_direction(waves: IrregularWaves) -> float:
    """The travel direction (rad NED) of the components that carry most slope energy, among the bank's directions."""
    energy = (waves.amplitude_m * waves.wavenumber_rad_m) ** 2
    directions = np.round(np.asarray(waves.direction_rad, float), 9)
    unique = np.unique(directions)
    totals = [float(energy[directions == d].sum()) for d in unique]
    return float(unique[int(np.argmax(totals))])


def region(waves: IrregularWaves, t0: float, north: float, east: float, speed: float, horizon: float,
           direction: float) -> Samples:
    """The bank's predicted slope over the times and reachable positions of the horizon (see the module docstring)."""
    leads = np.arange(0.0, horizon + 1e-9, STEP_S)
    reach = speed * leads + MARGIN_M
    frac = np.linspace(-1.0, 1.0, OFFSETS)
    along = np.multiply.outer(reach, frac).ravel()
    t = np.repeat(t0 + leads, OFFSETS)
    n, e = north + along * math.cos(direction), east + along * math.sin(direction)
    slope_n, slope_e = waves.gradient(n, e, t)
    nan = np.full(t.size, math.nan)
    return Samples(t, n, e, np.asarray(slope_n, float), np.asarray(slope_e, float), nan, nan)


def compress(waves: IrregularWaves, components: int, t0: float, north: float, east: float, speed: float,
             horizon: float, band_rad_s: tuple[float, float]) -> tuple[dict[str, np.ndarray], float] | None:
    """K components over ``band_rad_s`` in the dominant direction fitted to ``waves``' slope over the horizon's
    reachable region: (arrays as ``PhasePredictor.bank_arrays``, share of the region's slope variance explained);
    None when the region has no slope."""
    direction = dominant_direction(waves)
    s = region(waves, t0, north, east, speed, horizon, direction)
    bank = make_bank(band_rad_s, components, [direction])
    fit = fit_bank(bank, s, RIDGE)
    if fit is None or fit.slope_rms <= 0:
        return None
    w = fit.waves
    arrays = {name: np.asarray(getattr(w, name), float).copy() for name in
              ("amplitude_m", "frequency_rad_s", "wavenumber_rad_m", "direction_rad", "phase_rad")}
    return arrays, float(fit.slope_explained)
