"""Bad values for every flag of every `mavbridge` subcommand (experiment, run, demo, check, sweep, tune,
signing setup): exit 2, one line naming the flag, no traceback, nothing written (issue 17 items 8, 10).

A flag added to the parser without a case here (or a reason in ``NO_BAD_VALUE``) fails
``test_every_flag_has_a_case``. Harness and checks: ``tests/system/bad_input.py``.
"""

from __future__ import annotations

import pytest

import mavbridge.cli
from mavbridge.cli.args import check_connection
from vessel.config import ConfigError

from .bad_input import SCENARIO, SWEEP_SPEC, table_tests

PARSERS = {"mavbridge": mavbridge.cli.build_parser()}

EXP = f"mavbridge experiment {SCENARIO}"
RUN = "mavbridge run"
DEMO = "mavbridge demo"
CHECK = "mavbridge check --solves 0"
SWEEP = f"mavbridge sweep {SWEEP_SPEC}"
TUNE = f"mavbridge tune {SCENARIO} --max-time 100"
SIGN = "mavbridge signing setup --signing-passphrase-file pass.txt"
REPORT = "mavbridge report otter.csv"
REPLAY = "mavbridge replay otter.csv --waypoint 10,0"
NAN, FINITE, CHOICE = "nan", "finite", "invalid choice"


def _link_cases(base: str) -> dict[str, list[tuple[str, ...]]]:
    """The flags `run` and `check` share: connection, ids, the companion YAML, retries and signing."""
    command = base.split()[1]
    return {
        f"mavbridge {command} --config": [(f"{base} --config no/such.yaml", "no/such.yaml"),
                                          (f"{base} --config adir", "adir"),
                                          (f"{base} --config broken.yaml", "broken.yaml"),
                                          (f"{base} --config list.yaml", "list.yaml"),
                                          (f"{base} --config bad_config.yaml", "system_id", "[1, 255]")],
        f"mavbridge {command} --connect": [(f"{base} --connect udpin:0.0.0.0:99999", "99999"),
                                           (f"{base} --connect udpin:0.0.0.0",),
                                           (f"{base} --connect tcp:localhost:port",),
                                           (f"{base} --connect no/such/tty", "no/such/tty"),
                                           (f"{base} --connect udpin:nothing.invalid:14999", "cannot resolve"),
                                           (f"{base} --connect udpout:nothing.invalid:14550", "cannot resolve"),
                                           (f"{base} --connect tcp:127.0.0.1:1", "nothing accepts"),
                                           (f"{base} --connect udpin:192.0.2.1:14551", "not an address"),
                                           (f"{base} --connect /dev/no-such-tty,57600", "no such serial")],
        f"mavbridge {command} --baud": [(f"{base} --baud 300", "1200"), (f"{base} --baud fast",)],
        f"mavbridge {command} --sysid": [(f"{base} --sysid 300", "[1, 255]"), (f"{base} --sysid 0", "[1, 255]"),
                                         (f"{base} --config cfg_ok.yaml --sysid 300", "[1, 255]"),
                                         (f"{base} --sysid one",)],
        f"mavbridge {command} --compid": [(f"{base} --compid 256", "[1, 255]"), (f"{base} --compid -1", "[1, 255]")],
        f"mavbridge {command} --output": [(f"{base} --output servo", CHOICE)],
        f"mavbridge {command} --scenario": [(f"{base} --scenario no/such.yaml", "no/such.yaml"),
                                            (f"{base} --scenario adir", "adir"),
                                            (f"{base} --scenario empty.yaml", "empty.yaml")],
        f"mavbridge {command} --solver": [(f"{base} --solver fast", CHOICE)],
        f"mavbridge {command} --waypoint": [(f"{base} --waypoint 1,2,3", "N,E"),
                                            (f"{base} --waypoint {NAN},0", FINITE)],
        f"mavbridge {command} --max-range": [(f"{base} --max-range -1", "> 0"), (f"{base} --max-range {NAN}", FINITE),
                                             (f"{base} --max-range 0", "> 0"), (f"{base} --max-range far",)],
        f"mavbridge {command} --command-timeout": [(f"{base} --command-timeout 0",),
                                                   (f"{base} --command-timeout {NAN}", FINITE)],
        f"mavbridge {command} --command-retries": [(f"{base} --command-retries -1",),
                                                   (f"{base} --command-retries x",)],
        f"mavbridge {command} --param-budget": [(f"{base} --param-budget 0.5", "[1, 600]"),
                                                (f"{base} --param-budget 601", "[1, 600]"),
                                                (f"{base} --param-budget {NAN}", FINITE)],
        f"mavbridge {command} --signing-passphrase-file": [
            (f"{base} --signing-passphrase-file no/such.txt", "no/such.txt"),
            (f"{base} --signing-passphrase-file adir", "adir"),
            (f"{base} --signing-passphrase-file empty.yaml", "empty.yaml")],
    }


