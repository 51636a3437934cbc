"""A companion whose startup ends after the lockstep start says so: the rates it measured are of a held simulator.

`sim-vehicle --lockstep --lockstep-start S` holds simulated time at S until the controller's first command.
A companion that is still starting up then (streams, mission, the rate measurement) measures the held
simulator's repeats, not its streams; it must say so in its log (and go on: the run is valid, only not
comparable with one whose startup ended in time), naming the flag to raise.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from sim_vehicle.harness import SimProcess

HOME = "--home=-35.363261,149.165230,584,90"
pytestmark = pytest.mark.slow


def test_a_startup_after_the_lockstep_start_is_said(tmp_path: Path) -> None:
    # the start at 0.1 s is passed long before any companion is up: time is held there from its start
    with SimProcess(tmp_path / "sim", speedup=1, waves="paper", udp_outs=1,
                    extra=[HOME, "--wipe", "--lockstep", "--lockstep-timeout", "5", "--lockstep-start", "0.1"]) as sim:
        cmd = [sys.executable, "-m", "mavbridge.cli", "run", "--connect", f"udpin:127.0.0.1:{sim.udp_ports[0]}",
               "--solver", "asrti", "--wave-source", "scenario", "--arm", "--set-mode", "--out", str(tmp_path / "run"),
               "--waypoint", "85,75", "--lockstep", "--start-at", "0.1", "--max-time", "1"]
        try:
            done = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
        except subprocess.TimeoutExpired as exc:
            raise AssertionError(f"mavbridge run did not finish within 300 s:\n{exc.stdout}") from None
    text = done.stdout + done.stderr
    assert done.returncode == 0, text[-3000:]  # a valid run, only not comparable
    warnings = [line for line in text.splitlines() if "autopilot's clock advanced" in line]
    assert len(warnings) == 1, text[-3000:]
    assert "--start-at" in warnings[0] and "lockstep" in warnings[0], warnings[0]
