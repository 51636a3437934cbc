"""`sim-vehicle --scenario/--sea`: one world, read by the one loader that mavbridge uses too."""

from __future__ import annotations

import csv
import math
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from mavbridge.lab.scenario import Scenario, load_scenarios
from sim_vehicle.harness import SimProcess
from sim_vehicle.scenario import sim_world
from tests.waits import wait_for
from vessel import ConfigError
from vessel.geo import Home
from vessel.world import SEA_PRESETS, World, load_world

ROOT = Path(__file__).resolve().parents[2]


def _sim_cli(*args: str) -> subprocess.CompletedProcess[str]:
    """sim-vehicle with no ports, for 0.1 s of simulated time."""
    return subprocess.run([sys.executable, "-m", "sim_vehicle.cli", "--no-tcp", "--no-out", "--duration", "0.1",
                           *args], capture_output=True, text=True, timeout=60)


def test_scenario_sets_sea_heading_and_a_negative_home_needs_no_equals_sign(tmp_path: Path) -> None:
    scenario = tmp_path / "s.yaml"
    scenario.write_text("vessel: corrected\nsea: {height_m: 1.0, length_m: 30.0, period_s: 5.0, travel_dir_deg: 0}\n"
                        "start: {heading_deg: 45.0, surge_mps: 1.0}\ncontroller: {q: 5}\n")
    with SimProcess(tmp_path / "sim", speedup=10, waves=None, extra=["--scenario", str(scenario), "--home",
                                                           "-35.363261,149.165230,584,353", "--wipe"]) as sim:
        conn = sim.connect()
        attitude = wait_for(conn, "ATTITUDE", 10)
        position = wait_for(conn, "GLOBAL_POSITION_INT", 10)
        assert position is not None, "no GLOBAL_POSITION_INT within 10 s"
        assert position.lat / 1e7 == pytest.approx(-35.3632, abs=1e-3)  # the negative latitude was taken
    with (sim.log_dir / "state.csv").open() as stream:
        rows = list(csv.DictReader(stream))
    # Simulated time runs from the start, not from when this client connected (a busy machine connects
    # later, and the waves have turned the boat by then): read each pose at a known simulated time.
    assert float(rows[0]["t_s"]) == 0.0 and math.degrees(float(rows[0]["yaw_rad"])) == pytest.approx(45.0)
    assert float(rows[0]["u_m_s"]) == pytest.approx(1.0, abs=0.05)  # the scenario's start speed
    plant_yaw = {round(float(r["t_s"]) * 1000): float(r["yaw_rad"]) for r in rows}[attitude.time_boot_ms]
    assert math.remainder(attitude.yaw - plant_yaw, 2 * math.pi) == pytest.approx(0.0, abs=1e-6)
    slopes = [abs(float(r["wave_slope_rad"])) for r in rows[:300]]
    assert max(slopes) == pytest.approx(math.atan(math.pi * 1.0 / 30.0), rel=0.05)  # the scenario's waves


def test_the_paper_scenarios_load_for_the_simulator() -> None:
    balanced = load_world(ROOT / "scenarios" / "balanced.yaml")
    assert balanced.sea == SEA_PRESETS["paper"] and balanced.start.heading_deg == 90.0
    with pytest.raises(ConfigError, match="single-run"):
        load_world(ROOT / "scenarios" / "table3.yaml")


def test_waves_flag_scenario_default_and_demo_share_the_preset_object() -> None:
    """`--sea paper`, a scenario's `sea: paper` and the companion's default scenario: the same object."""
    assert sim_world(None, "paper", None, Home()).sea == SEA_PRESETS["paper"]
    assert sim_world(None, None, None, Home()).sea is SEA_PRESETS["calm"]
    assert Scenario().sea is SEA_PRESETS["paper"] and World().sea is SEA_PRESETS["paper"]
    paper = SEA_PRESETS["paper"]
    assert (paper.height_m, paper.length_m, paper.period_s, paper.travel_dir_deg) == (1.75, 35.0, 6.0, -90.0)
    assert SEA_PRESETS["calm"].height_m == 0.0


