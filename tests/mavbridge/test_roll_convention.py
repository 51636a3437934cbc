"""One roll convention (issue 35): ``roll_sign`` says which way the hull rolls with the slope, the calibrated
``roll_phase_deg`` is only the hull's lag, and the estimate carries the sign to the NMPC's prediction."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from mavbridge.companion.wave_gate import make_wave_source
from mavbridge.waves import EstimatorSettings, WindowEstimator, make_estimator
from mavbridge.waves.inloop import calibrated_settings
from mavbridge.waves.kinematic import KinematicBoat, motion_samples, paper_sea
from mavbridge.waves.settings import METHODS
from vessel import otter_parameters
from vessel.config import ConfigError


@pytest.mark.parametrize("roll_sign", [1.0, -1.0])
def test_calibration_measures_a_lag_not_a_sign(roll_sign: float) -> None:
    """Either sign: the model hull rolls that way in the lab sea, so gain ≈ 1 and |phase| is a lag (< 30°)."""
    s = calibrated_settings(otter_parameters(), True, roll_sign)
    assert s.roll_sign == roll_sign
    assert 0.8 < s.roll_gain < 1.25 and abs(s.roll_phase_deg) < 30.0, (s.roll_gain, s.roll_phase_deg)
    assert 0.7 < s.pitch_gain < 1.3 and abs(s.pitch_phase_deg) < 40.0


def test_a_sign_said_as_a_phase_is_refused_with_the_fix() -> None:
    """A phase beyond ±90° is a reversed sign: refused with a line that names roll_sign as the fix."""
    with pytest.raises(ConfigError, match=r"roll_phase_deg: 179\.6 is outside the allowed range \[-90, 90\] deg; "
                                          r"a phase beyond ±90° is a reversed sign.*wave_roll_sign"):
        EstimatorSettings(roll_phase_deg=179.6)
    assert EstimatorSettings(roll_phase_deg=-89.0, roll_sign=-1.0).roll_phase_deg == -89.0


def test_the_boats_wave_source_builds_with_a_geometric_hull() -> None:
    """What `deploy/companion-boat.yaml` asks for (wave_roll_sign −1) builds: it was refused at start before."""
    source = make_wave_source("estimated", None, -1.0, 0.0, otter_parameters())
    assert isinstance(source, WindowEstimator) and source.s.roll_sign == -1.0
    assert abs(source.s.roll_phase_deg) < 30.0


@pytest.mark.parametrize("method", METHODS)
def test_a_geometric_hull_read_with_its_sign_finds_the_wave_and_predicts_its_roll(method: str) -> None:
    """A point riding a regular sea that rolls it geometrically (−1), read with roll_sign −1: the estimate's
    direction is the true one, and its field rolls the hull with the same sign, as the boat does (both
    estimators)."""
    sea = dataclasses.replace(paper_sea(0.7), paper_roll_sign=False)
    heading = math.radians(45.0)
    boat = KinematicBoat(sea, 1.5, lambda t: heading, roll_sign=-1.0)
    estimator = make_estimator(EstimatorSettings(roll_sign=-1.0, method=method))
    estimate = None
    for sample in motion_samples(boat, 40.0, seed=3, t0=500.0):
        estimator.observe(sample)
        estimate = estimator.estimate(sample.t_s) or estimate
    assert estimate is not None, "no confident estimate in 40 s"
    error = math.degrees(math.remainder(estimate.travel_dir_rad - sea.travel_dir_rad, 2 * math.pi))
    assert abs(error) < 10.0, f"direction off by {error:.1f} deg"
    assert estimate.roll_sign == -1.0 and estimate.field().roll_sign == -1.0
    read_as_paper = make_estimator(EstimatorSettings(roll_sign=1.0, method=method))
    mirrored = None
    for sample in motion_samples(boat, 40.0, seed=3, t0=500.0):
        read_as_paper.observe(sample)
        mirrored = read_as_paper.estimate(sample.t_s) or mirrored
    assert mirrored is not None  # read with the wrong sign the wave is mirrored about the hull's axis
    wrong = math.degrees(math.remainder(mirrored.travel_dir_rad - sea.travel_dir_rad, 2 * math.pi))
    assert abs(wrong) > 45.0, wrong
    assert np.isfinite(estimate.phase_rad)
