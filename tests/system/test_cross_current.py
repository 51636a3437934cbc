"""A current across the path that nobody tells the companion: `mavbridge demo` paced, as a user runs it, over MAVLink.

The simulator's sea carries 0.5 m/s towards 130° (across the line from the start to the waypoint, 41°); the
companion is told nothing of it (its scenario sections are the controller and the mission; it never reads the
sea). It learns the current from the boat's own motion before and while engaged, and the boat neither crabs off
nor circles the waypoint."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = [pytest.mark.slow, pytest.mark.integration]

SCENARIO = """name: cross
vessel: published
sea: {height_m: 1.75, length_m: 35.0, period_s: 6.0, travel_dir_deg: -90.0, current_speed_mps: 0.5,
      current_dir_deg: 130.0}
start: {north_m: 0.0, east_m: 0.0, heading_deg: 90.0, surge_mps: 0.0}
waypoint: {north_m: 85.0, east_m: 75.0, acceptance_radius_m: 2.0}
t_max_s: 240.0
controller: {q: 5, r: 1550, s: 2, solver: nrti}
"""


def test_a_cross_current_it_is_not_told_is_learnt_and_the_boat_arrives_without_a_loop(tmp_path: Path) -> None:
    (tmp_path / "cross.yaml").write_text(SCENARIO)
    run = tmp_path / "run"
    done = subprocess.run([sys.executable, "-m", "mavbridge.cli", "demo", "--scenario", str(tmp_path / "cross.yaml"),
                           "--out", str(run)], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    metrics = json.loads((run / "companion" / "metrics.json").read_text())
    assert metrics["phase"] == "ARRIVED", metrics
    assert metrics["overshoot_m"] < 25.0 and metrics["loops_around_waypoint"] < 1.0, metrics
    learnt = metrics["disturbance"]
    truth = 0.5 * math.cos(math.radians(130.0)), 0.5 * math.sin(math.radians(130.0))
    error = math.hypot(learnt["current_north_m_s"] - truth[0], learnt["current_east_m_s"] - truth[1])
    assert error < 0.15 and learnt["settled_at_s"] is not None, learnt  # (when it settles depends on how soon the
    # wave estimate is confident: before it, the waves' forces are in every error and weigh less)
    assert "disturbance settled at t = " in done.stdout and "current 0." in done.stdout
    assert "model: published (the hull the NMPC predicts with" in done.stdout
