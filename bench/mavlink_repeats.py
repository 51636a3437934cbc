"""Benchmark: how well lockstep MAVLink runs repeat — the same seed flown N times on each output path.

Run: OMP_NUM_THREADS=1 python bench/mavlink_repeats.py [--runs 5] [--seeds 1] [--paths rc_override,attitude_target]
     [--solver nrti] [--attitude-form heading|rate|tau] [--speedup 10] [--keep DIR]

Each run is `mavbridge demo --lockstep --seed N --wave-source scenario` (a real `sim-vehicle`, MAVSDK's upload,
`mavbridge run`), Balanced. Prints every run's average roll and arrival, then per path the spread
(max − min) / mean of each; issue 15 asks for five runs within 1 %. Runs may go side by side with other
work: lockstep makes simulated time wait for every command, so load slows a run but does not change it.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from mavlink_estimated import (  # this folder is on sys.path when run as a script
    add_form_flag,
    demo_parser,
    exit_with,
    form_flags,
    parse_demo_flags,
    run_demo,
)
from mavlink_vs_inprocess import PATHS, arrival, paths


def spread(values: list[float]) -> float:
    """(max − min) / mean, 0 for one value."""
    mean = sum(values) / len(values)
    return (max(values) - min(values)) / mean if mean else float("inf")


def main() -> int:
    """Print the runs and the spread per path; exit 1 when a run did not arrive."""
    p = demo_parser(__doc__.splitlines()[0], [1])
    p.add_argument("--runs", type=int, default=5, help="runs per path and seed (default 5)")
    p.add_argument("--paths", type=paths, default=list(PATHS), help="output paths, comma-separated")
    p.add_argument("--solver", choices=("asrti", "nrti"), default="nrti",
                   help="NMPC solver (default nrti, the companion's)")
    add_form_flag(p)
    args = parse_demo_flags(p)
    if not 2 <= args.runs <= 50:
        p.error(f"--runs: {args.runs} is outside [2, 50]")
    root = args.keep or Path(tempfile.mkdtemp(prefix="mavlink-repeats-"))
    print("| path | seed | run | avg roll ° | arrival s |\n|---|---|---|---|---|", flush=True)
    summary, status = [], 0
    for output in args.paths:
        for seed in args.seeds:
            rolls, times = [], []
            for run in range(1, args.runs + 1):
                m = run_demo(seed, False, args.speedup, root / f"{output}-seed{seed}-run{run}", output,
                             "--solver", args.solver, "--wave-source", "scenario",
                             *form_flags(output, args.attitude_form))
                t = arrival(m)
                print(f"| {output} | {seed} | {run} | {m['avg_roll_deg']:.4f} | {t if t is not None else 'n/a'} |",
                      flush=True)
                if t is None:
                    status = 1
                    continue
                rolls.append(m["avg_roll_deg"])
                times.append(t)
            if rolls:
                summary.append(f"| {output} | {seed} | {len(rolls)} of {args.runs} | {100 * spread(rolls):.2f} % | "
                               f"{100 * spread(times):.2f} % |")
    print("\n| path | seed | arrived | avg roll spread | arrival spread |\n|---|---|---|---|---|")
    print("\n".join(summary))
    print(f"\n(runs in {root})")
    return status


if __name__ == "__main__":
    exit_with(main)
