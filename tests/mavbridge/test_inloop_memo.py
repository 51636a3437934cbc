"""The realistic loop's per-process memo: the hull calibration is measured once per configuration."""

from __future__ import annotations

import dataclasses

from mavbridge.waves.inloop import calibrated_settings
from vessel.params import otter_parameters


def test_calibration_is_measured_once_per_configuration() -> None:
    params = otter_parameters()
    calibrated_settings.cache_clear()
    first = calibrated_settings(params, True, 1.0)
    assert calibrated_settings(dataclasses.replace(params), True, 1.0) is first  # an equal configuration: the memo
    assert calibrated_settings.cache_info().hits == 1
    other = calibrated_settings(params, True, -1.0)  # another roll sign is another measurement
    assert other is not first and other.roll_sign == -1.0
    assert calibrated_settings.cache_info().misses == 2
