"""Every file in deploy/ loaded as its consumer loads it, against a live `sim-vehicle` (issue 35).

A file that would not start on the boat fails here: each companion configuration is checked
(`mavbridge check`) and run (`mavbridge run --dry-run`) as shipped, only its connection pointed at the
simulator by the `--connect` flag, the way deploy/README.md does; the systemd unit's command line is run
as systemd would run it (its environment file, its working directory, SIGTERM to stop); and the commands
of deploy/README.md run as written, the simulator standing in for the boat (``test_deploy_readme``).
"""

from __future__ import annotations

import json
import shlex
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

from sim_vehicle.harness import SimProcess
from sim_vehicle.rover.params import read_parm
from tests.system.nullmodem import NullModem
from tests.system.processes import collecting, wait_for_line
from tests.waits import upload_waypoint

ROOT = Path(__file__).resolve().parents[2]
DEPLOY = ROOT / "deploy"
PARM = DEPLOY / "otter-rover.parm"
MAVBRIDGE = [sys.executable, "-m", "mavbridge.cli"]
pytestmark = pytest.mark.slow

LOADED_BY = {  # every file in deploy/ and the test that loads it the way its consumer does
    "README.md": "tests/system/test_deploy_readme.py",
    "companion-boat.yaml": "test_companion_configuration_starts_as_shipped",
    "companion-sim.yaml": "test_companion_configuration_starts_as_shipped",
    "mavbridge.service": "test_service_command_line_runs_and_stops_as_systemd_runs_it",
    "mavbridge.env": "test_service_command_line_runs_and_stops_as_systemd_runs_it",
    "otter-rover.parm": "test_parameter_files_load_in_the_simulator",
    "otter-guided-tau.parm": "test_parameter_files_load_in_the_simulator",
    "otter-json-sitl.parm": "test_parameter_files_load_in_the_simulator",  # the firmware: test_json_backend_parm
}


def test_every_file_in_deploy_is_loaded_by_a_test() -> None:
    """A file added to deploy/ without a test that loads it fails here, by name."""
    shipped = sorted(p.name for p in DEPLOY.iterdir() if p.is_file())
    assert shipped == sorted(LOADED_BY), f"deploy/ files without a loading test: {set(shipped) - set(LOADED_BY)}"
    for test in set(LOADED_BY.values()):
        assert (ROOT / test).is_file() if "/" in test else test in globals(), test


def _mavbridge(*args: str, timeout: float, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run([*MAVBRIDGE, *args], capture_output=True, text=True, timeout=timeout, cwd=cwd)


def _serial(config: Path) -> bool:
    """True when the configuration's link is a serial device (the boat's), False for a network URL."""
    return str(yaml.safe_load(config.read_text())["connect"]).startswith("/dev/")


@pytest.mark.parametrize("name", sorted(p.name for p in DEPLOY.glob("companion-*.yaml")))
def test_companion_configuration_starts_as_shipped(tmp_path: Path, name: str) -> None:
    """The check passes and a shadow run plans, with every value of the file as shipped (only the link moved:
    a serial file gets a null-modem pair, a network one a UDP port): the boat's file was refused at start
    (its calibrated roll phase of −180° against a range of ±90°) before issue 35."""
    config = DEPLOY / name
    modem = NullModem() if _serial(config) else None
    link = ["--serial", f"{modem.ends[0]},921600"] if modem else []
    try:
        with SimProcess(tmp_path / "sim", speedup=5, waves="paper", udp_outs=0 if modem else 2,
                        extra=["--params", str(PARM), "--wipe", *link], sensors="realistic",
                        sea_phase="hidden") as sim:
            # the second UDP output is the simulator's SERIAL2 (SR2_* rates), where a companion listens (14551)
            connect = modem.ends[1] if modem else f"udpin:127.0.0.1:{sim.udp_ports[1]}"
            upload_waypoint(sim.connect(), 85, 75)
            check = _mavbridge("check", "--config", str(config), "--connect", connect, "--solves", "20",
                               "--timeout", "20", timeout=180)
            assert check.returncode == 0, check.stdout + check.stderr
            out = tmp_path / "shadow"
            run = _mavbridge("run", "--config", str(config), "--connect", connect, "--dry-run", "--max-time", "8",
                             "--out", str(out), timeout=180)
    finally:
        if modem:
            modem.close()
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-2000:]
    assert "error" not in run.stdout + run.stderr, run.stdout[-3000:] + run.stderr
    assert "1 waypoint from the mission" in run.stdout
    resolved = yaml.safe_load((out / "config.yaml").read_text())
    shipped = yaml.safe_load(config.read_text())
    changed = {k: (v, resolved["companion"][k]) for k, v in shipped.items()
               if k not in ("connect", "max_time_s") and resolved["companion"][k] != v}  # the flags moved those
    assert not changed, f"values that did not reach the run as shipped: {changed}"
    planned = len((out / "companion.csv").read_text().splitlines()) - 1
    metrics = json.loads((out / "metrics.json").read_text())
    # nothing is sent in a shadow run, so nothing holds time: under load ticks are skipped, never lost (each of
    # the 80 ticks of 8 s is planned or counted), and a working plan shows on at least a few of them
    accounted = planned + metrics["skipped_ticks"] + metrics["stale_states"]
    assert planned >= 10 and accounted >= 75, (planned, metrics["skipped_ticks"], metrics["stale_states"])
    assert metrics["waves"]["source"] == shipped["waves"], metrics["waves"]


