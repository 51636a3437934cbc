"""Bad values for every flag of `vessel` (maneuver, sea) and `sim-vehicle` (and its `--json-backend` mode):
exit 2, one line naming the flag, no traceback, nothing written (issue 17 items 8 and 10).

A flag added to one of these parsers without a case here (or a reason in ``NO_BAD_VALUE``) fails
``test_every_flag_has_a_case``. Harness and checks: ``tests/system/bad_input.py``.
"""

from __future__ import annotations

from pathlib import Path

import pytest

import sim_vehicle.cli
import sim_vehicle.json_backend.cli
import vessel.cli

from .bad_input import make_fixtures, problems, run_as_process, run_in_process, table_tests

PARSERS = {"vessel": vessel.cli.build_parser(), "sim-vehicle": sim_vehicle.cli.build_parser(),
           "sim-vehicle --json-backend": sim_vehicle.json_backend.cli.build_parser()}

MAN = "vessel maneuver --left 10 --right 10 --duration 1"
SEA = "vessel sea --csv out.csv --duration 60"
SIM = "sim-vehicle --no-tcp --no-out --duration 0.05"
JSON = "sim-vehicle --json-backend 127.0.0.1:39002 --duration 0.05"
NAN, FINITE = "nan", "finite"

CASES: dict[str, list[tuple[str, ...]]] = {
    "vessel maneuver --preset": [("vessel maneuver --preset sideways", "invalid choice")],
    "vessel maneuver --left": [("vessel maneuver --left 150 --right 0", "[-100, 100]"),
                               (f"vessel maneuver --left {NAN} --right 0", FINITE),
                               ("vessel maneuver --left inf --right 0", FINITE),
                               ("vessel maneuver --left ten --right 0",)],
    "vessel maneuver --right": [("vessel maneuver --left 0 --right -101", "[-100, 100]"),
                                ("vessel maneuver --left 0",)],
    "vessel maneuver --duration": [(f"{MAN} --duration 0", "(0, 3600]"), (f"{MAN} --duration -1", "(0, 3600]"),
                                   (f"{MAN} --duration 1e9", "(0, 3600]"), (f"{MAN} --duration {NAN}", FINITE)],
    "vessel maneuver --dt": [(f"{MAN} --dt 0", "(0, 0.1]"), (f"{MAN} --dt 0.5", "(0, 0.1]"),
                             (f"{MAN} --dt inf", FINITE)],
    "vessel maneuver --roll-deg": [(f"{MAN} --roll-deg 61", "[-60, 60]"), (f"{MAN} --roll-deg {NAN}", FINITE)],
    "vessel maneuver --pitch-deg": [(f"{MAN} --pitch-deg -75", "[-60, 60]")],
    "vessel maneuver --zigzag-deg": [("vessel maneuver --preset zig-zag --zigzag-deg -5",),
                                     ("vessel maneuver --preset zig-zag --zigzag-deg 1000",)],
    "vessel maneuver --integrator": [(f"{MAN} --integrator heun", "invalid choice")],
    "vessel maneuver --parameter-set": [(f"{MAN} --parameter-set heavy", "invalid choice"),
                                        (f"{MAN} --parameter-set published --params empty.yaml", "not allowed")],
    "vessel maneuver --params": [(f"{MAN} --params no/such.yaml", "no/such.yaml"),
                                 (f"{MAN} --params adir", "adir"),
                                 (f"{MAN} --params broken.yaml", "broken.yaml"),
                                 (f"{MAN} --params list.yaml", "list.yaml")],
    "vessel maneuver --sea": [(f"{MAN} --sea stormy", "invalid choice"),
                              ("vessel maneuver --preset roll-decay --sea paper", "decay")],
    "vessel maneuver --waves": [(f"{MAN} --waves stormy", "invalid choice")],  # the old name of --sea
    "vessel maneuver --csv": [(f"{MAN} --csv adir", "adir"), (f"{MAN} --csv no/such/x.csv", "no/such"),
                              (f"{MAN} --csv afile.txt/x.csv", "afile.txt")],
    "vessel maneuver --plot": [(f"{MAN} --plot x.xyz", "x.xyz"), (f"{MAN} --plot adir", "adir"),
                               (f"{MAN} --plot no/such/x.png", "no/such")],
    "vessel sea --spectrum": [(f"{SEA} --spectrum bretschneider", "invalid choice")],
    "vessel sea --hs": [(f"{SEA} --hs 0",), (f"{SEA} --hs 31",), (f"{SEA} --hs {NAN}", FINITE), (f"{SEA} --hs one",)],
    "vessel sea --tp": [(f"{SEA} --tp 0.5", "[1, 30]"), (f"{SEA} --tp inf", FINITE)],
    "vessel sea --gamma": [(f"{SEA} --gamma 0.5", "[1, 10]")],
    "vessel sea --dir": [(f"{SEA} --dir 400", "[-360, 360]"), (f"{SEA} --dir {NAN}", FINITE)],
    "vessel sea --spreading": [(f"{SEA} --spreading -1",)],
    "vessel sea --sea-state": [(f"{SEA} --sea-state 9", "[0, 8]"), (f"{SEA} --sea-state 1.5",)],
    "vessel sea --seed": [(f"{SEA} --seed -1",), (f"{SEA} --seed x",)],
    "vessel sea --components": [(f"{SEA} --components 5", "[10, 5000]"), (f"{SEA} --components 1e9",)],
    "vessel sea --depth": [(f"{SEA} --depth 0.1", "[0.5, 10000]")],
    "vessel sea --duration": [(f"{SEA} --duration 0", "(0, 86400]"), (f"{SEA} --duration {NAN}", FINITE),
                              (f"{SEA} --duration 1",)],
    "vessel sea --dt": [(f"{SEA} --dt 0", "(0, 10]"), (f"{SEA} --dt 11", "(0, 10]")],
    "vessel sea --north": [(f"{SEA} --north 1e6",)],
    "vessel sea --east": [(f"{SEA} --east {NAN}", FINITE)],
    "vessel sea --csv": [("vessel sea --csv adir --duration 60", "adir"),
                         ("vessel sea --csv no/such/x.csv --duration 60", "no/such"),
                         ("vessel sea --duration 60", "required")],
    "vessel sea --plot": [(f"{SEA} --plot adir", "adir"), (f"{SEA} --plot no/such/x.png", "no/such"),
                          (f"{SEA} --plot x.xyz", "x.xyz")],
    "sim-vehicle --tcp": [(f"{SIM} --tcp 0", "[1, 65535]"), (f"{SIM} --tcp 70000", "[1, 65535]"), (f"{SIM} --tcp x",)],
    "sim-vehicle --out": [(f"{SIM} --out udp:127.0.0.1", "udp:HOST:PORT"), (f"{SIM} --out udp:127.0.0.1:0",),
                          (f"{SIM} --out tcp:127.0.0.1:5760", "udp:HOST:PORT"),
                          ("sim-vehicle --no-tcp --duration 0.05 --out udp:no.such.host.invalid:14550",
                          "no.such.host.invalid")],
    "sim-vehicle --serial": [(f"{SIM} --serial ,115200",), (f"{SIM} --serial /dev/null,fast",),
                             (f"{SIM} --serial /dev/null,300", "[1200, 4000000]"),
                             (f"{SIM} --serial no/such/tty", "no/such/tty")],
    "sim-vehicle --speedup": [(f"{SIM} --speedup -1", "[0, 1000]"), (f"{SIM} --speedup 2000", "[0, 1000]"),
                              (f"{SIM} --speedup {NAN}", FINITE), (f"{SIM} --speedup x",)],
    "sim-vehicle --home": [(f"{SIM} --home 1,2,3", "LAT,LON,ALT,HEADING"), (f"{SIM} --home {NAN},0,0,0", FINITE),
                           (f"{SIM} --home 95,0,0,0", "[-89, 89]")],
    "sim-vehicle --waves": [(f"{SIM} --waves stormy", "invalid choice")],  # the old name of --sea
    "sim-vehicle --scenario": [(f"{SIM} --scenario no/such.yaml", "no/such.yaml"), (f"{SIM} --scenario adir", "adir"),
                               (f"{SIM} --scenario empty.yaml", "empty.yaml"),
                               (f"{SIM} --scenario broken.yaml", "broken.yaml"),
                               (f"{SIM} --scenario typo_waypoint.yaml", "acceptance_radus_m"),
                               (f"{SIM} --scenario bad_solver.yaml", "controller.solver", "ipopts"),
                               (f"{SIM} --scenario half_horizon.yaml", "controller.horizon", "15.5")],
    "sim-vehicle --sea": [(f"{SIM} --sea 1.75,0,6,-90",), (f"{SIM} --sea {NAN},35,6,0", FINITE),
                          (f"{SIM} --sea 1,2,3",), (f"{SIM} --sea -1,35,6,0",), (f"{SIM} --sea 1.75,35,0,0",)],
    "sim-vehicle --sea-state": [(f"{SIM} --sea-state 9", "[0, 8]"), (f"{SIM} --sea-state x", "[0, 8]")],
    "sim-vehicle --seed": [(f"{SIM} --seed -1",), (f"{SIM} --seed 4294967296",), (f"{SIM} --seed x",)],
    "sim-vehicle --sea-phase": [(f"{SIM} --sea-phase random", "invalid choice")],
    "sim-vehicle --heave": [(f"{SIM} --heave none", "invalid choice")],
    "sim-vehicle --current": [(f"{SIM} --current 1",), (f"{SIM} --current {NAN},0", FINITE),
                              (f"{SIM} --current 100,0",)],
    "sim-vehicle --params": [(f"{SIM} --params no/such.parm", "no/such.parm"), (f"{SIM} --params adir", "adir"),
                             (f"{SIM} --params bad.parm", "bad.parm")],
    "sim-vehicle --params-store": [(f"{SIM} --params-store adir", "adir"),
                                   (f"{SIM} --params-store afile.txt/params.json", "afile.txt")],
    "sim-vehicle --signing-passphrase": [(f"{SIM} --params-store p.json --signing-passphrase=",)],
    "sim-vehicle --log-dir": [(f"{SIM} --log-dir afile.txt", "afile.txt"),
                              (f"{SIM} --log-dir afile.txt/logs", "afile.txt")],
    "sim-vehicle --duration": [("sim-vehicle --no-tcp --no-out --duration 0",),
                               ("sim-vehicle --no-tcp --no-out --duration -1",),
                               (f"sim-vehicle --no-tcp --no-out --duration {NAN}", FINITE)],
    "sim-vehicle --hide-params": [(f"{SIM} --hide-params RC1_NOPE", "RC1_NOPE"), (f"{SIM} --hide-params 'a b'",),
                                  (f"{SIM} --hide-params RC1_MIN,,RC3_MIN",)],
    "sim-vehicle --lockstep": [(f"{SIM} --lockstep 0",), (f"{SIM} --lockstep 100",), (f"{SIM} --lockstep {NAN}",)],
    "sim-vehicle --lockstep-timeout": [(f"{SIM} --lockstep-timeout 0",), (f"{SIM} --lockstep-timeout 1000",)],
    "sim-vehicle --lockstep-start": [(f"{SIM} --lockstep-start -1",), (f"{SIM} --lockstep-start {NAN}",)],
    "sim-vehicle --json-backend --json-backend": [("sim-vehicle --json-backend 0", "[1, 65535]"),
                                                  ("sim-vehicle --json-backend 70000", "[1, 65535]"),
                                                  ("sim-vehicle --json-backend :9002",),
                                                  ("sim-vehicle --json-backend host:x",)],
    "sim-vehicle --json-backend --waves": [(f"{JSON} --waves stormy", "invalid choice")],
    "sim-vehicle --json-backend --sea": [(f"{JSON} --sea 1.75,0,6,-90",), (f"{JSON} --sea {NAN},35,6,0", FINITE)],
    "sim-vehicle --json-backend --sea-state": [(f"{JSON} --sea-state 9", "[0, 8]"),
                                               (f"{JSON} --sea-state x", "[0, 8]")],
    "sim-vehicle --json-backend --heave": [(f"{JSON} --heave none", "invalid choice")],
    "sim-vehicle --json-backend --current": [(f"{JSON} --current {NAN},0", FINITE)],
    "sim-vehicle --json-backend --vessel": [(f"{JSON} --vessel titanic", "--vessel: 'titanic' is neither a named set"),
                                            (f"{JSON} --vessel bad_config.yaml", "unknown key 'system_id'")],
    "sim-vehicle --vessel": [(f"{SIM} --vessel titanic", "--vessel: 'titanic' is neither a named set"),
                             (f"{SIM} --vessel list.yaml", "expected a vessel mapping")],
    "sim-vehicle --json-backend --scenario": [(f"{JSON} --scenario no/such.yaml", "no/such.yaml"),
                                              (f"{JSON} --scenario empty.yaml", "empty.yaml"),
                                              (f"{JSON} --scenario bad_solver.yaml", "controller.solver")],
    "sim-vehicle --json-backend --heading": [(f"{JSON} --heading 400", "[-360, 360]"),
                                             (f"{JSON} --heading {NAN}", FINITE)],
    "sim-vehicle --json-backend --seed": [(f"{JSON} --seed -1",)],
    "sim-vehicle --json-backend --log-dir": [(f"{JSON} --log-dir afile.txt", "afile.txt"),
                                             (f"{JSON} --log-dir afile.txt/logs", "afile.txt")],
    "sim-vehicle --json-backend --duration": [("sim-vehicle --json-backend 127.0.0.1:39002 --duration 0",)],
}

