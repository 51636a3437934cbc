"""Every console script speaks alike: --version from the installed metadata, a bare command lists its commands
(exit 2), and a maneuver that cannot be measured is one line and exit 2. Real processes, nothing mocked."""

from __future__ import annotations

import subprocess
import sys
from importlib.metadata import version

import pytest

SCRIPTS = {"mavbridge": "mavbridge.cli", "mission": "mission.cli", "vessel": "vessel.cli",
           "sim-vehicle": "sim_vehicle.cli"}
BARE = {"mavbridge": ("experiment", "run", "demo", "check", "replay"), "mission": ("upload", "download", "clear"),
        "vessel": ("maneuver", "sea")}


def _run(module: str, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", module, *args], capture_output=True, text=True, timeout=120)


@pytest.mark.parametrize("name", sorted(SCRIPTS))
def test_version_is_the_installed_one(name: str) -> None:
    done = _run(SCRIPTS[name], "--version")
    assert done.returncode == 0 and done.stdout.strip() == f"{name} {version('otter-rollaware')}", done


@pytest.mark.parametrize("name", sorted(BARE))
def test_a_bare_command_prints_its_usage_and_commands(name: str) -> None:
    done = _run(SCRIPTS[name])
    assert done.returncode == 2 and done.stderr.startswith(f"usage: {name}"), done.stderr
    assert "arguments are required" not in done.stderr
    assert all(command in done.stderr for command in BARE[name]), done.stderr


def test_a_roll_decay_in_waves_is_refused_in_one_line() -> None:
    done = _run("vessel.cli", "maneuver", "--preset", "roll-decay", "--sea", "paper")
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1 and "decay" in done.stderr
    assert done.stdout == ""


RENAMED = [("vessel.cli", ("maneuver", "--preset", "roll-decay", "--waves", "paper"), "--sea", "decay"),
           ("sim_vehicle.cli", ("--waves", "paper", "--no-tcp", "--no-out", "--duration", "0.2", "--speedup", "0"),
            "--sea", "regular waves H 1.75 m"),
           ("mavbridge.cli", ("run", "--waves", "scenario", "--dry-run", "--arm"), "--wave-source", "--dry-run")]


@pytest.mark.parametrize(("module", "args", "new", "then"), RENAMED, ids=[r[0] for r in RENAMED])
def test_an_old_flag_name_still_works_and_says_its_new_one(module: str, args: tuple[str, ...], new: str,
                                                            then: str) -> None:
    """``--waves`` meant a named sea (vessel, sim-vehicle) or where the companion's waves come from (mavbridge):
    each meaning has its own name now, and the old one is taken, with one line naming the new one first."""
    done = _run(module, *args)
    lines = done.stderr.strip().splitlines()
    assert lines[0].endswith(f"--waves is now {new} (the old name still works, for now)"), done.stderr
    assert then in done.stderr + done.stdout, done


def test_one_name_for_the_true_sea_in_every_command() -> None:
    """`truth` (the experiment's word) and `scenario` (the companion's) name the same sea in every --wave-source."""
    from mavbridge.cli.main import build_parser
    from mavbridge.cli.run import companion_source

    parser = build_parser()
    for command in ("run", "demo"):
        assert companion_source(parser.parse_args([command, "--wave-source", "truth"]).wave_source) == "scenario"
        assert companion_source(parser.parse_args([command, "--wave-source", "scenario"]).wave_source) == "scenario"
    assert parser.parse_args(["experiment", "x.yaml", "--wave-source", "scenario"]).wave_source == "scenario"
