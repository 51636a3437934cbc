"""The companion's range gate and its loop notices, as functions (the processes are in tests/system/test_safety.py)."""

from __future__ import annotations

import pytest

from mavbridge.companion.engage_gate import WaypointRefusedError, check_waypoints, far_waypoint
from mavbridge.companion.notices import LoopNotices, keep_up_summary
from mavbridge.preflight.cli import add_check_parser
from vessel.geo import DEFAULT_MAX_RANGE_M


def test_within_range_of_home_and_boat_is_flown() -> None:
    assert far_waypoint([(3000.0, 4000.0)], 5000.0, (0.0, 0.0)) is None  # exactly at the limit
    check_waypoints([(10.0, 10.0), (-20.0, 5.0)], 5000.0)


def test_far_from_home_names_the_waypoint_and_the_limit() -> None:
    reason = far_waypoint([(10.0, 0.0), (10_000_000.0, 0.0)], 5000.0)
    assert reason is not None
    assert reason.startswith("waypoint 2 (N 10000000 m, E 0 m) is 10,000.0 km from home")
    assert "farther than --max-range 5000 m" in reason


def test_near_home_but_far_from_the_boat_is_refused() -> None:
    """A boat that drifted (or a home that moved) 6 km off: the waypoint near home is 6 km from the boat."""
    with pytest.raises(WaypointRefusedError, match="from the boat"):
        check_waypoints([(10.0, 0.0)], 5000.0, (6010.0, 0.0))


def test_not_a_number_is_never_in_range() -> None:
    assert far_waypoint([(float("nan"), 0.0)], 5000.0) is not None


def test_the_check_and_the_companion_share_one_default() -> None:
    import argparse

    from mavbridge.companion.config import CompanionConfig

    sub = argparse.ArgumentParser().add_subparsers()
    add_check_parser(sub)
    check_default = sub.choices["check"].get_default("max_range")
    assert check_default == CompanionConfig().max_range_m == DEFAULT_MAX_RANGE_M == 5000.0


def test_notices_are_rate_limited_and_count_what_they_skipped() -> None:
    lines: list[str] = []
    now = [0.0]
    notices = LoopNotices(lines.append, 0, interval_s=10.0, clock=lambda: now[0])
    notices.waiting("")
    notices.waiting("")
    notices.skipped(3, 0.1)
    now[0] = 5.0
    notices.skipped(2, 0.1)  # within 10 s of the last warning: counted, not said
    now[0] = 10.5
    notices.waiting("switch out of it and back")
    notices.skipped(1, 0.1)
    assert lines[0] == "waiting for the pilot to switch to MANUAL (armed)"
    assert lines[1].startswith("warning: the controller cannot keep up: 3 control ticks")
    assert lines[2].endswith("; switch out of it and back")
    assert lines[3].startswith("warning: the controller cannot keep up: 3 control ticks")  # 2 + 1 since then
    assert len(lines) == 4


def test_keep_up_summary() -> None:
    assert keep_up_summary(0, 900) is None
    summary = keep_up_summary(100, 900)
    assert summary is not None and summary.startswith("warning: the controller could not keep up: 100 control "
                                                      "ticks skipped, 10.0 % of the ticks")
    assert keep_up_summary(5, 1500) == "note: 5 control ticks skipped, 0.3 % of the ticks"
    assert keep_up_summary(0, 1000, late=2) == "note: 2 steps past their deadline, 0.2 % of the ticks"
    both = keep_up_summary(10, 990, late=40)
    assert both is not None and both.startswith("warning: the controller could not keep up: 10 control ticks "
                                                "skipped and 40 steps past their deadline, 5.0 % of the ticks")


def test_progress_every_10_s_of_autopilot_time_with_the_largest_roll_so_far() -> None:
    lines: list[str] = []
    notices = LoopNotices(lines.append, 0)
    for step in range(251):  # 25 s of 0.1 s steps; the roll peaks at 0.2 rad at t = 5 s
        t_s = 100.0 + step * 0.1
        notices.progress(t_s, 300.0 - step, 0.2 if step == 50 else 0.01, 2.5)
    assert len(lines) == 2, lines
    assert lines[0] == "t = 110.0 s (autopilot): 200 m to go, max roll so far 11.5 deg, step 2.5 ms"
    assert lines[1].startswith("t = 120.0 s (autopilot): 100 m to go")