NO_BAD_VALUE: dict[str, str] = {
    "sim-vehicle --no-tcp": "a switch: no value to get wrong",
    "sim-vehicle --no-out": "a switch: no value to get wrong",
    "sim-vehicle --ideal-sensors": "a switch: no value to get wrong",
    "sim-vehicle --wipe": "a switch: no value to get wrong",
    "sim-vehicle --no-param-error": "a switch: no value to get wrong",
    "sim-vehicle --no-rc-receiver": "a switch: no value to get wrong",
    "sim-vehicle --wait-for-client": "a switch: no value to get wrong",
    "sim-vehicle --verbose": "a switch: no value to get wrong",
    "sim-vehicle --json-backend": "hands the whole command line to the JSON-backend parser, whose own --json-backend "
                                  "has the cases ('sim-vehicle --json-backend --json-backend')",
    "sim-vehicle --json-backend --verbose": "a switch: no value to get wrong",
}


test_every_flag_has_a_case, test_bad_value_is_one_line_exit_2 = table_tests(PARSERS, CASES, NO_BAD_VALUE)



@pytest.mark.parametrize("command", [
    "sim-vehicle --no-tcp --no-out --duration 0.05 --sea 1.75,0,6,-90",  # issue 17: ZeroDivisionError
    "vessel maneuver --preset straight --plot x.xyz",  # issue 17: ValueError from matplotlib
    "vessel maneuver --left 10 --right 10 --csv adir",  # issue 17: IsADirectoryError
    "mavbridge check --max-range nan",  # issue 17: accepted
    "mission download --out no/such/x.plan",  # issue 17: downloaded, then a traceback
])
def test_in_process_is_what_a_shell_sees(command: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                         capsys: pytest.CaptureFixture[str]) -> None:
    """The tables run commands in-process; a real process of a few of the issue's own cases prints the same
    line with the same exit code (argparse, signals and stderr behave alike)."""
    make_fixtures(tmp_path)
    shell = run_as_process(command, tmp_path)
    monkeypatch.chdir(tmp_path)
    here = run_in_process(command, lambda: tuple(capsys.readouterr()))
    assert (shell.code, shell.stderr) == (here.code, here.stderr)
    assert not problems(shell, [])
