"""deploy/README.md as a deployer reads it: every command in its code blocks either runs here as written,
the simulator on pseudo-terminals standing in for the boat, or is named below as one that needs the boat's
computer, the ArduPilot firmware or another test (and why). A command added to the README joins one list or
fails ``test_every_readme_command_is_run_or_accounted_for``.

What "as written" allows: the device names become the two ends of a null modem, the installed paths
(/etc/mavbridge, /opt/mavbridge/venv) this checkout's, and the simulator gets test-only ports and stores
(`--tcp PORT --no-out --params-store … --log-dir …`) so that it cannot meet another test's. Nothing else.
"""

from __future__ import annotations

import json
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from sim_vehicle.harness import SimProcess, sim_vehicle_command
from tests.system.nullmodem import NullModem
from tests.waits import upload_waypoint

ROOT = Path(__file__).resolve().parents[2]
README = ROOT / "deploy" / "README.md"
pytestmark = pytest.mark.slow

ELSEWHERE = {  # program (or section for our own programs) -> why it is not run here
    "useradd": "creates the service's user on the companion computer",
    "git": "fetches the sources onto the companion computer",
    "python3": "makes the companion computer's virtual environment (CI does the same from pyproject.toml)",
    "/opt/mavbridge/venv/bin/pip": "installs onto the companion computer (CI installs the same way)",
    "install": "copies files into /etc on the companion computer (the tests read them from deploy/)",
    "systemctl": "needs systemd as PID 1; the unit's command line runs in test_deploy_shipped",
    "journalctl": "reads the journal of a running service",
    "echo": "writes the signing passphrase into /etc/mavbridge (with tee)",
    "tee": "writes the signing passphrase into /etc/mavbridge",
    "sed": "edits the companion computer's kernel command line (isolcpus=, section 2b)",
    "cat": "reads the companion computer's isolated CPUs and governor after its reboot (section 2b)",
    "Tools/autotest/sim_vehicle.py": "the ArduPilot firmware, not here (tests/sim_vehicle/test_json_backend*)",
    "section 2a": "signing setup against the autopilot's USB port: tests/system/test_signing.py runs it",
    "section 5a": "needs the ArduPilot firmware (SERIAL2 on TCP 5763): tests/sim_vehicle/test_json_backend*.py",
}
RUN_HERE = ("4", "5")  # the sections whose mavbridge / sim-vehicle commands run in this test


def readme_commands() -> list[tuple[str, list[str]]]:
    """(section number, argv) for every command in the README's bash blocks, continuations joined."""
    commands: list[tuple[str, list[str]]] = []
    section, block = "", None
    for line in README.read_text().splitlines():
        heading = re.match(r"#{2,3} (\d+[a-z]?)\. ", line)
        if heading:
            section = heading.group(1)
        elif line.startswith("```") and block is None:
            block = []
        elif line.startswith("```"):
            commands += [(section, argv) for argv in _split(block)]
            block = None
        elif block is not None:
            block.append(line)
    return commands


def _split(lines: list[str]) -> list[list[str]]:
    """Shell lines (comments dropped, ``\\`` continuations joined) as argv lists, split at ``|``, ``&&``,
    ``||`` and ``;`` (so that ``systemctl stop x && mavbridge check`` is two commands, each accounted for)."""
    text = "\n".join(lines).replace("\\\n", " ")
    argvs: list[list[str]] = []
    for line in text.splitlines():
        lexer = shlex.shlex(line, posix=True, punctuation_chars="|&;")
        lexer.whitespace_split, lexer.commenters = True, "#"
        words: list[str] = []
        for word in [*lexer, ";"]:
            if word in ("|", "||", "&&", ";", "&"):
                argvs += [words] if words else []
                words = []
            else:
                words.append(word)
    return argvs


def _unwrap(argv: list[str]) -> tuple[dict[str, str], list[str]]:
    """(environment, command) past ``sudo [-u USER]`` and ``env K=V …``."""
    if argv[0] == "sudo":
        argv = argv[3:] if argv[1] == "-u" else argv[1:]
    env = {}
    if argv[0] == "env":
        argv = argv[1:]
        while "=" in argv[0]:
            key, _, value = argv.pop(0).partition("=")
            env[key] = value
    return env, argv


def _program(argv: list[str]) -> str:
    """The program a command runs, past ``sudo [-u USER]`` and ``env K=V``."""
    return _unwrap(argv)[1][0]


def _ours(program: str) -> bool:
    return Path(program).name in ("mavbridge", "sim-vehicle")


