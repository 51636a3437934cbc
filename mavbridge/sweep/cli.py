"""``mavbridge sweep SPEC.yaml`` and ``mavbridge tune SCENARIO``: flags, runs on an executor, summaries."""

from __future__ import annotations

import argparse
import dataclasses
import math
import signal
import sys
from pathlib import Path

from mavbridge.cli.args import positive
from mavbridge.lab.scenario import Scenario, load_scenarios
from mavbridge.nmpc.config import SOLVERS
from mavbridge.sweep.executors import open_executor, parse_executor
from mavbridge.sweep.runner import SweepOutcome, run_sweep
from mavbridge.sweep.spec import SweepSpec, load_spec
from mavbridge.sweep.summary import case_rows, markdown_table, plot_heatmap, plot_tradeoff, write_csv
from mavbridge.sweep.tune import ROBUST_HEADINGS_DEG, Target, report, tune
from vessel import ConfigError
from vessel.argtypes import check_output_folder
from vessel.sea.waves import CalmWater
from vessel.wording import counted


def _executor_flag(text: str) -> str:
    try:
        parse_executor(text)
    except ConfigError as exc:
        raise argparse.ArgumentTypeError(str(exc).removeprefix("--executor: ")) from None
    return text


def add_sweep_parser(sub: argparse._SubParsersAction) -> None:
    """The ``sweep`` subcommand."""
    p = sub.add_parser("sweep", help="many in-process closed loops over axes of a base scenario",
                       description="Expand SPEC (a base scenario plus axes) into cases, run each in-process "
                                   "on a process pool or a Dask cluster, and write one result file per case "
                                   "(a rerun skips finished cases), summary.csv, summary.md and plots.")
    p.add_argument("spec", help="sweep SPEC YAML (base, axes, sample, reference, max_cases)")
    p.add_argument("--executor", type=_executor_flag, default="local",
                   help="local (process pool, default) | dask-local:N | tcp://HOST:PORT (a Dask scheduler)")
    p.add_argument("--jobs", type=positive, default=None, help="processes for the local executor (default: all cores)")
    p.add_argument("--out", default=None, help="output folder (default: runs/sweep-<spec name>); reused to resume")
    p.add_argument("--yes", action="store_true", help="run a sweep larger than the spec's max_cases")
    p.add_argument("--heatmap", default=None, metavar="X_AXIS,Y_AXIS",
                   help="two axes for heatmap.png (default: the first two axes, if there are two)")


def add_tune_parser(sub: argparse._SubParsersAction) -> None:
    """The ``tune`` subcommand."""
    p = sub.add_parser("tune", help="the paper's tuning procedure as batches of in-process runs",
                       description="Tune Q and S (R = 0), raise R, raise Q where the boat stops aiming for the "
                                   "waypoint, raise S where progress is slow; report the fastest weights that "
                                   "meet the target and re-run them from several start headings.")
    p.add_argument("scenario", help="a single-scenario YAML file (sea, start, waypoint, controller settings)")
    p.add_argument("--min-reduction", type=float, default=None,
                   help="average-roll reduction vs Direct, a fraction in (0, 0.95) (default: none; give it, "
                        "--max-time or both)")
    p.add_argument("--max-time", type=float, default=None,
                   help="latest arrival, s, > 0 (default: none; give it, --min-reduction or both)")
    p.add_argument("--executor", type=_executor_flag, default="local",
                   help="local (default) | dask-local:N | tcp://HOST:PORT")
    p.add_argument("--jobs", type=positive, default=None, help="processes for the local executor (default: all cores)")
    p.add_argument("--out", default=None, help="output folder (default: runs/tune-<scenario name>); reused to resume")
    p.add_argument("--headings", default=None, help="start headings for the robustness re-runs, deg "
                                                     "(default 90,60,120,30,150)")
    p.add_argument("--solver", choices=SOLVERS, default=None,
                   help=f"override the scenario's controller.solver: {', '.join(SOLVERS)} (default: the scenario's, "
                        "ipopt unless its file says)")
    p.add_argument("--sea-seeds", default=None, metavar="N,...",
                   help="an irregular sea: fly every trial on each of these draws (a draw's seed sets both "
                        "sea.spectrum.seed and estimation.seed, the sensor noise; 0..2147483647) and tune on the mean, "
                        "so the weights fit the sea state rather than one draw of it (default: the scenario's own)")


SEED_MAX = 2**31 - 1  # estimation.seed's range (the sea's own reaches 2³² − 1)


def _seed_list(text: str | None, scenario: Scenario) -> list[int]:
    """--sea-seeds as distinct plain integers in [0, 2³¹ − 1] (a draw's sea and sensor-noise seed); only for a sea
    with waves drawn from a spectrum; else ConfigError."""
    if text is None:
        return []
    items = [v.strip() for v in text.split(",")]
    values = [int(v) for v in items if v.isdigit() and v.isascii()]
    if len(values) != len(items) or len(set(values)) != len(values) or not all(v <= SEED_MAX for v in values):
        raise ConfigError(f"--sea-seeds: expected distinct comma-separated integers in [0, {SEED_MAX}], got {text!r}")
    spectrum = scenario.world.sea.spectrum
    if spectrum is None:
        raise ConfigError("--sea-seeds: the scenario's sea is a regular wave or calm (no sea.spectrum): it has no "
                          "draws")
    if isinstance(spectrum.wave_field(), CalmWater):
        raise ConfigError("--sea-seeds: the scenario's sea.spectrum is calm water (sea state 0): it has no draws")
    return values


