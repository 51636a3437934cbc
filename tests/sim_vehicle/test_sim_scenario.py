"""`sim-vehicle --scenario`: the sea, vessel and start of a scenario file drive the simulator."""

from __future__ import annotations

import csv
import math
import subprocess
import sys
from pathlib import Path

import pytest

from sim_vehicle.harness import SimProcess
from sim_vehicle.scenario import load_sim_scenario
from tests.waits import wait_for
from vessel import ConfigError

ROOT = Path(__file__).resolve().parents[2]


def test_scenario_sets_sea_heading_and_a_negative_home_needs_no_equals_sign(tmp_path: Path) -> None:
    scenario = tmp_path / "s.yaml"
    scenario.write_text("vessel: corrected\nsea: {height_m: 1.0, length_m: 30.0, period_s: 5.0, travel_dir_deg: 0}\n"
                        "start: {heading_deg: 45.0, surge_mps: 1.0}\ncontroller: {q: 5}\n")
    with SimProcess(tmp_path / "sim", speedup=10, waves=None, extra=["--scenario", str(scenario), "--home",
                                                           "-35.363261,149.165230,584,353", "--wipe"]) as sim:
        conn = sim.connect()
        attitude = wait_for(conn, "ATTITUDE", 10)
        position = wait_for(conn, "GLOBAL_POSITION_INT", 10)
        assert position.lat / 1e7 == pytest.approx(-35.3632, abs=1e-3)  # the negative latitude was taken
    with (sim.log_dir / "state.csv").open() as stream:
        rows = list(csv.DictReader(stream))
    # Simulated time runs from the start, not from when this client connected (a busy machine connects
    # later, and the waves have turned the boat by then): read each pose at a known simulated time.
    assert float(rows[0]["t_s"]) == 0.0 and math.degrees(float(rows[0]["yaw_rad"])) == pytest.approx(45.0)
    plant_yaw = {round(float(r["t_s"]) * 1000): float(r["yaw_rad"]) for r in rows}[attitude.time_boot_ms]
    assert math.remainder(attitude.yaw - plant_yaw, 2 * math.pi) == pytest.approx(0.0, abs=1e-6)
    slopes = [abs(float(r["wave_slope_rad"])) for r in rows[:300]]
    assert max(slopes) == pytest.approx(math.atan(math.pi * 1.0 / 30.0), rel=0.05)  # the scenario's waves
    assert float(rows[1]["u_m_s"]) > 0.9  # the scenario's start speed


def test_the_paper_scenarios_load_for_the_simulator() -> None:
    balanced = load_sim_scenario(ROOT / "scenarios" / "balanced.yaml")
    assert balanced.sea.height_m == 1.75 and balanced.start.heading_deg == 90.0
    with pytest.raises(ConfigError, match="single-run"):
        load_sim_scenario(ROOT / "scenarios" / "table3.yaml")


@pytest.mark.parametrize(("text", "expected"), [("sea: {height_m: -1}\n", "sea.height_m"),
                                                ("start: {heading_deg: 400}\n", "start.heading_deg"),
                                                ("vessel: heavy\n", "vessel")])
def test_bad_scenario_is_one_line_exit_2(tmp_path: Path, text: str, expected: str) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    out = subprocess.run([sys.executable, "-m", "sim_vehicle.cli", "--scenario", str(path), "--no-tcp", "--no-out",
                          "--duration", "0.1"], capture_output=True, text=True, timeout=60)
    assert out.returncode == 2 and len(out.stderr.strip().splitlines()) == 1 and expected in out.stderr
