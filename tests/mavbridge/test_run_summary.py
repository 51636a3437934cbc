"""What a user reads about a run (issue 17 item 11): modes by Rover's names, no "None", both clocks named."""

from __future__ import annotations

import pytest
from pymavlink import mavutil

from mavbridge.companion.notices import LoopNotices
from mavbridge.companion.rover_modes import mode_name
from mavbridge.companion.summary import summary_lines, waves_line
from mavbridge.companion.supervisor import Phase, Supervisor

mavlink = mavutil.mavlink

NOTHING_FLOWN = {"avg_roll_deg": None, "max_roll_deg": None, "solve_ms_median": None, "time_to_waypoint_s": None,
                 "engaged_at_s": None, "steps": 0, "skipped_ticks": 0,
                 "waves": {"source": "estimated", "roll_term_fraction": None, "time_to_confident_s": None,
                           "estimator_ms_median": None}}


@pytest.mark.parametrize("number, name", [(mavlink.ROVER_MODE_HOLD, "HOLD"), (mavlink.ROVER_MODE_MANUAL, "MANUAL"),
                                          (mavlink.ROVER_MODE_GUIDED, "GUIDED"), (mavlink.ROVER_MODE_AUTO, "AUTO"),
                                          (mavlink.ROVER_MODE_RTL, "RTL"), (mavlink.ROVER_MODE_LOITER, "LOITER")])
def test_modes_are_named_as_rover_names_them(number: int, name: str) -> None:
    assert mode_name(number) == name


def test_a_number_rover_does_not_have_stays_a_number() -> None:
    assert mode_name(99) == "mode 99"


def test_a_pilot_switching_to_hold_is_reported_as_hold() -> None:
    supervisor = Supervisor(required_mode=mavlink.ROVER_MODE_MANUAL, self_commanded=True)
    assert supervisor.on_heartbeat(0.0, True, mavlink.ROVER_MODE_MANUAL) == Phase.ENGAGED
    assert supervisor.on_heartbeat(1.0, True, mavlink.ROVER_MODE_HOLD) == Phase.TAKEN_OVER
    assert supervisor.reason == "mode changed to HOLD by someone else"


def test_the_wait_for_the_pilot_names_the_mode() -> None:
    lines: list[str] = []
    LoopNotices(lines.append, mavlink.ROVER_MODE_GUIDED).waiting("")
    assert lines == ["waiting for the pilot to switch to GUIDED (armed)"]


def test_a_run_that_never_flew_prints_no_none() -> None:
    lines = summary_lines(NOTHING_FLOWN)
    assert lines == ["waypoint not reached (never engaged)", "waves (estimated): no control step"]
    assert not any("None" in line for line in lines)


def test_arrival_names_both_clocks() -> None:
    engaged, to_go = 45.9, 95.7
    metrics = {**NOTHING_FLOWN, "avg_roll_deg": 1.92, "max_roll_deg": 4.5, "solve_ms_median": 3.2,
               "time_to_waypoint_s": to_go, "engaged_at_s": engaged, "steps": 957,
               "waves": {**NOTHING_FLOWN["waves"], "roll_term_fraction": 0.9, "time_to_confident_s": None}}
    first, waves = summary_lines(metrics)
    assert first.startswith("average roll 1.92 deg, max roll 4.5 deg, solve median 3.2 ms, ")
    assert f"time to waypoint {to_go:g} s (since engaging at t = {engaged:.1f} s, reached at " \
           f"t = {engaged + to_go:.1f} s, autopilot time)" in first
    assert waves == "waves (estimated): roll term on 90 % of the steps, never confident"


def test_the_waves_line_times_confidence_from_the_first_motion_sample() -> None:
    waves = {"source": "estimated", "roll_term_fraction": 1.0, "time_to_confident_s": 0.0,
             "first_sample_at_s": 16.36, "first_confident_at_s": 30.21}
    assert waves_line(waves) == ("waves (estimated): roll term on 100 % of the steps, first confident 13.9 s after "
                                 "its first motion sample (before engaging)")
    late = {**waves, "time_to_confident_s": 4.5, "first_confident_at_s": 50.5}
    assert waves_line(late).endswith("first confident 34.1 s after its first motion sample")
    assert waves_line({"source": "estimated", "time_to_confident_s": 4.5}) == \
        "waves (estimated): first confident 4.5 s after engaging"
    watched_only = {**waves, "roll_term_fraction": 0.996, "time_to_confident_s": None}  # lost before engaging
    assert waves_line(watched_only) == ("waves (estimated): roll term on 99.6 % of the steps, first confident "
                                        "13.9 s after its first motion sample")


def test_an_engaged_run_that_did_not_arrive_says_so() -> None:
    lines = summary_lines({**NOTHING_FLOWN, "avg_roll_deg": 2.0, "engaged_at_s": 10.0, "steps": 5})
    assert lines[0] == "average roll 2 deg, waypoint not reached" and "None" not in " ".join(lines)
