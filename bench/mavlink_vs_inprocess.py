"""Benchmark: Balanced and Direct in-process (τ and propeller plants) and over MAVLink on both output paths.

Run: OMP_NUM_THREADS=1 python bench/mavlink_vs_inprocess.py [--seeds 1,2] [--solver nrti] [--wave-source scenario]
     [--paths rc_override,attitude_target] [--attitude-form heading|rate|tau] [--no-in-process] [--speedup 10]
     [--keep DIR]

In-process: the experiment runner on the paper's sea, once per plant. Over MAVLink: `mavbridge demo
--lockstep --seed N` (a real `sim-vehicle`, MAVSDK's waypoint upload, `mavbridge run`), once on RC override
(MANUAL) and once on SET_ATTITUDE_TARGET (GUIDED), Balanced and ``--direct`` (R = 0) for each seed. With
``--wave-source scenario`` (the default) the companion flies on the simulator's true sea and the simulator has
exact sensors and the phase from boot, so the seeds repeat a run (the repeat check); ``--wave-source estimated``
flies on the companion's own estimate. One table: average and maximum roll, arrival, the cut of Balanced
against Direct on the same path, the arrival against the in-process propeller-plant Balanced run, and the
step time (median / p99). Issue 15 asks for a cut >= 35 % and an arrival within 10 % on each path.
About 40 s per MAVLink run here.
"""

from __future__ import annotations

import argparse
import dataclasses
import tempfile
from pathlib import Path
from typing import Any

from mavlink_estimated import (  # this folder is on sys.path when run as a script
    add_form_flag,
    demo_parser,
    exit_with,
    form_flags,
    parse_demo_flags,
    run_demo,
)

from mavbridge.lab.experiment import run_scenario
from mavbridge.lab.scenario import Scenario

PATHS = ("rc_override", "attitude_target")


def paths(text: str) -> list[str]:
    """--paths: a comma-separated subset of the output paths."""
    chosen = [part.strip() for part in text.split(",") if part.strip()]
    if not chosen or any(part not in PATHS for part in chosen):
        raise argparse.ArgumentTypeError(f"expected a comma-separated subset of {','.join(PATHS)}, got {text!r}")
    return chosen


def in_process(plant: str, direct: bool, solver: str) -> dict[str, Any]:
    """The experiment runner's metrics for Balanced (or Direct, R = 0) on ``plant``."""
    base = Scenario(name="direct" if direct else "balanced")
    controller = base.controller.replace(solver=solver, **({"r": 0.0} if direct else {}))
    return run_scenario(dataclasses.replace(base, plant=plant, controller=controller), None, plots=False).metrics


def over_mavlink(output: str, direct: bool, seed: int, args: argparse.Namespace, out: Path) -> dict[str, Any]:
    """One lockstep demo with this bench's solver and waves; the companion's metrics.json."""
    return run_demo(seed, direct, args.speedup, out, output, "--solver", args.solver,
                    "--wave-source", args.wave_source,
                    *form_flags(output, args.attitude_form))


def arrival(metrics: dict[str, Any]) -> float | None:
    """Arrival time (s since engaging), None when the run did not arrive."""
    if metrics.get("phase", "ARRIVED") != "ARRIVED":
        return None
    return metrics.get("time_to_waypoint_s")


def table_row(label: str, balanced: dict[str, Any], direct: dict[str, Any], reference_s: float | None) -> str:
    """One Markdown line: Balanced's figures, Direct's roll, the cut and the arrival against the reference."""
    t_bal = arrival(balanced)
    cut = 100.0 * (1.0 - balanced["avg_roll_deg"] / direct["avg_roll_deg"])
    versus = f"{100.0 * (t_bal / reference_s - 1.0):+.1f} %" if t_bal and reference_s else "n/a"
    return (f"| {label} | {balanced['avg_roll_deg']:.3f} | {balanced['max_roll_deg']:.2f} | "
            f"{t_bal if t_bal is not None else 'n/a'} | {direct['avg_roll_deg']:.3f} | "
            f"{arrival(direct) if arrival(direct) is not None else 'n/a'} | {cut:.1f} % | {versus} | "
            f"{balanced['solve_ms_median']:.2f} / {balanced['solve_ms_p99']:.2f} |")


def main() -> int:
    """Print the comparison table; exit 1 when a run left no figures."""
    p = demo_parser(__doc__.splitlines()[0], [1, 2])
    p.add_argument("--solver", choices=("asrti", "nrti"), default="nrti",
                   help="NMPC solver (default nrti, the companion's)")
    p.add_argument("--wave-source", choices=("scenario", "estimated"), default="scenario",
                   help="the companion's waves over MAVLink (default scenario: the simulator's truth)")
    p.add_argument("--paths", type=paths, default=list(PATHS),
                   help="output paths over MAVLink, comma-separated (default rc_override,attitude_target)")
    add_form_flag(p)
    p.add_argument("--no-in-process", dest="in_process", action="store_false", help="skip the in-process rows")
    args = parse_demo_flags(p)
    root = args.keep or Path(tempfile.mkdtemp(prefix="mavlink-vs-inprocess-"))
    print("| path | Balanced avg roll ° | max roll ° | arrival s | Direct avg roll ° | Direct arrival s | cut | "
          "arrival vs in-process propellers | step ms median / p99 |\n|---|---|---|---|---|---|---|---|---|",
          flush=True)
    reference_s = None
    for plant in ("tau", "propellers") if args.in_process else ():
        balanced, direct = in_process(plant, False, args.solver), in_process(plant, True, args.solver)
        reference_s = arrival(balanced) if plant == "propellers" else reference_s
        print(table_row(f"in-process, {plant} plant", balanced, direct, reference_s), flush=True)
    for output in args.paths:
        for seed in args.seeds:
            balanced = over_mavlink(output, False, seed, args, root / f"{output}-seed{seed}-balanced")
            direct = over_mavlink(output, True, seed, args, root / f"{output}-seed{seed}-direct")
            print(table_row(f"MAVLink {output}, seed {seed}", balanced, direct, reference_s), flush=True)
    print(f"\n(runs in {root})")
    return 0


if __name__ == "__main__":
    exit_with(main)
