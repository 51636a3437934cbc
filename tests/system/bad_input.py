"""Harness of the table-driven bad-input tests (issue 17 item 8): enumerate every flag of a command from
its own argparse parser, run one bad command line in-process, and check what the user sees.

A case is a command line (split like a shell would) run with the working directory in a fresh tmp folder
that holds the few files the cases name (:data:`FIXTURE_FILES`); relative paths in a case point there.
The checks, for every case: exit code 2, exactly one line on stderr that names the flag (and any other
text the case asks for), no traceback, no Python quotes around the message, and the tmp folder exactly
as it was (nothing created, nothing changed: a bad command writes nothing).

The commands run in-process (``main(argv)`` of each console script, SystemExit caught): a process per
case would cost ~1 s each on a busy machine. A case that does not fail fast (the bad value was accepted
and the command went on to connect or compute) is stopped by SIGALRM after :data:`CASE_TIMEOUT_S` and
fails, naming the command line.
"""

from __future__ import annotations

import argparse
import os
import shlex
import signal
import subprocess
import sys
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import pytest

import mission.cli
import sim_vehicle.cli
import sim_vehicle.json_backend.cli
import vessel.cli

CASE_TIMEOUT_S = 20  # a bad value is refused in well under a second; anything longer went on to run
REPO = Path(__file__).resolve().parents[2]
SCENARIO = str(REPO / "scenarios" / "calm_short.yaml")  # a valid single-run scenario (absolute path)
SWEEP_SPEC = str(REPO / "scenarios" / "sweep-example.yaml")  # a valid sweep spec

OTTER_CSV = ";current_time;lat;lon;current_course_over_ground;current_speed;current_orientation_1;" \
    "current_orientation_2;current_orientation_3;current_rotational_velocities_1;current_rotational_velocities_2;" \
    "current_rotational_velocities_3\n" + "".join(
        f"2024-03-22_12:42:{10 + i // 10:02d}:{i % 10 * 100000:06d};{1711107730 + i / 10:.1f};59.9074{i:02d};10.7177;"
        f"50.0;1.0;{(i % 7 - 3) * 0.8 if i else 0.0:.1f};0.5;50.0;{(i % 5 - 2) * 0.3 if i else 0.0:.1f};0.1;0.2\n"
        for i in range(25))

FIXTURE_FILES: dict[str, str | None] = {  # name in the tmp folder -> text (None: an empty folder)
    "afile.txt": "keep me\n",  # an existing file: not a folder, not YAML of settings
    "adir": None,  # an existing (empty) folder: not a file
    "empty.yaml": "",  # an empty file
    "broken.yaml": "a: [1\n",  # not valid YAML
    "list.yaml": "- 1\n- 2\n",  # valid YAML, not a mapping
    "pass.txt": "correct horse battery staple\n",  # a valid signing passphrase file
    "bad.parm": "SYSID_THISMAV banana\n",  # a .parm line whose value is not a number
    "bad_config.yaml": "system_id: 300\n",  # a companion YAML with a field out of range
    "cfg_ok.yaml": "system_id: 250\n",  # a valid companion YAML (a bad flag on top must name the flag)
    "otter.csv": OTTER_CSV,  # a valid Otter API log (mavbridge report/replay): a placeholder row, then 2 s of motion
    # scenarios whose world is fine and whose other sections are not: refused by every reader of scenario files
    "typo_waypoint.yaml": "waypoint: {acceptance_radus_m: 2}\n",
    "bad_solver.yaml": "controller: {solver: ipopts}\n",
    "half_horizon.yaml": "controller: {horizon: 15.5}\n",
}

# Flags every parser has: not a value to get wrong (help prints and exits 0 by design).
HELP_REASON = "prints the help (or the version) and exits 0; takes no value"


@dataclass(frozen=True)
class Outcome:
    """What one in-process run of a command line left: exit code and the lines written to stderr."""

    code: object
    stderr: str
    stdout: str


class CaseTimeoutError(Exception):
    """A bad command line that ran on instead of being refused."""


