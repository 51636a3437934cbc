"""`vessel` command line: open-water maneuvers on the bare Otter plant, and irregular-sea records."""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence

from vessel.argtypes import OneLineParser, add_renamed, add_version, check_output_file, naming, plot_formats
from vessel.config import ConfigError
from vessel.maneuver import PRESETS, Maneuver, maneuver_figures, plot, run_maneuver, write_csv
from vessel.params import PARAMETER_SETS, load_parameters, otter_parameters
from vessel.plant import INTEGRATORS
from vessel.sea import cli as seacli
from vessel.world import SEA_PRESETS

EXIT_USAGE = 2


# OneLineParser: one-line errors, exit 2; a bare command lists its subcommands (vessel.argtypes)


def _number(text: str) -> float:
    """A finite float for argparse; NaN and inf are refused here so messages name the flag."""
    value = float(text)
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"{text!r} is not a finite number")
    return value


def build_parser() -> OneLineParser:
    """The `vessel` parser with its `maneuver` and `sea` subcommands."""
    parser = OneLineParser(prog="vessel", description=__doc__)
    add_version(parser)
    sub = parser.add_subparsers(dest="command", required=True, parser_class=OneLineParser)
    man = sub.add_parser("maneuver", help="run a standard open-water maneuver on the bare plant",
                         description="Shaft commands are percent of n_max (negative = reverse).")
    man.add_argument("--preset", choices=sorted(PRESETS),
                     help=f"a named maneuver, one of {', '.join(sorted(PRESETS))}; flags given override it "
                          "(default: none: --left and --right are required)")
    man.add_argument("--left", type=_number, help="left (port) shaft speed, %% of n_max, [-100, 100] (default: "
                                                  "the preset's; required without --preset)")
    man.add_argument("--right", type=_number, help="right (starboard) shaft speed, %% of n_max, [-100, 100] "
                                                   "(default: the preset's; required without --preset)")
    man.add_argument("--duration", type=_number, help="simulated time in s, (0, 3600] (default 60)")
    man.add_argument("--dt", type=_number, help="integration step in s, (0, 0.1] (default 0.01)")
    man.add_argument("--roll-deg", type=_number, help="initial roll in degrees, [-60, 60] (default: the preset's, "
                                                      "else 0)")
    man.add_argument("--pitch-deg", type=_number, help="initial pitch in degrees, [-60, 60] (default: the preset's, "
                                                       "else 0)")
    man.add_argument("--zigzag-deg", type=_number, help="zig-zag: swap sides at ±this heading change, deg, [0, 90]; 0 "
                                                        "= no zig-zag (default: the preset's, else 0)")
    man.add_argument("--integrator", choices=INTEGRATORS, default="rk4",
                     help="the plant's integrator: rk4 (default) or euler")
    group = man.add_mutually_exclusive_group()
    group.add_argument("--parameter-set", choices=PARAMETER_SETS, default="published",
                       help="named Otter parameter set (default: published, quirks included)")
    group.add_argument("--params", metavar="FILE", help="YAML parameter file (base set + overrides; default: "
                                                       "none, --parameter-set's set)")
    man.add_argument("--sea", choices=tuple(SEA_PRESETS), default="calm", metavar="NAME",
                     help=f"a named sea (vessel.world presets, one of {', '.join(SEA_PRESETS)}: paper is the paper's "
                          "waves from the East; default calm; --waves is its old name)")
    add_renamed(man, "--waves", "--sea", choices=tuple(SEA_PRESETS))
    man.add_argument("--csv", metavar="PATH",
                     help="write t_s and the states, units in the names (north_m, roll_rad, ...) (default: none, "
                          "figures printed only)")
    man.add_argument("--plot", metavar="PATH", help="write a plot of the track and time series, its format by the "
                                                    "extension (.png, .pdf, .svg, ...; default: none)")
    seacli.add_parser(sub)
    return parser


def _maneuver_from_args(args: argparse.Namespace) -> Maneuver:
    """Merge preset and flags into a validated Maneuver."""
    settings: dict[str, float] = dict(PRESETS.get(args.preset, {})) if args.preset else {}
    for flag, key in (("left", "left_pct"), ("right", "right_pct"), ("duration", "duration_s"),
                      ("dt", "dt_s"), ("roll_deg", "roll_deg"), ("pitch_deg", "pitch_deg"),
                      ("zigzag_deg", "zigzag_deg")):
        value = getattr(args, flag)
        if value is not None:
            settings[key] = value
    if not args.preset and (args.left is None or args.right is None):
        raise ConfigError("--left and --right are required without --preset (percent of n_max, [-100, 100])")
    with naming("--params"):
        params = load_parameters(args.params) if args.params else otter_parameters(args.parameter_set)
    sea = SEA_PRESETS[args.sea]
    decays = [name for name in ("roll", "pitch") if settings.get(f"{name}_deg", 0.0) != 0.0]
    if decays and sea.height_m > 0:  # waves drive the roll: the 'decay' would be the wave's period, never damped
        raise ConfigError(f"--sea {args.sea}: a free {' and '.join(decays)} decay cannot be measured in waves "
                          f"(they drive the motion: its period would be the wave's {sea.period_s:g} s); use --sea "
                          "calm, or no initial roll/pitch")
    waves = sea.waves()
    return Maneuver(**settings, integrator=args.integrator, params=params, waves=waves)


def _print_figures(figures: dict[str, float]) -> None:
    """Figures as aligned 'name  value' lines."""
    for name, value in figures.items():
        print(f"  {name:<26} {value:10.4f}")


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the `vessel` console script."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command == "sea":
        return seacli.run(args)
    try:
        maneuver = _maneuver_from_args(args)
        if args.csv:
            check_output_file(args.csv, "--csv")  # before the run: never compute, then fail on the name
        if args.plot:
            check_output_file(args.plot, "--plot", plot_formats())
        result = run_maneuver(maneuver)
    except ConfigError as exc:
        print(f"vessel {args.command}: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except FloatingPointError as exc:
        print(f"vessel {args.command}: error: {exc} (try a smaller --dt or --integrator rk4)",
              file=sys.stderr)
        return 1
    m = maneuver
    print(f"maneuver: left {m.left_pct:g} %, right {m.right_pct:g} %, {m.duration_s:g} s at dt {m.dt_s:g} s "
          f"({m.integrator}), roll {m.roll_deg:g} deg, pitch {m.pitch_deg:g} deg")
    _print_figures(maneuver_figures(result))
    try:
        if args.csv:
            write_csv(result, args.csv)
            print(f"csv:  {args.csv}")
        if args.plot:
            plot(result, args.plot)
            print(f"plot: {args.plot}")
    except OSError as exc:
        print(f"vessel {args.command}: error: cannot write {exc.filename}: {exc.strerror}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