CASES: dict[str, list[tuple[str, ...]]] = {
    "mavbridge experiment scenario": [("mavbridge experiment no/such.yaml", "no/such.yaml"),
                                      ("mavbridge experiment adir", "adir"),
                                      ("mavbridge experiment empty.yaml", "empty.yaml"),
                                      ("mavbridge experiment broken.yaml", "broken.yaml")],
    "mavbridge experiment --out": [(f"{EXP} --out afile.txt", "afile.txt"),
                                   (f"{EXP} --out afile.txt/run", "afile.txt")],
    "mavbridge experiment --jobs": [(f"{EXP} --jobs 0", ">= 1"), (f"{EXP} --jobs two",)],
    "mavbridge experiment --only": [(f"{EXP} --only nope", "nope")],
    "mavbridge experiment --solver": [(f"{EXP} --solver fast", CHOICE)],
    "mavbridge experiment --plant": [(f"{EXP} --plant sails", CHOICE)],
    "mavbridge experiment --wave-source": [(f"{EXP} --wave-source guessed", CHOICE),
                                           (f"{EXP} --wave-source stormy", CHOICE)],
    "mavbridge experiment --waves": [(f"{EXP} --waves guessed", CHOICE)],  # the old name of --wave-source
    **_link_cases(RUN),
    "mavbridge run --wave-source": [(f"{RUN} --wave-source stormy", CHOICE)],
    "mavbridge run --waves": [(f"{RUN} --waves stormy", CHOICE)],  # the old name of --wave-source
    "mavbridge run --attitude-form": [(f"{RUN} --attitude-form yaw", CHOICE),
                                      (f"{RUN} --attitude-form tau", "--output attitude_target only")],
    "mavbridge run --arm": [(f"{RUN} --dry-run --arm", "--dry-run")],
    "mavbridge run --set-mode": [(f"{RUN} --dry-run --set-mode", "--dry-run")],
    "mavbridge run --dry-run": [(f"{RUN} --arm --dry-run", "--arm")],
    "mavbridge run --identify": [(f"{RUN} --identify --output attitude_target", "--identify"),
                                 (f"{RUN} --identify --waypoint 10,10", "--identify")],
    "mavbridge run --max-time": [(f"{RUN} --max-time 0",), (f"{RUN} --max-time -5",),
                                 (f"{RUN} --max-time {NAN}", FINITE)],
    "mavbridge run --out": [(f"{RUN} --out afile.txt", "afile.txt"), (f"{RUN} --out afile.txt/run", "afile.txt")],
    "mavbridge run --start-at": [(f"{RUN} --start-at -1",), (f"{RUN} --start-at {NAN}", FINITE)],
    "mavbridge run --engage-after": [(f"{RUN} --engage-after -1", "[0, 3600]"), (f"{RUN} --engage-after 4000", "3600"),
                                     (f"{RUN} --engage-after {NAN}", FINITE)],
    "mavbridge demo --engage-after": [(f"{DEMO} --engage-after -1", "[0, 3600]"),
                                      (f"{DEMO} --engage-after {NAN}", FINITE)],
    "mavbridge demo --speedup": [(f"{DEMO} --speedup 0", "(0, 100]"), (f"{DEMO} --speedup 101", "(0, 100]"),
                                 (f"{DEMO} --speedup {NAN}", "not finite")],
    "mavbridge demo --solver": [(f"{DEMO} --solver fast", CHOICE)],
    "mavbridge demo --output": [(f"{DEMO} --output servo", CHOICE)],
    "mavbridge demo --attitude-form": [(f"{DEMO} --attitude-form yaw", CHOICE),
                                       (f"{DEMO} --output rc_override --attitude-form rate",
                                        "--output attitude_target only")],
    "mavbridge demo --sim-params": [(f"{DEMO} --sim-params no/such.parm", "no/such.parm"),
                                    (f"{DEMO} --sim-params adir", "adir")],
    "mavbridge demo --scenario": [(f"{DEMO} --scenario no/such.yaml", "no/such.yaml"),
                                  (f"{DEMO} --scenario adir", "adir")],
    "mavbridge demo --wave-source": [(f"{DEMO} --wave-source stormy", CHOICE)],
    "mavbridge demo --waves": [(f"{DEMO} --waves stormy", CHOICE)],  # the old name of --wave-source
    "mavbridge demo --seed": [(f"{DEMO} --seed -1", "[0, 4294967295]"),
                              (f"{DEMO} --seed 4294967296", "[0, 4294967295]"),
                              (f"{DEMO} --seed 1.5", "integer"), (f"{DEMO} --seed nan", "integer")],
    "mavbridge demo --out": [(f"{DEMO} --out afile.txt", "afile.txt"), (f"{DEMO} --out afile.txt/run", "afile.txt")],
    **_link_cases(CHECK),
    "mavbridge check --solves": [("mavbridge check --solves -1", ">= 0"), ("mavbridge check --solves many",)],
    "mavbridge check --attitude-form": [(f"{CHECK} --attitude-form yaw", CHOICE),
                                        (f"{CHECK} --attitude-form tau", "--output attitude_target only")],
    "mavbridge check --port": [(f"{CHECK} --port 10", "[0, 9]"), (f"{CHECK} --port -1", "[0, 9]"),
                               (f"{CHECK} --port x",)],
    "mavbridge check --timeout": [(f"{CHECK} --timeout 0",), (f"{CHECK} --timeout -3",),
                                  (f"{CHECK} --timeout {NAN}", FINITE)],
    "mavbridge sweep spec": [("mavbridge sweep no/such.yaml", "no/such.yaml"), ("mavbridge sweep adir", "adir"),
                             ("mavbridge sweep empty.yaml", "empty.yaml")],
    "mavbridge sweep --executor": [(f"{SWEEP} --executor cloud",), (f"{SWEEP} --executor dask-local:0",)],
    "mavbridge sweep --jobs": [(f"{SWEEP} --jobs 0", ">= 1")],
    "mavbridge sweep --out": [(f"{SWEEP} --out afile.txt", "afile.txt"),
                              (f"{SWEEP} --out afile.txt/sweep", "afile.txt")],
    "mavbridge sweep --heatmap": [(f"{SWEEP} --heatmap controller.r", "controller.r"),
                                  (f"{SWEEP} --heatmap controller.r,nope", "nope")],
    "mavbridge tune scenario": [("mavbridge tune no/such.yaml --max-time 100", "no/such.yaml"),
                                ("mavbridge tune adir --max-time 100", "adir")],
    "mavbridge tune --min-reduction": [(f"mavbridge tune {SCENARIO} --min-reduction 0.99", "(0, 0.95)"),
                                       (f"mavbridge tune {SCENARIO} --min-reduction {NAN}", FINITE),
                                       (f"mavbridge tune {SCENARIO} --min-reduction half",)],
    "mavbridge tune --max-time": [(f"mavbridge tune {SCENARIO} --max-time 0", "> 0"),
                                  (f"mavbridge tune {SCENARIO} --max-time {NAN}", FINITE),
                                  (f"mavbridge tune {SCENARIO}", "--min-reduction")],
    "mavbridge tune --executor": [(f"{TUNE} --executor cloud",)],
    "mavbridge tune --jobs": [(f"{TUNE} --jobs 0", ">= 1")],
    "mavbridge tune --out": [(f"{TUNE} --out afile.txt", "afile.txt"), (f"{TUNE} --out afile.txt/tune", "afile.txt")],
    "mavbridge tune --headings": [(f"{TUNE} --headings north", "[-360, 360]"),
                                  (f"{TUNE} --headings 400", "[-360, 360]"),
                                  (f"{TUNE} --headings 90,{NAN}", FINITE)],
    "mavbridge tune --solver": [(f"{TUNE} --solver fast", CHOICE)],
    "mavbridge tune --sea-seeds": [(f"{TUNE} --sea-seeds a", "distinct comma-separated integers"),
                                   (f"{TUNE} --sea-seeds 1,1", "distinct"), (f"{TUNE} --sea-seeds -1", "[0, "),
                                   (f"{TUNE} --sea-seeds 1_0", "[0, "), (f"{TUNE} --sea-seeds 2147483648", "[0, "),
                                   (f"{TUNE} --sea-seeds 1,2", "regular wave")],
    "mavbridge signing setup --config": [(f"{SIGN} --config no/such.yaml", "no/such.yaml"),
                                         (f"{SIGN} --config broken.yaml", "broken.yaml")],
    "mavbridge signing setup --connect": [(f"{SIGN} --connect udpin:0.0.0.0:99999", "99999")],
    "mavbridge signing setup --baud": [(f"{SIGN} --baud 300", "1200")],
    "mavbridge signing setup --signing-passphrase-file": [
        ("mavbridge signing setup --signing-passphrase-file no/such.txt", "no/such.txt"),
        ("mavbridge signing setup --signing-passphrase-file empty.yaml", "empty.yaml"),
        ("mavbridge signing setup", "needed")],
    "mavbridge signing setup --timeout": [(f"{SIGN} --timeout 0",), (f"{SIGN} --timeout {NAN}", FINITE),
                                          (f"{SIGN} --timeout -1",)],
}



