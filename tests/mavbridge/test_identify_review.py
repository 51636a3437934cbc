"""What a second reading of identify found: rates that are no gyro's, a base's asymmetry the logs no longer show,
a propeller ratio beyond the model's range."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from mavbridge.identify.analyse import Identification, _rates
from mavbridge.identify.asymmetry import propeller_scale
from mavbridge.identify.estimate import Estimate
from mavbridge.identify.logdata import LogData
from mavbridge.identify.outputs import vessel_fields
from vessel import OtterParameters


def _log(rates: str) -> LogData:
    """A 10 Hz roll decay (1.2 s, ζ 0.15) whose rate columns are a gyro's, or the angles' own differences."""
    t = np.arange(0.0, 20.0, 0.1)
    w = 2 * math.pi / 1.2
    roll = math.radians(3.0) * np.exp(-0.15 * w * t) * np.cos(w * t)
    pitch = 0.3 * roll
    rows = np.zeros((t.size, 7))
    rows[:, 0], rows[:, 1], rows[:, 2] = t, roll, pitch
    if rates == "gyro":
        rows[:, 4], rows[:, 5] = np.gradient(roll, t, edge_order=2), np.gradient(pitch, t, edge_order=2)
    else:  # as a DataFlash reader fills ATTITUDE's rates when no IMU sample is beside the ATT
        rows[1:, 4], rows[1:, 5] = np.diff(roll) / 0.1, np.diff(pitch) / 0.1
    return LogData(Path("x.bin"), "dataflash", "2024-03-22", rows, np.zeros((0, 2)))


def test_rates_made_from_the_angles_are_not_taken_for_a_gyro() -> None:
    assert _rates(_log("gyro")) is not None
    assert _rates(_log("differenced")) is None  # the decays are then looked for in the angle, as before


def _ratio(value: float, low: float, high: float) -> Estimate:
    return Estimate(value, low, high, "", "windows")


def test_a_base_asymmetry_the_logs_no_longer_show_is_written_even() -> None:
    base = OtterParameters().replace(propeller_scale=(1.0, 0.85))  # an earlier vessel.yaml, the prop since cleaned
    result = Identification(estimates={"propeller_thrust_ratio": _ratio(1.001, 0.995, 1.007)})
    assert vessel_fields(base, result)["propeller_scale"] == (1.0, 1.0)
    assert "propeller_scale" not in vessel_fields(OtterParameters(), result)  # an even base: nothing to change


def test_a_ratio_beyond_the_models_range_writes_no_scale() -> None:
    assert propeller_scale(_ratio(0.05, 0.04, 0.06)) is None  # a tenth of the thrust: a fault, not a model
    assert propeller_scale(_ratio(0.85, 0.84, 0.86)) == (1.0, 0.85)


def test_a_nomoto_t_whose_interval_reaches_zero_fits_no_yaw_field() -> None:
    from mavbridge.identify.outputs import unfit_lines, yaw_identified

    loose = Identification(estimates={"yaw_nomoto_time_constant_s": Estimate(0.95, -1.2, 3.1, "s", "zig-zag")})
    tight = Identification(estimates={"yaw_nomoto_time_constant_s": Estimate(0.87, 0.37, 1.37, "s", "zig-zag")})
    assert not yaw_identified(loose) and yaw_identified(tight)
    assert any("yaw_time_constant not put" in line for line in unfit_lines(loose))
    assert not any("yaw_time_constant" in line for line in unfit_lines(tight))


def test_a_nomoto_t_too_short_for_an_interval_is_still_fitted() -> None:
    from mavbridge.identify.outputs import unfit_lines, yaw_identified

    one_block = Identification(estimates={"yaw_nomoto_time_constant_s": Estimate(0.66, math.nan, math.nan, "s", "z")})
    assert yaw_identified(one_block)
    assert not any("yaw_time_constant" in line for line in unfit_lines(one_block))
