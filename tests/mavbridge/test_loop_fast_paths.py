"""The realistic loop's fast paths: the hull calibration measured once per configuration; finite()."""

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


def test_finite_reads_arrays_and_sequences_alike() -> None:
    import math

    import numpy as np

    from mavbridge.waves.filters import finite

    assert finite(np.array([1.5, -2.0, 3.0, 9.0]), 3) == (1.5, -2.0, 3.0)
    assert finite(np.array([1.5, -2.0, 3.0], np.float32), 2) == (1.5, -2.0)
    assert finite([1, 2, 3], 3) == (1.0, 2.0, 3.0) and finite(np.array([1, 2]), 2) == (1.0, 2.0)
    assert finite(np.array([1.0, 2.0]), 3) is None and finite([1.0], 2) is None and finite(None, 1) is None
    assert finite(np.array([1.0, math.nan, 2.0]), 3) is None and finite((1.0, math.inf), 2) is None
    assert finite(np.array([1.0, math.nan]), 1) == (1.0,)  # only the first n count
    assert finite(np.array([1e308, 1e308]), 2) == (1e308, 1e308)  # finite, though their sum overflows
    assert finite(np.zeros((2, 3)), 2) is None  # rows are no numbers
    assert all(type(v) is float for v in finite(np.array([1.0, 2.0]), 2) or ())
