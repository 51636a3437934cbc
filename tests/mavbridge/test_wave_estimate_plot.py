"""The wave estimator's figure over time (``wave_estimate.png``) draws only what the estimator gave.

Before its first fit the rows' wave columns are empty: nothing of the estimate is drawn there and the
confidence reads 0, never the true wave at confidence 1.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from mavbridge.lab.plots import plot_wave_estimate, wave_estimate_series
from mavbridge.waves.source import WaveEstimate
from vessel import RegularWaves

TRUTH = RegularWaves(1.75, 35.0, 6.0, math.radians(-90.0), phase_rad=0.3)
ESTIMATE = WaveEstimate(2.0, 5.8, 40.0, math.radians(-89.0), 0.25, confidence=0.4)


def _rows(first_fit_s: float, t_end_s: float = 4.0, period_s: float = 0.1, empty: object = None) -> list[dict]:
    """Rows of a run on the estimate: the true slope at every step, the estimate from ``first_fit_s`` on, and
    before it the wave columns empty (``empty``: None in memory, "" as read back from the CSV)."""
    rows = []
    for k in range(round(t_end_s / period_s) + 1):
        t = k * period_s
        north, east = 0.0, 1.5 * t
        row = {"t_s": t, "north_m": north, "east_m": east,
               "wave_slope_rad": float(TRUTH.slope_along_travel(north, east, t))}
        estimated = ESTIMATE.row() if t >= first_fit_s - 1e-9 else dict.fromkeys(ESTIMATE.row(), empty)
        rows.append({**row, **estimated})
    return rows


def test_before_the_first_fit_nothing_of_the_estimate_and_confidence_zero() -> None:
    for empty in (None, ""):
        data = wave_estimate_series(_rows(first_fit_s=1.5, empty=empty))
        before = data["t_s"] < 1.5 - 1e-9
        assert before.sum() == 15 and (~before).sum() == 26
        assert data["first_estimate_s"] == 1.5
        for name in ("estimated_slope_deg", "wave_height_m", "wave_period_s", "wave_length_m", "wave_dir_deg"):
            assert np.isnan(data[name][before]).all(), name
            assert np.isfinite(data[name][~before]).all(), name
        assert (data["confidence"][before] == 0.0).all()
        assert np.allclose(data["confidence"][~before], 0.4)  # the estimator's own number, not 1
        assert np.allclose(data["wave_height_m"][~before], 2.0)  # the estimate, not the truth's 1.75
        assert np.isfinite(data["true_slope_deg"]).all()  # the truth is drawn all along


def test_a_run_that_never_fits_draws_no_estimate(tmp_path: Path) -> None:
    data = wave_estimate_series(_rows(first_fit_s=math.inf))
    assert data["first_estimate_s"] is None
    assert np.isnan(data["estimated_slope_deg"]).all() and (data["confidence"] == 0.0).all()
    plot_wave_estimate(tmp_path / "wave_estimate.png", _rows(first_fit_s=math.inf), TRUTH, "never")
    assert (tmp_path / "wave_estimate.png").stat().st_size > 0


def test_the_figure_draws_the_series(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import matplotlib.pyplot as plt

    figures, close = [], plt.close
    monkeypatch.setattr(plt, "close", figures.append)  # keep the figure to read its lines back
    rows = _rows(first_fit_s=1.5)
    plot_wave_estimate(tmp_path / "wave_estimate.png", rows, TRUTH, "late fit")
    (fig,) = figures
    axes = fig.axes
    slope_true, slope_est = axes[0].get_lines()[:2]
    height = axes[1].get_lines()[0].get_ydata()
    confidence = axes[5].get_lines()[0].get_ydata()
    t = axes[5].get_lines()[0].get_xdata()
    before = t < 1.5 - 1e-9
    assert np.isnan(np.asarray(slope_est.get_ydata())[before]).all()
    assert np.isfinite(np.asarray(slope_true.get_ydata())).all()
    assert np.isnan(np.asarray(height)[before]).all() and np.allclose(np.asarray(height)[~before], 2.0)
    assert (np.asarray(confidence)[before] == 0.0).all() and np.allclose(np.asarray(confidence)[~before], 0.4)
    close(fig)
