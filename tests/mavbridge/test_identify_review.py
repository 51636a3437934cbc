"""What a second reading of identify found: rates that are no gyro's, a base's asymmetry the logs no longer show,
a propeller ratio beyond the model's range; and a third: an asymmetry read from one heading hold (where a steady
wind or current moment looks like a weaker propeller) and from the attitude's differentiated yaw rate."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from mavbridge.identify.analyse import Identification, _rates, frames
from mavbridge.identify.asymmetry import propeller_scale
from mavbridge.identify.commands import identify_propellers
from mavbridge.identify.estimate import Estimate
from mavbridge.identify.logdata import LogData
from mavbridge.identify.outputs import unfit_lines, vessel_fields, yaw_identified
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
    loose = Identification(estimates={"yaw_nomoto_time_constant_s": Estimate(0.95, -1.2, 3.1, "s", "zig-zag")})
    tight = Identification(estimates={"yaw_nomoto_time_constant_s": Estimate(0.87, 0.37, 1.37, "s", "zig-zag")})
    assert not yaw_identified(loose) and yaw_identified(tight)
    assert any("yaw_time_constant not put" in line for line in unfit_lines(loose))
    assert not any("yaw_time_constant" in line for line in unfit_lines(tight))


def _helm_log(holds: list[tuple[float, float]], ratio: float, moment: float, yaw_noise_deg: float = 0.05,
              gyro: bool = True) -> LogData:
    """A 10 Hz log of heading holds, each (seconds, starboard output), separated by 10 s turns at 20°/s: the
    helm gives the port motor what keeps the boat straight, port thrust = ``ratio`` · starboard thrust +
    ``moment`` (a steady wind or current moment held off), as a SERVO_OUTPUT_RAW log holds it; the gyro's yaw
    rate beside the attitude (``gyro``), or none (NaN: a log whose rates are the angles')."""
    rng = np.random.default_rng(11)
    attitude, motors, t, yaw = [], [], 0.0, 0.0
    for seconds, starboard in [(10.0, -1.0), *((s, o) for hold in holds for s, o in (hold, (10.0, -1.0)))]:
        turning = starboard < 0  # (a turn between holds)
        port = 0.5 if turning else math.sqrt(ratio * starboard**2 + moment)
        right = 0.1 if turning else starboard
        for _ in range(round(seconds * 10)):
            rate = math.radians(20.0) if turning else 0.0
            yaw += 0.1 * rate
            noisy = yaw + math.radians(yaw_noise_deg) * rng.normal()
            gyro_rate = rate + math.radians(0.1) * rng.normal() if gyro else math.nan
            attitude.append((t, 0.0, 0.0, noisy, 0.0 if gyro else math.nan, 0.0 if gyro else math.nan, gyro_rate))
            motors.append((t, port + 0.003 * rng.normal(), right + 0.003 * rng.normal()))
            t = round(t + 0.1, 6)
    return LogData(Path("helm.tlog"), "tlog", "2026-12-09", np.array(attitude), np.zeros((0, 2)),
                   {"motors": np.array(motors)})


def _propellers(log: LogData) -> Identification:
    result = Identification()
    identify_propellers([frames(log)], result)
    return result


def test_one_heading_hold_says_the_asymmetry_is_not_identifiable() -> None:
    result = _propellers(_helm_log([(40.0, 0.5)], 0.85, 0.0))
    assert "propeller_thrust_ratio" not in result.estimates
    assert [line for line in result.missing if "one heading hold" in line and "not identifiable" in line]
    assert "propeller_scale" not in vessel_fields(OtterParameters(), result)
    alike = _propellers(_helm_log([(30.0, 0.5), (30.0, 0.52)], 0.85, 0.0))  # two holds at one throttle
    assert "propeller_thrust_ratio" not in alike.estimates
    assert [line for line in alike.missing if "one thrust" in line and "not identifiable" in line]


def test_a_steady_moment_on_an_even_pair_over_two_throttles_is_no_propeller() -> None:
    result = _propellers(_helm_log([(30.0, 0.4), (30.0, 0.7)], 1.0, 0.02))  # a current's moment, props even
    ratio = result.estimates["propeller_thrust_ratio"]
    assert ratio.low <= 1.0 <= ratio.high or abs(ratio.value - 1.0) < 0.02, ratio
    assert "propeller_scale" not in vessel_fields(OtterParameters(), result)
    port_over_starboard = (0.4**2 + 0.02 + 0.7**2 + 0.02) / (0.4**2 + 0.7**2)
    assert port_over_starboard > 1.05  # (what the ratio of the sums, the earlier estimate, took for a propeller)


@pytest.mark.parametrize("moment", [0.0, 0.02])
def test_a_weaker_starboard_propeller_over_two_throttles_is_found_with_or_without_a_moment(moment: float) -> None:
    result = _propellers(_helm_log([(30.0, 0.4), (30.0, 0.7)], 0.85, moment))
    ratio = result.estimates["propeller_thrust_ratio"]
    assert ratio.value == pytest.approx(0.85, abs=0.01) and ratio.high < 0.9, ratio
    assert vessel_fields(OtterParameters(), result)["propeller_scale"] == (1.0, pytest.approx(0.85, abs=0.01))


def test_the_gyros_yaw_rate_is_used_where_the_log_has_it() -> None:
    """An attitude with 1° of noise: its differentiated yaw weaves (a mean |r| near 6°/s), the gyro's does not."""
    holds = [(30.0, 0.4), (30.0, 0.7)]
    assert "propeller_thrust_ratio" in _propellers(_helm_log(holds, 0.85, 0.0, yaw_noise_deg=1.0)).estimates
    weaving = _propellers(_helm_log(holds, 0.85, 0.0, yaw_noise_deg=1.0, gyro=False))
    assert "propeller_thrust_ratio" not in weaving.estimates and weaving.missing


def test_a_nomoto_t_without_an_interval_fits_no_yaw_field_and_says_why() -> None:
    """A T whose log gave fewer than two independent blocks has no interval (nan): nothing says the logs hold
    the yaw's lag, so yaw_time_constant is left as the base's, with a line that says so (not "reaches zero")."""
    one_block = Identification(estimates={"yaw_nomoto_time_constant_s": Estimate(0.66, math.nan, math.nan, "s", "z")})
    assert not yaw_identified(one_block)
    lines = [line for line in unfit_lines(one_block) if "yaw_time_constant" in line]
    assert len(lines) == 1 and "no interval" in lines[0] and "reaches zero" not in lines[0]
