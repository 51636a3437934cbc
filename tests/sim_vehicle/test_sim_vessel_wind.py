"""`sim-vehicle --vessel` (a boat that is not the model) and ArduPilot SITL's SIM_WIND_* parameters."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import pytest

from sim_vehicle.harness import SimProcess
from tests.waits import wait_for


def _sim_cli(*args: str) -> subprocess.CompletedProcess[str]:
    """sim-vehicle with no ports, for 0.1 s of simulated time."""
    return subprocess.run([sys.executable, "-m", "sim_vehicle.cli", "--no-tcp", "--no-out", "--duration", "0.1",
                           *args], capture_output=True, text=True, timeout=60)


def test_vessel_flag_sets_the_plant_over_the_scenario(tmp_path: Path) -> None:
    boat = tmp_path / "heavy.yaml"
    boat.write_text("base: corrected\npayload_mass: 55\npropeller_scale: [1.0, 0.85]\n")
    out = _sim_cli("--sea", "calm", "--vessel", str(boat), "--log-dir", str(tmp_path / "logs"))
    assert out.returncode == 0, out.stderr
    sea = json.loads((tmp_path / "logs" / "sea.json").read_text())
    assert sea["vessel"] == {"base": "corrected", "payload_mass": 55.0, "propeller_scale": [1.0, 0.85]}


@pytest.mark.parametrize(("vessel", "expected"), [
    ("missing.yaml", "--vessel: 'missing.yaml' is neither a named set (published, corrected) nor a readable"),
    ("bad", "bad.yaml.zeta_roll: 5 is outside the allowed range [0, 2]"),
])
def test_bad_vessel_flags_are_one_line(tmp_path: Path, vessel: str, expected: str) -> None:
    (tmp_path / "bad.yaml").write_text("zeta_roll: 5\n")
    path = str(tmp_path / "bad.yaml") if vessel == "bad" else vessel
    out = _sim_cli("--vessel", path, "--log-dir", str(tmp_path / "logs"))
    assert out.returncode == 2 and len(out.stderr.strip().splitlines()) == 1 and expected in out.stderr
    assert not (tmp_path / "logs").exists()


def _rows(path: Path) -> list[dict[str, float]]:
    with path.open() as stream:
        return [{k: float(v) for k, v in row.items() if k in ("t_s", "east_m", "roll_rad")}
                for row in csv.DictReader(stream)]


def test_the_scenarios_wind_seeds_sim_wind_and_a_param_set_changes_it_in_flight(tmp_path: Path) -> None:
    scenario = tmp_path / "s.yaml"
    scenario.write_text("sea: {height_m: 0, wind_speed_mps: 4, wind_from_deg: 90}\nstart: {heading_deg: 0}\n")
    with SimProcess(tmp_path / "sim", speedup=10, waves=None, extra=["--scenario", str(scenario)]) as sim:
        conn = sim.connect()
        conn.mav.param_request_read_send(1, 1, b"SIM_WIND_SPD", -1)
        assert wait_for(conn, "PARAM_VALUE", 5, lambda m: m.param_id == "SIM_WIND_SPD").param_value == 4.0
        before = wait_for(conn, "ATTITUDE", 30, lambda m: m.time_boot_ms >= 3000).time_boot_ms / 1000.0
        conn.mav.param_set_send(1, 1, b"SIM_WIND_SPD", 12.0, 9)
        assert wait_for(conn, "PARAM_VALUE", 5, lambda m: m.param_id == "SIM_WIND_SPD").param_value == 12.0
        set_at = wait_for(conn, "ATTITUDE", 10).time_boot_ms / 1000.0
        wait_for(conn, "ATTITUDE", 60, lambda m: m.time_boot_ms / 1000.0 > set_at + 6.0)
    rows = _rows(sim.log_dir / "state.csv")

    def east_speed(t0: float, t1: float) -> float:
        inside = [r for r in rows if t0 <= r["t_s"] <= t1]
        return (inside[-1]["east_m"] - inside[0]["east_m"]) / (inside[-1]["t_s"] - inside[0]["t_s"])

    slow = east_speed(before - 3.0, before)
    fast = east_speed(set_at + 3.0, set_at + 6.0)
    assert slow < 0 and fast < 2 * slow  # blown West by the 4 m/s wind from the start, faster once it is 12 m/s