def flags(parser: argparse.ArgumentParser, path: str) -> Iterator[str]:
    """``"<path> <flag>"`` for every option (its first long name) and positional of ``parser`` and its
    subcommands, help and version actions left out (see :data:`HELP_REASON`)."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from flags(sub, f"{path} {name}")
        elif isinstance(action, (argparse._HelpAction, argparse._VersionAction)):
            continue
        elif action.option_strings:
            longs = [o for o in action.option_strings if o.startswith("--")] or action.option_strings
            yield f"{path} {longs[0]}"
        else:
            yield f"{path} {action.dest}"


def untabled(parsers: Mapping[str, argparse.ArgumentParser], cases: Mapping[str, Sequence[object]],
             allowed: Mapping[str, str]) -> tuple[set[str], set[str]]:
    """(flags with neither a case nor an allow-list reason, table entries naming no flag)."""
    known = {flag for path, parser in parsers.items() for flag in flags(parser, path)}
    tabled = set(cases) | set(allowed)
    return known - tabled, tabled - known


def make_fixtures(folder: Path) -> None:
    """The files of :data:`FIXTURE_FILES` in ``folder``."""
    for name, text in FIXTURE_FILES.items():
        if text is None:
            (folder / name).mkdir()
        else:
            (folder / name).write_text(text)
            (folder / name).chmod(0o600)  # a passphrase file others can read draws a warning line


def snapshot(folder: Path) -> dict[str, bytes | None]:
    """Every path under ``folder``: file contents, or None for a folder."""
    return {str(p.relative_to(folder)): (None if p.is_dir() else p.read_bytes()) for p in sorted(folder.rglob("*"))}


def _mavbridge_main(argv: list[str]) -> int:
    import mavbridge.cli  # imported on first use: CasADi and friends load once per test session

    return mavbridge.cli.main(argv)


MAINS: dict[str, Callable[[list[str]], int]] = {
    "vessel": vessel.cli.main,
    "sim-vehicle": sim_vehicle.cli.main,
    "mavbridge": _mavbridge_main,
    "mission": mission.cli.main,
}


MODULES = {"vessel": "vessel.cli", "sim-vehicle": "sim_vehicle.cli", "mavbridge": "mavbridge.cli",
           "mission": "mission.cli"}


def run_as_process(command: str, folder: Path) -> Outcome:
    """Run ``command`` as its own Python process in ``folder`` (what a user's shell does), for comparison with
    :func:`run_in_process`."""
    program, *argv = shlex.split(command)
    done = subprocess.run([sys.executable, "-m", MODULES[program], *argv], cwd=folder, capture_output=True,
                          text=True, timeout=120, env={**os.environ, "PYTHONPATH": str(REPO)})
    return Outcome(done.returncode, done.stderr, done.stdout)


def _alarm(signum: int, frame: object) -> None:
    raise CaseTimeoutError(f"still running after {CASE_TIMEOUT_S} s: the bad value was accepted")


def run_in_process(command: str, readouterr: Callable[[], tuple[str, str]]) -> Outcome:
    """Run ``command`` ("<program> args…") through its ``main``; the caller has set the working folder and
    captures output (``readouterr`` returns (stdout, stderr) so far). Signal handlers a command installs
    are put back afterwards."""
    program, *argv = shlex.split(command)
    watched = (signal.SIGTERM, signal.SIGINT, signal.SIGHUP, signal.SIGALRM)
    saved = {s: signal.getsignal(s) for s in watched}
    readouterr()
    signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(CASE_TIMEOUT_S)
    try:
        code: object = MAINS[program](argv)
    except SystemExit as exc:
        code = exc.code
    finally:
        signal.alarm(0)
        for number, handler in saved.items():
            signal.signal(number, handler)
    out, err = readouterr()
    return Outcome(code, err, out)


def problems(outcome: Outcome, needles: Sequence[str]) -> list[str]:
    """Everything wrong with a bad-input outcome (empty when it is one clear line with exit code 2); a needle
    that is a flag must be named once as the subject of the line, not twice (``argument --x: --x: …``)."""
    found = []
    lines = outcome.stderr.splitlines()
    if outcome.code != 2:
        found.append(f"exit code {outcome.code!r}, expected 2")
    if len(lines) != 1:
        found.append(f"{len(lines)} lines on stderr, expected 1")
    if "Traceback" in outcome.stderr + outcome.stdout:
        found.append("a traceback")
    text = lines[0] if lines else ""
    found += [f"{needle!r} not in the message" for needle in needles if needle not in text]
    _, _, message = text.partition("error: ")
    if message[:1] in ("'", '"'):
        found.append("Python quotes around the message")
    found += [f"{needle!r} named twice" for needle in needles
              if needle.startswith("-") and message.count(f"{needle}:") > 1]
    return found


def case_params(cases: Mapping[str, Sequence[Sequence[str]]]) -> list[object]:
    """pytest params (flag key, command line, needles), named by the command line, for every case of a table
    {flag key: [(command, *needles), …]}."""
    return [pytest.param(key, command, tuple(needles), id=command)
            for key, entries in cases.items() for command, *needles in entries]


def check_case(key: str, command: str, needles: Sequence[str], folder: Path,
               readouterr: Callable[[], tuple[str, str]]) -> None:
    """Run one case in ``folder`` (already the working folder, fixtures made) and assert it was refused
    cleanly: see :func:`problems`, plus the folder unchanged. The flag of ``key`` is always a needle."""
    before = snapshot(folder)
    outcome = run_in_process(command, readouterr)
    flag = key.split()[-1]
    found = problems(outcome, [flag, *needles] if flag.startswith("-") else list(needles))
    after = snapshot(folder)
    if after != before:
        changed = sorted(name for name in set(after) | set(before) if after.get(name, 0) != before.get(name, 0))
        found.append(f"the working folder changed: {', '.join(changed)}")
    assert not found, f"{command}: {'; '.join(found)}\n  stderr: {outcome.stderr!r}"


def table_tests(parsers: Mapping[str, argparse.ArgumentParser], cases: Mapping[str, Sequence[Sequence[str]]],
                no_bad_value: Mapping[str, str]) -> tuple[Callable[..., None], Callable[..., None]]:
    """The two tests of a table module: every flag has a case (or a reason), and every case is refused cleanly.
    A module binds them to ``test_*`` names so that pytest collects them there."""

    def every_flag_has_a_case() -> None:
        missing, stale = untabled(parsers, cases, no_bad_value)
        assert not missing, f"flags without a bad-input case or a reason in NO_BAD_VALUE: {sorted(missing)}"
        assert not stale, f"table entries that name no flag: {sorted(stale)}"

    @pytest.mark.parametrize(("key", "command", "needles"), case_params(cases))
    def bad_value_is_one_line_exit_2(key: str, command: str, needles: tuple[str, ...], tmp_path: Path,
                                     monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
        make_fixtures(tmp_path)
        monkeypatch.chdir(tmp_path)
        check_case(key, command, needles, tmp_path, lambda: tuple(capsys.readouterr()))

    return every_flag_has_a_case, bad_value_is_one_line_exit_2
