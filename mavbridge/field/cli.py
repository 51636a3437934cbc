"""The command lines of `mavbridge report` and `mavbridge replay` (argument parsing and dispatch)."""

from __future__ import annotations

import argparse
import math
import shlex
from typing import Any

from mavbridge.cli.args import REAL_TIME_SOLVER, SOLVER_HELP, parse_north_east
from mavbridge.companion.choices import OUTPUTS
from mavbridge.companion.outputs import ATTITUDE_FORMS
from mavbridge.field.logs import FORMAT_HELP, FORMATS
from mavbridge.nmpc.config import SOLVERS

SYSID_HELP = "the autopilot's system id, for a .tlog that holds several (default: the first autopilot HEARTBEAT's)"
CONFIG_HELP = ("the companion YAML the boat flies with: the estimator's roll sign and GPS lag (default: the "
               "simulator's, roll sign +1; a real hull: deploy/companion-boat.yaml)")
SCENARIO_HELP = "scenario YAML whose vessel the estimator's hull response is calibrated on (default: Balanced's)"


def system_id(text: str) -> int:
    """A MAVLink system id in [1, 255] (argparse type)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a system id in [1, 255], got {text!r}") from None
    if not 1 <= value <= 255:
        raise argparse.ArgumentTypeError(f"{value} is outside the allowed range [1, 255]")
    return value


def log_time(text: str) -> float:
    """A time on the log's timeline, seconds >= 0 (argparse type)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected seconds >= 0, got {text!r}") from None
    if not math.isfinite(value) or value < 0:
        raise argparse.ArgumentTypeError(f"{text} is outside the allowed range [0, inf) s")
    return value


def _log_flags(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--format", choices=FORMATS, default="auto", help=f"{FORMAT_HELP} (default auto)")
    parser.add_argument("--sysid", type=system_id, help=SYSID_HELP)
    parser.add_argument("--config", help=CONFIG_HELP)
    parser.add_argument("--scenario", help=SCENARIO_HELP)


def add_report_parser(sub: Any) -> None:
    """`mavbridge report`: a trial's logs as printed figures, one HTML page and JSON."""
    report = sub.add_parser(
        "report", help="a trial's logs (tlog, DataFlash, Otter CSV) as figures, an HTML page and JSON",
        description="Read MAVLink .tlogs (any ground station, any autopilot), ArduPilot DataFlash .bin/.log and "
                    "Otter API .csv logs; print the average roll, the segments per mode and per engagement of our "
                    "companion, the sea the companion's wave estimator sees; write DIR/report.html and "
                    "DIR/report.json.")
    report.add_argument("log", nargs="+", metavar="LOG", help="the logs to report")
    report.add_argument("--out", metavar="DIR", help="folder for report.html and report.json (default "
                                                     "runs/report-<time>; an existing run is never overwritten)")
    _log_flags(report)


def add_replay_parser(sub: Any) -> None:
    """`mavbridge replay`: the companion fed from a log, beside what the boat did; sends nothing."""
    replay = sub.add_parser(
        "replay", help="what the companion would have commanded, fed from a log at its own clock (sends nothing)",
        description="Feed the companion's state, wave estimator and NMPC from a log at the log's own clock and "
                    "write what it would have commanded beside what the boat did (RC inputs, servo outputs): "
                    "DIR/replay.csv, DIR/replay.json (the estimator's figures as the live run's metrics.json "
                    "gives them) and DIR/replay.png. Nothing is sent anywhere.")
    replay.add_argument("log", metavar="LOG", help="the log to replay")
    replay.add_argument("--out", metavar="DIR", help="folder for replay.csv and replay.png (default "
                                                     "runs/replay-<time>)")
    _log_flags(replay)
    replay.add_argument("--solver", choices=SOLVERS, default=REAL_TIME_SOLVER, help=SOLVER_HELP)
    replay.add_argument("--output", choices=OUTPUTS, help="the command path to replay: rc_override (MANUAL) or "
                                                          "attitude_target (GUIDED) (default: the --config's, else the "
                                                          "companion run's own for its tlog, else rc_override)")
    replay.add_argument("--attitude-form", choices=ATTITUDE_FORMS,
                        help=f"attitude_target's form: {', '.join(ATTITUDE_FORMS)} (default: the --config's, else "
                             "the companion run's own for its tlog, else tau)")
    replay.add_argument("--waypoint", type=parse_north_east, metavar="N,E",
                        help="fly to this point (m north, east of the log's home) instead of the log's mission "
                             "(default: the log's mission)")
    replay.add_argument("--from", dest="start", type=log_time, metavar="S",
                        help="replay from this time of the log, s >= 0 (default 0: its start)")
    replay.add_argument("--to", dest="stop", type=log_time, metavar="S",
                        help="replay up to this time of the log, s > --from (default: its end)")
    replay.add_argument("--plan-all", action="store_true",
                        help="also plan where the companion would not command (disarmed, another mode), on a wave "
                             "gate of their own (default: off; as the companion, the NMPC then plans from its "
                             "engagement on, so that its commands are the ones it sent)")


def command_line(args: argparse.Namespace, positional: list[str], flags: dict[str, str]) -> str:
    """The command as given (for the page's 'made by' line): the positionals and the flags that were set."""
    words = ["mavbridge", args.command, *positional]
    for flag, name in flags.items():
        value = getattr(args, name, None)
        if value is not None and value != "auto":
            words += [flag, ",".join(f"{v:g}" for v in value) if isinstance(value, tuple) else str(value)]
    return " ".join(shlex.quote(w) for w in words)


def report_command(args: argparse.Namespace) -> int:
    """Carry out `mavbridge report`."""
    from mavbridge.field.report import report_command as run

    flags = {"--out": "out", "--format": "format", "--sysid": "sysid", "--config": "config", "--scenario": "scenario"}
    return run(args.log, args.format, args.sysid, args.config, args.scenario, args.out,
               command_line(args, args.log, flags))


def replay_command(args: argparse.Namespace) -> int:
    """Carry out `mavbridge replay`."""
    from mavbridge.field.replay import ReplayRequest
    from mavbridge.field.replay import replay_command as run

    return run(ReplayRequest(args.log, args.format, args.sysid, args.config, args.scenario, args.out, args.solver,
                             args.output, args.attitude_form, args.waypoint, args.start, args.stop, args.plan_all))