def _log_cases(base: str) -> dict[str, list[tuple[str, ...]]]:
    """The flags `report` and `replay` share: the log's format, the autopilot, the companion YAML, the scenario."""
    command = base.split()[1]
    return {
        f"mavbridge {command} --out": [(f"{base} --out afile.txt", "afile.txt"),
                                       (f"{base} --out afile.txt/run", "afile.txt")],
        f"mavbridge {command} --format": [(f"{base} --format excel", CHOICE),
                                          (f"{base} --format tlog", "otter.csv", "looks like otter-csv")],
        f"mavbridge {command} --sysid": [(f"{base} --sysid 0", "[1, 255]"), (f"{base} --sysid 300", "[1, 255]"),
                                         (f"{base} --sysid one",), (f"{base} --sysid 3", ".tlog logs only")],
        f"mavbridge {command} --config": [(f"{base} --config no/such.yaml", "no/such.yaml"),
                                          (f"{base} --config broken.yaml", "broken.yaml"),
                                          (f"{base} --config bad_config.yaml", "system_id", "[1, 255]")],
        f"mavbridge {command} --scenario": [(f"{base} --scenario no/such.yaml", "no/such.yaml"),
                                            (f"{base} --scenario adir", "adir")],
    }


CASES.update({
    "mavbridge report log": [("mavbridge report no/such.csv", "no/such.csv"), ("mavbridge report adir", "adir"),
                             ("mavbridge report empty.yaml", "empty.yaml", "empty"),
                             ("mavbridge report afile.txt", "afile.txt", "not a log"),
                             ("mavbridge report otter.csv afile.txt", "afile.txt", "not a log")],
    **_log_cases(REPORT),
    "mavbridge replay log": [("mavbridge replay no/such.csv", "no/such.csv"),
                             ("mavbridge replay afile.txt", "afile.txt", "not a log"),
                             ("mavbridge replay otter.csv", "otter.csv", "--waypoint")],
    **_log_cases(REPLAY),
    "mavbridge replay --solver": [(f"{REPLAY} --solver fast", CHOICE)],
    "mavbridge replay --output": [(f"{REPLAY} --output servo", CHOICE)],
    "mavbridge replay --attitude-form": [(f"{REPLAY} --attitude-form yaw", CHOICE),
                                         (f"{REPLAY} --attitude-form tau", "--output attitude_target only")],
    "mavbridge replay --waypoint": [("mavbridge replay otter.csv --waypoint 1,2,3", "N,E"),
                                    (f"mavbridge replay otter.csv --waypoint {NAN},0", FINITE)],
    "mavbridge replay --from": [(f"{REPLAY} --from -1", "[0, inf)"), (f"{REPLAY} --from {NAN}", "[0, inf)"),
                                (f"{REPLAY} --from soon",)],
    "mavbridge identify log": [("mavbridge identify no/such.tlog", "no/such.tlog"),
                               ("mavbridge identify afile.txt", "afile.txt", "not a log")],
    "mavbridge identify --out": [("mavbridge identify otter.csv --out afile.txt", "afile.txt")],
    "mavbridge identify --base": [("mavbridge identify otter.csv --base nope", "nope")],
    "mavbridge replay --to": [(f"{REPLAY} --to -1", "[0, inf)"), (f"{REPLAY} --from 10 --to 5", "--from")],
})