def test_every_readme_command_is_run_or_accounted_for() -> None:
    """Each command runs in this test or is listed in ELSEWHERE with a reason; none is silently skipped."""
    commands = readme_commands()
    assert len(commands) >= 15, f"only {len(commands)} commands read from {README.name}: the parser lost some"
    unaccounted = []
    for section, argv in commands:
        program = _program(argv)
        if _ours(program):
            if section not in RUN_HERE and f"section {section}" not in ELSEWHERE:
                unaccounted.append(f"section {section}: {shlex.join(argv)}")
        elif program not in ELSEWHERE:
            unaccounted.append(f"section {section}: {shlex.join(argv)}")
    assert not unaccounted, "README commands neither run nor accounted for:\n" + "\n".join(unaccounted)


def _as_here(argv: list[str], modem: NullModem, installed: Path) -> list[str]:
    """A README command with the boat's names replaced by this machine's (see the module docstring)."""
    argv = _unwrap(argv)[1]

    def here(word: str) -> str:
        if word.startswith("/dev/ttyUSB0"):
            return modem.ends[0] + word.removeprefix("/dev/ttyUSB0")
        if word == "/dev/ttyUSB1":
            return modem.ends[1]
        if word == "/etc/mavbridge/companion.yaml":
            return str(installed)
        return str(ROOT / word) if word.startswith("deploy/") else word

    program = Path(argv[0]).name
    runner = [sys.executable, "-m", "mavbridge.cli"] if program == "mavbridge" else sim_vehicle_command()
    return runner + [here(word) for word in argv[1:]]


def test_deploy_readme_commands_run_as_written(tmp_path: Path, modem: NullModem) -> None:
    """Section 5 (the serial path with the boat's configuration) and section 4 (the preflight check on the
    installed configuration) as written: the check passes, the shadow run plans, the run arrives."""
    runnable = [(s, argv) for s, argv in readme_commands() if s in RUN_HERE and _ours(_program(argv))]
    sims = [argv for _, argv in runnable if Path(_program(argv)).name == "sim-vehicle"]
    assert len(sims) == 1, sims
    installed = tmp_path / "etc-mavbridge-companion.yaml"  # section 2: install companion-boat.yaml, edit device
    installed.write_text((ROOT / "deploy" / "companion-boat.yaml").read_text()
                         .replace("connect: /dev/ttyAMA0", f"connect: {modem.ends[1]}"))
    sim = SimProcess(tmp_path / "sim")
    sim.args = [*_as_here(sims[0], modem, installed), "--tcp", str(sim.tcp_port), "--no-out",
                "--params-store", str(tmp_path / "sim" / "params.json"), "--log-dir", str(sim.log_dir)]
    results = []
    with sim:
        upload_waypoint(sim.connect(), 85, 75)  # the ground station's mission, for the check without --waypoint
        for section, argv in runnable:
            if argv is sims[0]:
                continue
            command = _as_here(argv, modem, installed)
            env = {**os.environ, **_unwrap(argv)[0]}
            if "MAVBRIDGE_CACHE_DIR" in _unwrap(argv)[0]:
                env["MAVBRIDGE_CACHE_DIR"] = str(tmp_path / "var-cache-mavbridge")
            done = subprocess.run(command, capture_output=True, text=True, timeout=400, cwd=tmp_path, env=env)
            results.append((section, shlex.join(argv), done))
            assert done.returncode == 0, f"section {section}: {shlex.join(argv)}\n{done.stdout[-3000:]}{done.stderr}"
        err = sim.stop()
    assert "error" not in err, err
    checks = [r for r in results if " check " in r[1]]
    assert len(checks) == 2 and all("FAIL" not in r[2].stdout for r in checks)
    assert all("ATTITUDE rate as configured" in r[2].stdout for r in checks)
    shadow = next(r for r in results if "--dry-run" in r[1])[2]
    assert "phase: shadow" in shadow.stdout and "s (autopilot):" in shadow.stdout, shadow.stdout[-2000:]
    run = next(r for r in results if "--arm" in r[1])[2]
    folder = re.search(r"logs in (\S+)", run.stdout)
    assert folder, run.stdout[-2000:]
    metrics = json.loads((Path(tmp_path, folder.group(1)) / "metrics.json").read_text())
    assert metrics["phase"] == "ARRIVED" and metrics["time_to_waypoint_s"] < 300, metrics
    assert metrics["rates_hz"]["ATTITUDE"] >= 10, metrics["rates_hz"]
    # both directions went through the serial relay: a 20-byte frame per engaged second each way at least
    assert min(modem.bytes) > 20 * metrics["time_to_waypoint_s"], (modem.bytes, metrics["time_to_waypoint_s"])
