"""``mavbridge sweep SPEC.yaml``: parse the flags, expand the spec, run it, write the summary."""

from __future__ import annotations

import argparse
import signal
import sys
from pathlib import Path

from vessel import ConfigError

from .executors import open_executor, parse_executor
from .runner import SweepOutcome, run_sweep
from .spec import SweepSpec, load_spec
from .summary import case_rows, markdown_table, plot_heatmap, plot_tradeoff, write_csv


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
    p.add_argument("--jobs", type=int, default=None, help="processes for the local executor (default: all cores)")
    p.add_argument("--out", default=None, help="output folder (default: runs/sweep-<spec name>); reused to resume")
    p.add_argument("--yes", action="store_true", help="run a sweep larger than the spec's max_cases")
    p.add_argument("--heatmap", default=None, metavar="X_AXIS,Y_AXIS",
                   help="two axes for heatmap.png (default: the first two axes, if there are two)")


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
    if args.jobs is not None and args.jobs < 1:
        raise ConfigError(f"--jobs: expected a whole number >= 1, got {args.jobs}")
    spec = load_spec(args.spec, allow_large=args.yes)
    heatmap = _heatmap_axes(spec, args.heatmap)
    out = Path(args.out) if args.out else Path("runs") / f"sweep-{Path(args.spec).stem}"
    if out.exists() and not out.is_dir():
        raise ConfigError(f"--out: {out} exists and is not a folder")
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
        print(f"sweep: interrupted; {outcome.remaining} run(s) remain — rerun the same command to finish them",
              file=sys.stderr)
        return 130
    print(f"sweep: {outcome.ran} run(s) done, {outcome.skipped} already done, {len(outcome.failed)} failed "
          f"-> {out}/summary.md", file=sys.stderr)
    return 1 if outcome.failed else 0
