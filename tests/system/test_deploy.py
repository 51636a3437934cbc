"""The deployment files: parameter file, companion configurations, systemd unit and its environment."""

from __future__ import annotations

import re
import shlex
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from mavbridge.cli import build_parser
from mavbridge.companion.flight import CompanionConfig, load_companion_config
from mavbridge.lab.scenario import Scenario
from sim_vehicle.harness import SimProcess
from sim_vehicle.rover.params import ParamTable, is_param_name, read_parm
from tests.waits import wait_for

ROOT = Path(__file__).resolve().parents[2]
DEPLOY = ROOT / "deploy"
PARM = DEPLOY / "otter-rover.parm"
UNIT = DEPLOY / "mavbridge.service"
ENV = DEPLOY / "mavbridge.env"
README = DEPLOY / "README.md"


def test_both_companion_configurations_load_and_agree_with_the_parameters() -> None:
    """sim and boat YAML load with the companion's own loader; ids and baud match otter-rover.parm."""
    params = read_parm(PARM)
    sim = load_companion_config(DEPLOY / "companion-sim.yaml")
    boat = load_companion_config(DEPLOY / "companion-boat.yaml")
    assert sim.connect == "udpin:0.0.0.0:14551"  # where sim-vehicle's companion output goes
    assert boat.connect.startswith("/dev/") and boat.baud == 921600
    assert params["SERIAL2_BAUD"] == 921 and params["SERIAL2_PROTOCOL"] == 2
    for config in (sim, boat):
        assert config.system_id == params["SYSID_MYGCS"] == CompanionConfig().system_id
        assert config.output == "rc_override"
    for path in ("companion-sim.yaml", "companion-boat.yaml"):
        text = (DEPLOY / path).read_text()
        assert text.count("\n#") >= 5, f"{path} should explain its settings"


def test_parameter_file_format_and_values() -> None:
    """`NAME,VALUE` lines only (no inline comments, which some loaders reject), each explained above it."""
    lines = PARM.read_text().splitlines()
    names = []
    for number, line in enumerate(lines):
        if not line.strip() or line.startswith("#"):
            continue
        assert re.fullmatch(r"[A-Z][A-Z0-9_]{0,15},-?[0-9.]+", line), f"line {number + 1}: {line!r}"
        names.append(line.split(",")[0])
        above = lines[number - 1]
        assert above.startswith("#") or re.fullmatch(r"[A-Z0-9_]+,.*", above), f"{line}: no comment above"
    assert len(names) == len(set(names)), "a parameter is set twice"
    p = read_parm(PARM)
    scenario = Scenario()
    assert (p["FRAME_CLASS"], p["SERVO1_FUNCTION"], p["SERVO3_FUNCTION"]) == (2, 73, 74)
    assert scenario.controller.period_s < p["RC_OVERRIDE_TIME"] <= 2.0
    assert p["SR2_EXTRA1"] >= 20 and p["SR2_POSITION"] >= 10
    assert p["WP_RADIUS"] == scenario.waypoint.acceptance_radius_m and p["WP_SPEED"] > 0
    assert p["FS_ACTION"] != 0 and p["FS_THR_ENABLE"] >= 1
    assert "MOT_SLEWRATE" in p
    known = ParamTable()
    assert all(name in known or is_param_name(name) for name in p), "a name the simulator would drop"


def test_unknown_but_real_parameters_are_kept_listed_and_settable() -> None:
    """Extras from a .parm file come after the built-in table as REAL32, settable, reported in the count."""
    table = ParamTable(extra={"MODE6": 15.0, "BATT_CAPACITY": 10000.0, "WP_SPEED": 9.0})
    assert table.extra_names == ("MODE6", "BATT_CAPACITY")  # a built-in name is not duplicated
    assert len(table) == len(ParamTable()) + 2 and table["MODE6"] == 15.0
    assert table.at(len(table) - 1)[0].name == "BATT_CAPACITY"
    assert table.set("MODE6", 4.0) and table["MODE6"] == 4.0
    assert not is_param_name("NOT_A_PARAM") and not is_param_name("SERVO1_FUNCTION_TOO_LONG")
    assert is_param_name("SERIAL4_PROTOCOL") and is_param_name("MODE1")