NO_BAD_VALUE: dict[str, str] = {
    "mavbridge run --lockstep": "a switch: no value to get wrong (simulation only, documented)",
    "mavbridge run --delay-compensation": "a switch (--no-delay-compensation): no value to get wrong",
    "mavbridge run --realtime": "a switch (--no-realtime): no value to get wrong; never fatal (tests/system/"
                                "test_realtime.py)",
    "mavbridge demo --lockstep": "a switch: no value to get wrong",
    "mavbridge demo --direct": "a switch: no value to get wrong",
    "mavbridge sweep --yes": "a switch: no value to get wrong",
    "mavbridge replay --plan-all": "a switch: no value to get wrong",
}


test_every_flag_has_a_case, test_bad_value_is_one_line_exit_2 = table_tests(PARSERS, CASES, NO_BAD_VALUE)


@pytest.mark.parametrize("url", ["udpin:0.0.0.0:14551", "udp:127.0.0.1:14551", "udpin::14551", "udpout:10.0.0.2:14550",
                                 "tcp:127.0.0.1:5760", "tcpin:0.0.0.0:5760", "mcast:", "/dev/null", "/dev/null,57600",
                                 "127.0.0.1:14550", "0.0.0.0:14550", "localhost:14550", "uds:/tmp/ap.sock",
                                 "wsserver:0.0.0.0:5760"])
def test_good_connections_pass(url: str) -> None:
    """The forms pymavlink opens (network, a bare HOST:PORT as MAVProxy users write it, multicast, Unix and web
    sockets, a serial device with or without a baud) are not refused."""
    check_connection(url, "--connect")


@pytest.mark.parametrize("url", ["127.0.0.1:99999", "127.0.0.1:port", ":14550"])
def test_a_bare_host_port_with_a_bad_port_names_the_form(url: str) -> None:
    """A bare HOST:PORT is pymavlink's listening UDP: a bad one is not called a missing serial device."""
    with pytest.raises(ConfigError, match=r"--connect: .*expected HOST:PORT .*\[1, 65535\]"):
        check_connection(url, "--connect")
