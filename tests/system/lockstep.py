"""Lockstep settings and checks shared by the system tests that compare figures (see test_companion_sitl)."""

from __future__ import annotations

import pytest

from sim_vehicle.harness import SimProcess

# autopilot time from which lockstep runs command: after the companion's startup (16 s wall at 10x: its
# streams, mission, rate measurement and cold solve must be done before it, or it measures the rates of a
# held simulator and meets its first tick with the default stream rates; at 10 s wall a CI run at load 6.7
# on two cores was late), the held first tick waiting 20 s more; and 27 whole periods of the paper's 6 s
# wave, so that the sea (phase from boot) meets the boat as at t = 0 of the in-process runs
START_AT_S = 162.0
# the lockstep tests compare with in-process runs on the true sea: the companion flies on it too
LOCKSTEP = ("--lockstep", "--start-at", str(START_AT_S), "--wave-source", "scenario")
# a tick waits up to 20 s wall (only a hung companion times out; the first tick includes the cold solve);
# from START_AT_S on time is held even before the first command, so the first tick is exactly START_AT_S
SIM_LOCKSTEP = ["--lockstep", "--lockstep-timeout", "20", "--lockstep-start", str(START_AT_S)]


def lockstep_summary(sim: SimProcess) -> str:
    """The simulator's lockstep line (ticks held, timeouts), written at exit."""
    lines = [line for line in sim.stop().splitlines() if "lockstep:" in line and "ticks held" in line]
    assert lines, "sim-vehicle wrote no lockstep summary"
    return lines[-1]


def assert_lockstep_run(metrics: dict, sim: SimProcess, start_at_s: float = START_AT_S) -> None:
    """A lockstep run started at ``start_at_s``, no tick was skipped or timed out, the state acted on was never
    old (time waits for each command: the age is zero by construction, nothing is predicted) and the estimator's
    process, where it has one, gave every answer in time."""
    assert metrics["engaged_at_s"] == pytest.approx(start_at_s, abs=1e-3), metrics
    assert metrics["delay"]["state_age_s_max"] == 0.0 and metrics["delay"]["prediction_s_median"] == 0.0, metrics
    assert metrics["skipped_ticks"] == 0, metrics
    process = metrics["waves"].get("process", {})  # the estimator in its own process: every answer waited for
    assert not any(process.get(k) for k in ("late", "stale", "stopped", "dropped")), process
    summary = lockstep_summary(sim)
    timed_out = int(summary.split(" timed out")[0].rsplit(" ", 1)[-1])
    assert timed_out <= 1, summary  # at most the tick after the companion exited, before the sim was stopped
