"""path.png: a long straight run is drawn as a wide chart, not a sliver under a square colour bar."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from mavbridge.lab.plots import MAX_RATIO, _no_sliver, plot_path
from vessel import RegularWaves


def test_limits_widen_the_short_side_about_its_middle() -> None:
    lo_e, hi_e, lo_n, hi_n = _no_sliver(-15.0, 415.0, -15.0, 15.0)
    assert (lo_e, hi_e) == (-15.0, 415.0)
    assert (hi_e - lo_e) / (hi_n - lo_n) == pytest.approx(MAX_RATIO) and (lo_n + hi_n) / 2 == pytest.approx(0.0)
    assert _no_sliver(0.0, 100.0, 0.0, 80.0) == (0.0, 100.0, 0.0, 80.0)  # near square: as it was
    lo_e, hi_e, lo_n, hi_n = _no_sliver(0.0, 10.0, 0.0, 300.0)
    assert (hi_n - lo_n) / (hi_e - lo_e) == pytest.approx(MAX_RATIO)


def test_a_long_run_across_draws_a_wide_chart(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import matplotlib.pyplot as plt

    figures, close = [], plt.close
    monkeypatch.setattr(plt, "close", figures.append)
    east = np.linspace(0.0, 80.0, 50)
    plot_path(tmp_path / "path.png", np.zeros_like(east), east, (0.0, 400.0), 2.0,
              RegularWaves(1.75, 35.0, 6.0, math.radians(-90.0)), 40.0, "straight")
    (fig,) = figures
    width, height = fig.get_size_inches()
    assert width > 1.5 * height
    close(fig)
