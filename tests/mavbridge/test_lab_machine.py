"""The step bench's view of the computer (``mavbridge.lab.machine``): spinners that really spin and really stop,
the collector's passes timed, and the cold factor's two costs measured (their values are the computer's)."""

from __future__ import annotations

import gc
import math
import os
import time

from mavbridge.lab.machine import cold_factor, cold_line, cold_table, collections_timed, spinners


def _cpu_s_of_children() -> float:
    return os.times().children_user + os.times().children_system


def test_spinners_burn_a_cpu_and_are_reaped_after() -> None:
    before = _cpu_s_of_children()
    with spinners(1):  # (it lets the spinner take its CPU for a second first)
        time.sleep(0.3)
    # a child's CPU time is counted once it has been reaped: a spinner that ran for 1.3 s, and was waited for
    assert _cpu_s_of_children() - before > 0.1


def test_every_collection_inside_is_timed_and_none_after() -> None:
    callbacks = len(gc.callbacks)
    with collections_timed() as spans:
        gc.collect()
        gc.collect()
    assert len(spans) >= 2 and all(s >= 0.0 for s in spans)
    before = len(spans)
    gc.collect()
    assert len(spans) == before and len(gc.callbacks) == callbacks  # its callback is gone


def test_the_cold_factor_measures_both_costs() -> None:
    hot, cold = cold_factor(asleep_s=0.002, times=3)
    assert math.isfinite(hot) and math.isfinite(cold) and hot > 0.0 and cold > 0.0
    line = cold_line(asleep_s=0.002)
    assert line.startswith("this computer: ") and "ms asleep" in line and "× hot" in line


def test_the_cold_table_has_a_row_of_three_costs_per_gap() -> None:
    lines = cold_table((0.0002, 0.001))
    assert len(lines) == 3 and lines[0].split()[0] == "gap"
    for line, gap_ms in zip(lines[1:], (0.2, 1.0), strict=True):
        values = [float(v) for v in line.split()]
        assert values[0] == gap_ms and all(math.isfinite(v) and v > 0.0 for v in values[1:])