@pytest.mark.parametrize("name", sorted(p.name for p in DEPLOY.glob("*.parm")))
def test_parameter_files_load_in_the_simulator(tmp_path: Path, name: str) -> None:
    """`sim-vehicle --params FILE` starts on each shipped file and answers every value it holds as written."""
    parm = DEPLOY / name
    values = read_parm(parm)
    with SimProcess(tmp_path, speedup=5, extra=["--params", str(parm), "--wipe"]) as sim:
        conn = sim.connect()
        conn.mav.param_request_list_send(1, 1)
        seen: dict[str, float] = {}
        deadline = time.monotonic() + 60
        while len(seen.keys() & values.keys()) < len(values) and time.monotonic() < deadline:
            msg = conn.recv_match(type="PARAM_VALUE", blocking=True, timeout=1)
            if msg is not None:
                seen[msg.param_id] = msg.param_value
        err = sim.stop()
    missing = sorted(values.keys() - seen.keys())
    assert not missing, f"{name}: parameters the simulator did not list: {missing}"
    wrong = {k: (v, seen[k]) for k, v in values.items() if abs(seen[k] - v) > 1e-4 * max(1.0, abs(v))}
    assert not wrong, f"{name}: listed with other values: {wrong}"
    assert "error" not in err.lower(), err


def _systemd_environment(path: Path) -> dict[str, str]:
    """An EnvironmentFile= as systemd reads it: KEY=VALUE lines, # comments, quotes group, no shell expansion."""
    env = {}
    for line in path.read_text().splitlines():
        if line.strip() and not line.lstrip().startswith(("#", ";")):
            key, sep, value = line.partition("=")
            assert sep and key.strip().isidentifier(), f"{path.name}: not KEY=VALUE: {line!r}"
            env[key.strip()] = " ".join(shlex.split(value)) if value.strip() else ""
    return env


def _exec_start(unit: Path, env: dict[str, str], program: str) -> list[str]:
    """ExecStart= with systemd's substitutions: ${VAR} one word, $VAR split on white space."""
    line = next(v for k, _, v in (x.partition("=") for x in unit.read_text().splitlines()) if k == "ExecStart")
    argv: list[str] = []
    for word in shlex.split(line):
        if word.startswith("${"):
            argv.append(env[word[2:-1]])
        elif word.startswith("$"):
            argv += env[word[1:]].split()
        else:
            argv.append(word)
    assert argv[0] == "/opt/mavbridge/venv/bin/mavbridge", argv[0]
    return [program, *argv[1:]]


def test_service_command_line_runs_and_stops_as_systemd_runs_it(tmp_path: Path, modem: NullModem) -> None:
    """The unit's ExecStart with the env file's variables, the boat's configuration installed as the README
    says (its device edited to the serial line), MAVBRIDGE_ARGS as the field procedure's shadow step
    (`--dry-run`), in the unit's WorkingDirectory: it connects, plans, and on systemd's SIGTERM stops within
    TimeoutStopSec with exit 0 (no restart), its run folder written under runs/."""
    installed = tmp_path / "etc" / "companion.yaml"
    installed.parent.mkdir()
    text = (DEPLOY / "companion-boat.yaml").read_text()
    installed.write_text(text.replace("connect: /dev/ttyAMA0", f"connect: {modem.ends[1]}"))
    assert installed.read_text() != text, "the deployer's edit (connect: DEVICE) did not apply"
    env = _systemd_environment(DEPLOY / "mavbridge.env")
    assert env["MAVBRIDGE_CONFIG"] == "/etc/mavbridge/companion.yaml"
    env.update(MAVBRIDGE_CONFIG=str(installed), MAVBRIDGE_ARGS="--dry-run",
               MAVBRIDGE_CACHE_DIR=str(tmp_path / "cache"))
    argv = _exec_start(DEPLOY / "mavbridge.service", env, str(Path(sys.executable).with_name("mavbridge")))
    logs = tmp_path / "var-log-mavbridge"
    logs.mkdir()
    with SimProcess(tmp_path / "sim", speedup=5, waves="paper", extra=[
            "--params", str(PARM), "--wipe", "--serial", f"{modem.ends[0]},921600"]) as sim:
        upload_waypoint(sim.connect(), 85, 75)
        # PYTHONPATH: the console script runs this checkout, wherever the venv's editable install points
        with collecting(argv, cwd=logs, env={"PATH": "/usr/bin:/bin", "PYTHONPATH": str(ROOT), **env}) as (
                service, lines):
            wait_for_line(service, lines, "s (autopilot):", timeout_s=120)  # a progress line: it is planning
            service.send_signal(signal.SIGTERM)
            service.wait(timeout=15)  # TimeoutStopSec=15
    output = "".join(lines)
    assert service.returncode == 0, output[-3000:]
    runs = list((logs / "runs").glob("companion-*"))
    assert len(runs) == 1, output[-2000:]
    for name in ("companion.tlog", "companion.csv", "metrics.json", "config.yaml"):
        assert (runs[0] / name).is_file(), f"{name} missing from {runs[0]}"
    assert "signal SIGTERM" in output and "error" not in output, output[-3000:]