def _float_list(text: str, flag: str) -> list[float]:
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        values = []
    if not values or not all(math.isfinite(v) and -360 <= v <= 360 for v in values):
        raise ConfigError(f"{flag}: expected comma-separated finite degrees in [-360, 360], got {text!r}")
    return values


def _tune_target(args: argparse.Namespace) -> Target:
    red, tmax = args.min_reduction, args.max_time
    if red is None and tmax is None:
        raise ConfigError("--min-reduction / --max-time: give at least one target")
    if red is not None and not (math.isfinite(red) and 0 < red < 0.95):
        raise ConfigError(f"--min-reduction: expected a finite fraction in (0, 0.95), got {red:g}")
    if tmax is not None and not (math.isfinite(tmax) and tmax > 0):
        raise ConfigError(f"--max-time: expected finite seconds > 0, got {tmax:g}")
    return Target(red, tmax)


def tune_command(args: argparse.Namespace) -> int:
    """Run the tuning procedure; 0 if weights meeting the target were found, 1 if not, 130 if interrupted."""
    target = _tune_target(args)
    headings = _float_list(args.headings, "--headings") if args.headings else list(ROBUST_HEADINGS_DEG)
    scenarios = load_scenarios(args.scenario)
    if len(scenarios) != 1:
        raise ConfigError(f"{args.scenario}: {len(scenarios)} runs; give a single scenario")
    if args.solver:
        scenarios = [dataclasses.replace(scenarios[0], controller=scenarios[0].controller.replace(solver=args.solver))]
    sea_seeds = _seed_list(args.sea_seeds, scenarios[0])
    out = Path(args.out) if args.out else Path("runs") / f"tune-{Path(args.scenario).stem}"
    check_output_folder(out, "--out")
    previous = signal.signal(signal.SIGTERM, _terminate_as_interrupt)
    try:
        with open_executor(args.executor, args.jobs) as executor:
            result = tune(scenarios[0], target, executor, out, say=lambda line: print(line, file=sys.stderr),
                          headings_deg=headings, sea_seeds=sea_seeds)
    except KeyboardInterrupt:
        print("tune: interrupted; rerun the same command to resume (finished runs are kept)", file=sys.stderr)
        return 130
    finally:
        signal.signal(signal.SIGTERM, previous)
    text = report(result, target)
    (out / "tune.md").write_text(text, encoding="utf-8")
    sys.stdout.write(text)
    return 0 if result.best is not None else 1


def _heatmap_axes(spec: SweepSpec, text: str | None) -> tuple[str, str] | None:
    names = list(spec.axes)
    if text is None:
        return (names[0], names[1]) if len(names) >= 2 else None
    parts = [p.strip() for p in text.split(",")]
    if len(parts) != 2 or any(p not in names for p in parts):
        raise ConfigError(f"--heatmap: expected two axes of the spec ({', '.join(names)}), got {text!r}")
    return parts[0], parts[1]


def _terminate_as_interrupt(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


def write_summary(spec: SweepSpec, outcome: SweepOutcome, out: Path, heatmap: tuple[str, str] | None) -> str:
    """summary.csv, summary.md, tradeoff.png (and heatmap.png) from every finished case; the table."""
    rows = case_rows(spec, outcome.results)
    write_csv(out / "summary.csv", rows)
    table = markdown_table(spec, rows)
    (out / "summary.md").write_text(table, encoding="utf-8")
    if rows:
        plot_tradeoff(out / "tradeoff.png", rows)
        if heatmap is not None:
            plot_heatmap(out / "heatmap.png", rows, *heatmap)
    return table


def sweep_command(args: argparse.Namespace) -> int:
    """Run the sweep; 0 when every case finished, 1 if some failed, 130 when interrupted."""
    spec = load_spec(args.spec, allow_large=args.yes)
    heatmap = _heatmap_axes(spec, args.heatmap)
    out = Path(args.out) if args.out else Path("runs") / f"sweep-{Path(args.spec).stem}"
    check_output_folder(out, "--out")
    previous = signal.signal(signal.SIGTERM, _terminate_as_interrupt)
    try:
        with open_executor(args.executor, args.jobs) as executor:
            print(f"sweep: {len(spec.cases)} cases ({len(spec.all_scenarios())} runs with references) "
                  f"on {args.executor} -> {out}", file=sys.stderr)
            outcome = run_sweep(spec, executor, out)
    finally:
        signal.signal(signal.SIGTERM, previous)
    sys.stdout.write(write_summary(spec, outcome, out, heatmap))
    for cid, why in outcome.failed.items():
        print(f"sweep: case {cid} failed: {why}", file=sys.stderr)
    if outcome.interrupted:
        print(f"sweep: interrupted; {counted(outcome.remaining, 'run')} remain — rerun the same command to finish them",
              file=sys.stderr)
        return 130
    print(f"sweep: {counted(outcome.ran, 'run')} done, {outcome.skipped} already done, {len(outcome.failed)} failed "
          f"-> {out}/summary.md", file=sys.stderr)
    return 1 if outcome.failed else 0
