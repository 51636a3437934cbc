"""The `mavbridge check` subcommand: arguments, then probe + solve time into one report."""

from __future__ import annotations

import argparse
import time
from typing import Any

from mavbridge.cli.args import (
    BAUD_HELP,
    CONFIG_HELP,
    CONNECT_HELP,
    DEFAULT_COMPID,
    DEFAULT_SYSID,
    REAL_TIME_SOLVER,
    SOLVER_HELP,
    config_from_flags,
    count,
    from_config,
    link_flags,
    model_line,
    parse_north_east,
    positive_metres,
    refuse_form_without_guided,
    single_scenario,
)
from mavbridge.companion.choices import OUTPUTS
from mavbridge.companion.outputs import ATTITUDE_FORMS
from mavbridge.link.signing import add_link_arguments
from mavbridge.nmpc.config import SOLVERS
from mavbridge.preflight.report import Report
from vessel.config import ConfigError
from vessel.geo import DEFAULT_MAX_RANGE_M

DEFAULT_SOLVES = 300  # mirrors solve_time.DEFAULT_SOLVES (kept import-light: no CasADi for --help)


def add_check_parser(sub: Any) -> None:
    """`mavbridge check`: the preflight check."""
    check = sub.add_parser("check", help="preflight check of an ArduPilot Rover for the companion",
                           description="Connect like `mavbridge run`, then check the heartbeat, the parameters "
                                       "the companion relies on, the achieved stream rates, GPS and home, the "
                                       "mission, and the NMPC's solve time on this computer. Prints PASS/WARN/"
                                       "FAIL per item; exit code 1 on any FAIL.")
    check.add_argument("--config", help=f"companion YAML (the same file `mavbridge run` uses; {CONFIG_HELP})")
    check.add_argument("--connect", help=CONNECT_HELP)
    check.add_argument("--baud", type=int, help=BAUD_HELP)
    check.add_argument("--sysid", type=int, help=f"our system id, [1, 255] "
                                                 f"({from_config('system_id', str(DEFAULT_SYSID))})")
    check.add_argument("--compid", type=int, help=f"our component id, [1, 255] "
                                                  f"({from_config('component_id', str(DEFAULT_COMPID))})")
    check.add_argument("--output", choices=OUTPUTS,
                       help=f"the output to check for: rc_override (MANUAL) or attitude_target (GUIDED) "
                            f"({from_config('output', 'rc_override')})")
    check.add_argument("--attitude-form", choices=ATTITUDE_FORMS, help="attitude_target: the form to check for "
                       "(tau: Rover's D gains 0, WP_SPEED letting full throttle through; default from config)")
    check.add_argument("--scenario", help="scenario YAML (default: the paper's Balanced run)")
    check.add_argument("--solver", choices=SOLVERS, default=REAL_TIME_SOLVER, help=SOLVER_HELP)
    check.add_argument("--solves", type=count, default=DEFAULT_SOLVES,
                       help=f"NMPC solves to time (default {DEFAULT_SOLVES}; 0 skips the solve-time check)")
    check.add_argument("--port", type=int, default=2, metavar="N",
                       help="stream-rate set of the companion's port: SRn_* / MAV(n+1)_*, [0, 9] (default 2 = "
                            "SERIAL2 on a typical Rover; the simulator's 127.0.0.1:14551 output is 2 as well)")
    check.add_argument("--waypoint", type=parse_north_east, metavar="N,E",
                       help="check this waypoint (m north,east of home) instead of the mission (default: the "
                            "autopilot's mission; FAIL at --max-range or farther)")
    check.add_argument("--max-range", type=positive_metres, default=DEFAULT_MAX_RANGE_M, metavar="M",
                       help=f"largest distance of a waypoint from home in m (default {DEFAULT_MAX_RANGE_M:g}, the "
                            "companion's engage limit)")
    check.add_argument("--timeout", type=float, help=f"wait this long for the autopilot, [0.5, 600] s "
                                                     f"({from_config('connect_timeout_s', '30')})")
    add_link_arguments(check)


def check_command(args: argparse.Namespace) -> int:
    """Carry out `mavbridge check`; 1 if anything FAILed, else 0."""
    from mavbridge.link.port_guard import refuse_if_taken
    from mavbridge.preflight.probe import Probe
    from mavbridge.preflight.solve_time import solve_time

    if not 0 <= args.port <= 9:
        raise ConfigError(f"--port: {args.port} is outside the allowed range [0, 9]")
    config = config_from_flags(args.config, {**link_flags(args), "output": ("--output", args.output),
                                             "attitude_form": ("--attitude-form", args.attitude_form),
                                             "connect_timeout_s": ("--timeout", args.timeout)})
    refuse_form_without_guided(args.attitude_form, config.output)
    config.signing_key()  # a bad passphrase file: one line, exit 2
    refuse_if_taken(config.connect)
    scenario = single_scenario(args.scenario, args.solver, config.model)
    report = Report()
    print(f"mavbridge check: {config.connect} as {config.system_id}/{config.component_id}, output {config.output}, "
          f"scenario {scenario.name} ({scenario.controller.solver}, period {scenario.controller.period_s:g} s)")
    print(model_line(scenario))
    start = time.monotonic()
    Probe(config, scenario, report, args.port, args.waypoint, args.max_range).run()
    solve_time(scenario, args.solves, report)  # after the link is closed
    print(report.table())
    print(f"({time.monotonic() - start:.1f} s)")
    return 1 if report.failed else 0
