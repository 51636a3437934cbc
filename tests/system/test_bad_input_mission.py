"""Bad values for every flag of `mission upload`, `download` and `clear`: exit 2, one line naming the flag, no
traceback, nothing written, and nothing sent: every case is refused before MAVSDK connects (issue 17 items 8, 10).

A flag added to the parser without a case here (or a reason in ``NO_BAD_VALUE``) fails
``test_every_flag_has_a_case``. Harness and checks: ``tests/system/bad_input.py``.
"""

from __future__ import annotations

import mission.cli

from .bad_input import table_tests

PARSERS = {"mission": mission.cli.build_parser()}

UP = "mission upload --waypoint 10,0"
NAN, FINITE = "nan", "finite"


def _link_cases(command: str) -> dict[str, list[tuple[str, ...]]]:
    """--connect and --timeout, which every subcommand has."""
    base = {"upload": UP, "download": "mission download", "clear": "mission clear"}[command]
    return {
        f"mission {command} --connect": [(f"{base} --connect udpin://0.0.0.0:99999", "[1, 65535]"),
                                         (f"{base} --connect carrier-pigeon", "udpin://HOST:PORT"),
                                         (f"{base} --connect http://host:80", "http"),
                                         (f"{base} --connect udpin:0.0.0.0", "udpin://HOST:PORT"),
                                         (f"{base} --connect tcpout://nothing.invalid:5760", "cannot resolve"),
                                         (f"{base} --connect udpout://nothing.invalid:14550", "cannot resolve"),
                                         (f"{base} --connect udpin://nothing.invalid:14550", "cannot resolve"),
                                         (f"{base} --connect tcpout://127.0.0.1:1", "nothing accepts"),
                                         (f"{base} --connect udpin://192.0.2.1:14550", "not an address"),
                                         (f"{base} --connect serial:///dev/no-such-tty:57600", "no such serial")],
        f"mission {command} --timeout": [(f"{base} --timeout 0", "(0, 600]"), (f"{base} --timeout 601", "(0, 600]"),
                                         (f"{base} --timeout {NAN}", "not finite"), (f"{base} --timeout soon",)],
    }


CASES: dict[str, list[tuple[str, ...]]] = {
    **_link_cases("upload"),
    "mission upload --waypoint": [("mission upload --waypoint 1,2,3", "A,B"),
                                  (f"mission upload --waypoint {NAN},0", FINITE),
                                  ("mission upload --waypoint 100000,0", "--max-range")],
    "mission upload --latlon": [("mission upload --latlon 95,0", "[-90, 90]"),
                                ("mission upload --latlon 0,200", "[-180, 180]"),
                                (f"mission upload --latlon {NAN},0", FINITE)],
    "mission upload file": [("mission upload no/such.plan", "no/such.plan"),
                            ("mission upload adir", "adir is a folder"),
                            ("mission upload afile.txt", "afile.txt"), ("mission upload empty.yaml", "empty.yaml")],
    "mission upload --max-range": [(f"{UP} --max-range -1", "> 0"), (f"{UP} --max-range {NAN}", FINITE),
                                   ("mission upload --waypoint 10,0 --max-range 5", "--max-range 5")],
    **_link_cases("download"),
    "mission download --out": [("mission download --out no/such/x.plan", "no/such"),
                               ("mission download --out x.kml", ".kml"),
                               ("mission download --out adir", "adir"),
                               ("mission download --out afile.txt/x.plan", "afile.txt is a file")],
    **_link_cases("clear"),
}

NO_BAD_VALUE: dict[str, str] = {}


test_every_flag_has_a_case, test_bad_value_is_one_line_exit_2 = table_tests(PARSERS, CASES, NO_BAD_VALUE)


def test_pymavlink_form_is_mavsdk_form() -> None:
    """`--connect udpin:0.0.0.0:14562` (the companion's form) means MAVSDK's udpin://0.0.0.0:14562."""
    args = mission.cli.build_parser().parse_args(["clear", "--connect", "udpin:0.0.0.0:14562"])
    assert args.connect == "udpin://0.0.0.0:14562"
    args = mission.cli.build_parser().parse_args(["clear", "--connect", "serial:///dev/ttyUSB0:57600"])
    assert args.connect == "serial:///dev/ttyUSB0:57600"