def test_flags_over_a_scenario_replace_only_their_part(tmp_path: Path) -> None:
    path = tmp_path / "s.yaml"
    path.write_text("sea: {height_m: 1.0, current_speed_mps: 0.4, current_dir_deg: 30}\nstart: {heading_deg: 10}\n")
    world = sim_world(path, "calm", None, Home())
    assert world.sea.height_m == 0.0 and world.sea.current_speed_mps == 0.4  # --sea NAME keeps the current
    world = sim_world(path, "0.5,20,4,45", "0.1,-90", Home())
    assert (world.sea.height_m, world.sea.travel_dir_deg, world.sea.current_dir_deg) == (0.5, 45.0, -90.0)
    assert world.start.heading_deg == 10.0
    assert sim_world(None, None, None, Home(heading_deg=200.0)).start.heading_deg == 200.0


def test_sea_literal_yaml_preset_name(tmp_path: Path) -> None:
    path = tmp_path / "s.yaml"
    path.write_text("sea: calm\nwaypoint: {north_m: 10, east_m: 0}\n")
    assert load_world(path).sea is SEA_PRESETS["calm"]
    (scenario,) = load_scenarios(path)
    assert scenario.sea == SEA_PRESETS["calm"]
    path.write_text("sea: stormy\n")
    with pytest.raises(ConfigError, match=r"sea: 'stormy' is not one of paper, calm"):
        load_world(path)


@pytest.mark.parametrize(("text", "expected"), [
    ("sea: {height_m: -1}\n", "sea.height_m"),
    ("start: {heading_deg: 400}\n", "start.heading_deg"),
    ("vessel: heavy\n", "vessel"),
    ("sae: {height_m: 1.0}\n", "unknown key 'sae'"),
    ("waypont: {north_m: 10}\n", "unknown key 'waypont'"),
    ("", "empty scenario file"),
    ("{}\n", "empty scenario file"),
    ("sea: {height_m: 10, length_m: 35}\n", "sea.height_m"),  # breaks: H/λ > 1/7
])
def test_one_rule_for_both_loaders(tmp_path: Path, text: str, expected: str) -> None:
    """The simulator and mavbridge reject the same file with the same one-line message (the simulator's names the
    flag that gave the file first), exit 2."""
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    out = _sim_cli("--scenario", str(path))
    assert out.returncode == 2 and len(out.stderr.strip().splitlines()) == 1 and expected in out.stderr
    assert "Traceback" not in out.stderr
    with pytest.raises(ConfigError) as info:
        load_scenarios(path)
    assert expected in str(info.value)
    assert out.stderr.strip() == f"sim-vehicle: error: --scenario: {info.value}"


@pytest.mark.parametrize(("flags", "expected"), [
    (("--sea", "1.75,0,6,-90"), "--sea.length_m"),
    (("--sea", "1.75,35,nan,-90"), "--sea: every number must be finite"),
    (("--sea", "10,35,6,-90"), "--sea.height_m"),
    (("--current", "9,0"), "--current.current_speed_mps"),
])
def test_bad_sea_flags_are_one_line(tmp_path: Path, flags: tuple[str, ...], expected: str) -> None:
    out = _sim_cli(*flags, "--log-dir", str(tmp_path / "logs"))
    assert out.returncode == 2 and len(out.stderr.strip().splitlines()) == 1 and expected in out.stderr
    assert not (tmp_path / "logs").exists()  # the world is checked before anything is written


def test_a_resolved_scenario_gives_both_loaders_the_same_world(tmp_path: Path) -> None:
    """What `mavbridge demo` hands its children: Scenario.to_mapping() read back by both loaders."""
    scenario = Scenario(name="resolved", world=World(vessel="corrected", sea=SEA_PRESETS["calm"]))
    path = tmp_path / "scenario.yaml"
    path.write_text(yaml.safe_dump(scenario.to_mapping(), sort_keys=False))
    (again,) = load_scenarios(path)
    assert again == scenario and load_world(path) == scenario.world