@pytest.mark.slow
def test_simulator_serves_the_deployed_file(tmp_path: Path) -> None:
    """`sim-vehicle --params deploy/otter-rover.parm`: modelled values apply, the others are readable."""
    with SimProcess(tmp_path, speedup=10, extra=["--params", str(PARM)]) as sim:
        conn = sim.connect()
        for name, value in (("RC_OVERRIDE_TIME", 0.5), ("SR2_EXTRA1", 20), ("MODE6", 15), ("SERIAL2_BAUD", 921)):
            conn.mav.param_request_read_send(1, 1, name.encode(), -1)
            msg = wait_for(conn, "PARAM_VALUE", 5, lambda m, n=name: m.param_id == n)
            assert msg is not None and msg.param_value == pytest.approx(value), name
        err = sim.stop()
    assert "not simulated: MODE1, MODE4, MODE6" in err


def _unit() -> dict[str, list[str]]:
    """The unit file as key -> values (comments and section headers dropped)."""
    entries: dict[str, list[str]] = {}
    for line in UNIT.read_text().splitlines():
        if line.strip() and not line.startswith(("#", "[")):
            key, _, value = line.partition("=")
            entries.setdefault(key.strip(), []).append(value.strip())
    return entries


def _env() -> dict[str, str]:
    pairs = {}
    for line in ENV.read_text().splitlines():
        if line.strip() and not line.startswith("#"):
            key, _, value = line.partition("=")
            pairs[key] = value
    return pairs


def test_service_names_only_installed_or_documented_things() -> None:
    """Its program is our console script, its command line parses, and every path it uses is documented."""
    unit, env = _unit(), _env()
    assert unit["Restart"] == ["on-failure"] and unit["User"] == ["mavbridge"]
    assert unit["EnvironmentFile"] == ["/etc/mavbridge/mavbridge.env"]
    argv = shlex.split(unit["ExecStart"][0])
    scripts = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]
    assert Path(argv[0]).name in scripts
    expanded = []
    for arg in argv[1:]:
        if arg.startswith("${"):
            expanded.append(env[arg[2:-1]])
        elif arg.startswith("$"):
            expanded += env[arg[1:]].split()
        else:
            expanded.append(arg)
    args = build_parser().parse_args(expanded)
    assert args.command == "run" and not args.arm and not args.set_mode  # the pilot arms and picks the mode
    found = re.findall(r"(?<![\w$])/[\w./-]+", UNIT.read_text() + ENV.read_text())
    referenced = {"/" + path.strip("/").rstrip(".") for path in found}  # file:///x -> /x; no full stop
    readme = README.read_text()
    missing = sorted(p for p in referenced if not p.startswith("/dev/") and p not in readme)
    assert not missing, f"paths not documented in deploy/README.md: {missing}"
    for name in ("mavbridge.service", "mavbridge.env", "companion-boat.yaml", "otter-rover.parm", "useradd"):
        assert name in readme


def test_systemd_accepts_the_unit(tmp_path: Path) -> None:
    """`systemd-analyze verify`, with the install paths pointed at this checkout's venv and files."""
    if shutil.which("systemd-analyze") is None:
        pytest.skip("systemd-analyze is not installed (apt-get install systemd); the unit was not verified")
    text = UNIT.read_text().replace("/opt/mavbridge/venv", str(Path(sys.executable).parent.parent))
    text = text.replace("/etc/mavbridge/mavbridge.env", str(ENV))
    unit = tmp_path / "mavbridge.service"
    unit.write_text(text)
    result = subprocess.run(["systemd-analyze", "verify", str(unit)], capture_output=True, text=True, timeout=60)
    problems = [line for line in (result.stdout + result.stderr).splitlines() if "mavbridge.service" in line]
    assert result.returncode == 0 and not problems, result.stdout + result.stderr
