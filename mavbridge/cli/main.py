"""``mavbridge`` console script: ``experiment`` (in-process), ``run`` (the companion), ``demo`` (everything),
``check`` (preflight against any ArduPilot Rover), ``report`` and ``replay`` (a trial's logs), ``identify`` (a
model of the boat from its logs)."""

from __future__ import annotations

import argparse
import dataclasses
import os
import signal
import sys
from pathlib import Path

from mavbridge.cli.args import positive
from mavbridge.cli.run import add_demo_parser, add_run_parser, demo_command, run_command
from mavbridge.cli.signing import add_signing_parser, signing_command
from mavbridge.nmpc.config import SOLVERS
from vessel import ConfigError
from vessel.argtypes import OneLineParser, add_renamed, add_version

PLANTS = ("tau", "propellers")  # mirrors mavbridge.lab.scenario.PLANTS (kept import-light)
WAVE_SOURCES = ("truth", "estimated")  # mirrors mavbridge.lab.scenario.WAVE_SOURCES


_Parser = OneLineParser  # one-line errors, exit 2; a bare command lists its subcommands (vessel.argtypes)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with its subcommands."""
    parser = _Parser(prog="mavbridge", description="Roll-aware NMPC companion for the Otter USV.")
    add_version(parser)
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    exp = sub.add_parser("experiment", help="closed-loop runs of a scenario file in-process (no MAVLink)",
                         description="Run every run of a scenario file in closed loop with the vessel plant; "
                                     "write timeseries.csv, metrics.json, scenario.yaml and plots per run, "
                                     "and table3.md for a set of runs.")
    exp.add_argument("scenario", help="scenario YAML file (a single scenario or base + runs)")
    exp.add_argument("--out", help="output folder (default: runs/<scenario file name>)")
    exp.add_argument("--jobs", type=positive, default=None,
                     help="parallel processes (default: all cores)")
    exp.add_argument("--only", default=None, help="comma-separated run names to run (default: all)")
    exp.add_argument("--solver", choices=SOLVERS, default=None,
                     help=f"override every run's controller.solver: {', '.join(SOLVERS)} (default: each run's own, "
                          "ipopt unless its file says)")
    exp.add_argument("--plant", choices=PLANTS, default=None,
                     help="override every run's plant: tau (rigid body driven by τ) or propellers (shaft-speed plant) "
                          "(default: each run's own, tau unless its file says)")
    exp.add_argument("--wave-source", choices=(*WAVE_SOURCES, "scenario"), default=None,
                     help="where the NMPC's waves come from, over every run's estimation.waves: truth (the true wave "
                          "to the NMPC) or estimated (the wave estimator on simulated sensors at 20 Hz); default: "
                          "each run's own (truth unless its file says; scenario, as the companion says it, is the "
                          "same). The plant's realism (heave, hidden phase) stays as the scenario's estimation section "
                          "says. --waves is its old name")
    add_renamed(exp, "--waves", "--wave-source", choices=(*WAVE_SOURCES, "scenario"))
    from mavbridge.field.cli import add_replay_parser, add_report_parser  # (the rooms' parsers import
    from mavbridge.identify.cli import add_identify_parser
    from mavbridge.preflight.cli import add_check_parser  # mavbridge.cli.args: imported here, a room imported
    from mavbridge.sweep.cli import add_sweep_parser, add_tune_parser  # first does not import itself back)

    add_run_parser(sub)
    add_demo_parser(sub)
    add_check_parser(sub)
    add_sweep_parser(sub)
    add_tune_parser(sub)
    add_signing_parser(sub)
    add_report_parser(sub)
    add_replay_parser(sub)
    add_identify_parser(sub)
    return parser


def _experiment(args: argparse.Namespace) -> int:
    from mavbridge.lab.experiment import experiment
    from mavbridge.lab.scenario import load_scenarios

    scenarios = load_scenarios(args.scenario)
    if args.only:
        wanted = [name.strip() for name in args.only.split(",") if name.strip()]
        names = [s.name for s in scenarios]
        missing = [name for name in wanted if name not in names]
        if missing:
            raise ConfigError(f"--only: no run named '{missing[0]}' in {args.scenario} "
                              f"(runs: {', '.join(names)})")
        scenarios = [s for s in scenarios if s.name in wanted]
    if args.solver:
        scenarios = [dataclasses.replace(s, controller=s.controller.replace(solver=args.solver)) for s in scenarios]
    if args.plant:
        scenarios = [dataclasses.replace(s, plant=args.plant) for s in scenarios]
    if args.wave_source:
        source = "truth" if args.wave_source == "scenario" else args.wave_source
        scenarios = [dataclasses.replace(s, estimation=dataclasses.replace(s.estimation, waves=source))
                     for s in scenarios]
    from mavbridge.lab.runlog import fresh_run_folder

    for stop in (signal.SIGTERM, signal.SIGHUP):  # stopped like Ctrl-C: the finished runs are written, the rest listed
        signal.signal(stop, _interrupt)
    out = fresh_run_folder(Path(args.out) if args.out else Path("runs") / Path(args.scenario).stem)
    experiment(scenarios, out, args.jobs)
    return 0


def _interrupt(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


def _first_line(exc: BaseException) -> str:
    """The error's own first line, without Python's quotes (its repr only when it has no text)."""
    text = str(exc)
    return text.splitlines()[0] if text else repr(exc)


def main(argv: list[str] | None = None) -> int:
    """Entry point; bad input prints one line to stderr and exits with code 2."""
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    args = build_parser().parse_args(argv)
    from mavbridge.field.cli import replay_command, report_command
    from mavbridge.identify.cli import identify_command
    from mavbridge.preflight.cli import check_command
    from mavbridge.sweep.cli import sweep_command, tune_command

    commands = {"experiment": _experiment, "run": run_command, "demo": demo_command, "check": check_command,
                "sweep": sweep_command, "tune": tune_command, "signing": signing_command, "report": report_command,
                "replay": replay_command, "identify": identify_command}
    try:
        if args.command in commands:
            return commands[args.command](args)
    except (ConfigError, ValueError) as exc:
        sys.stderr.write(f"mavbridge: error: {_first_line(exc)}\n")
        return 2
    except (FloatingPointError, RuntimeError) as exc:
        sys.stderr.write(f"mavbridge: run failed: {_first_line(exc)}\n")
        return 1
    except KeyboardInterrupt:
        sys.stderr.write("mavbridge: interrupted\n")
        return 130
    return 2


if __name__ == "__main__":
    raise SystemExit(main())