@pytest.mark.parametrize(("flags", "expected"), [
    (("--sea", "jonswap:0,6,-90"), "--sea HS: 0.0 is outside the allowed range (0, 30] m"),
    (("--sea", "jonswap:1,0.5,-90"), "--sea TP: 0.5 is outside the allowed range [1, 30] s"),
    (("--sea", "jonswap:1,31,-90"), "--sea TP: 31.0 is outside the allowed range [1, 30] s"),
    (("--sea", "jonswap:1,6,-90,0.5"), "--sea GAMMA: 0.5 is outside the allowed range [1, 10]"),
    (("--sea", "jonswap:1,6,-90,11"), "--sea GAMMA: 11.0 is outside the allowed range [1, 10]"),
    (("--sea", "jonswap:1,6,-90,3.3,-1"), "--sea SPREADING: -1.0 is outside the allowed range >= 0"),
    (("--sea", "swell:1,6,-90"), "--sea: 'swell:1,6,-90' is not of the form"),
    (("--sea-state", "9"), "argument --sea-state: sea state must be an integer in [0, 8], got 9"),
    (("--sea-state", "-1"), "argument --sea-state: sea state must be an integer in [0, 8], got -1"),
    (("--sea-state", "2.5"), "argument --sea-state: sea state must be an integer in [0, 8], got '2.5'"),
    (("--seed", "1.5"), "argument --seed: seed must be an integer in [0, 4294967295], got '1.5'"),
    (("--seed", "-3"), "argument --seed: seed must be an integer in [0, 4294967295], got -3"),
    (("--heave", "up"), "argument --heave: invalid choice: 'up'"),
])
def test_bad_irregular_sea_and_seed_flags_are_one_line(tmp_path: Path, flags: tuple[str, ...], expected: str) -> None:
    """Hs ≤ 0, Tp outside 1–30 s, γ outside 1–10, spreading < 0, sea state outside 0–8, a non-integer seed."""
    out = _sim_cli(*flags, "--log-dir", str(tmp_path / "logs"))
    assert out.returncode == 2 and len(out.stderr.strip().splitlines()) == 1, out.stderr
    assert expected in out.stderr
    assert not (tmp_path / "logs").exists()


def test_bad_scenario_sea_keys_are_one_line(tmp_path: Path) -> None:
    """An unknown key in a scenario's irregular sea: one line naming the field, exit 2."""
    path = tmp_path / "s.yaml"
    path.write_text("sea:\n  spectrum: {kind: jonswap, hs_m: 1.75, tpp_s: 6}\n  seed: 7\n")
    out = _sim_cli("--scenario", str(path))
    assert out.returncode == 2 and len(out.stderr.strip().splitlines()) == 1, out.stderr
    assert "sea.spectrum: unknown key 'tpp_s'" in out.stderr


def test_scenario_irregular_sea_reaches_the_simulator(tmp_path: Path) -> None:
    """A scenario's irregular sea drives the simulator's plant; it says it compiles, then starts."""
    path = tmp_path / "s.yaml"
    path.write_text("sea:\n  spectrum: {kind: jonswap, hs_m: 1.75, tp_s: 6, n_components: 100}\n  seed: 7\n")
    out = _sim_cli("--scenario", str(path), "--seed", "3", "--log-dir", str(tmp_path / "logs"))
    assert out.returncode == 0, out.stderr
    assert "compiling the irregular sea's plant" in out.stderr and "jonswap Hs 1.75 m" in out.stderr
    with (tmp_path / "logs" / "state.csv").open() as f:
        elevations = [float(r["wave_elevation_m"]) for r in csv.DictReader(f)]
    assert len(set(elevations)) > 5 and max(map(abs, elevations)) > 0.0


def test_mavbridge_checks_every_scenario_file_the_simulator_reads(tmp_path: Path) -> None:
    """`sim-vehicle --scenario` refuses what `mavbridge` refuses, through the entry point mavbridge registers
    (vessel.world.check_whole_scenario), never by importing it; a file that mavbridge takes passes."""
    from vessel.config import ConfigError
    from vessel.world import check_whole_scenario

    good = tmp_path / "good.yaml"
    good.write_text("controller: {horizon: 15, solver: nrti}\nwaypoint: {acceptance_radius_m: 2}\n")
    assert check_whole_scenario(good) == ["mavbridge"]
    for body, field in (("waypoint: {acceptance_radus_m: 2}", "acceptance_radus_m"),
                        ("controller: {solver: ipopts}", "controller.solver"),
                        ("controller: {horizon: 15.5}", "controller.horizon")):
        path = tmp_path / "bad.yaml"
        path.write_text(body + "\n")
        with pytest.raises(ConfigError, match=field):
            sim_world(path, None, None, Home())
