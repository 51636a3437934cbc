"""Benchmark: Balanced against Direct over MAVLink, both flying on the companion's own wave estimate.

Run: OMP_NUM_THREADS=1 python bench/mavlink_estimated.py [--seeds 1,2,3] [--output rc_override|attitude_target|both]
     [--attitude-form heading|rate|tau] [--speedup 10] [--keep DIR]

Each seed is one pair of real `mavbridge demo --lockstep --seed N` runs: `sim-vehicle` in the paper's sea
with its realistic defaults (the hull heaving with the sea, a hidden phase drawn from the seed, sensor
noise), the waypoint uploaded with MAVSDK, and `mavbridge run --wave-source estimated` on the output path given
(RC override in MANUAL, or SET_ATTITUDE_TARGET in GUIDED): once with the paper's Balanced weights, once
with ``--direct`` (R = 0). Lockstep with a fixed start time makes a pair repeat
exactly on any machine; the companion's estimator has watched the drifting boat from its connection
until the start (300 s of autopilot time at speedup 10). Prints per seed the average roll, the arrival
time (since engaging), the share of steps with the roll term on, the IMU share of the estimator's
samples, and the cut of Balanced against Direct; then the mean cut. Issue 12 asks for >= 35 %.
About 1.5 minutes per pair here.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

from mavbridge.companion.outputs import ATTITUDE_FORMS


def seeds(text: str) -> list[int]:
    """--seeds: comma-separated whole numbers >= 0."""
    try:
        values = [int(part) for part in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated whole numbers, got {text!r}") from None
    if not values or min(values) < 0:
        raise argparse.ArgumentTypeError(f"{text!r}: seeds are whole numbers >= 0")
    return values


def run_demo(seed: int, direct: bool, speedup: float, out: Path, output: str, *extra: str) -> dict[str, Any]:
    """One lockstep demo (``extra``: more demo flags); the companion's metrics.json (its phase says whether it
    arrived)."""
    cmd = [sys.executable, "-m", "mavbridge.cli", "demo", "--lockstep", "--seed", str(seed), "--speedup",
           f"{speedup:g}", "--out", str(out), "--output", output, *(["--direct"] if direct else []), *extra]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=1800)
    metrics_file = out / "companion" / "metrics.json"
    if not metrics_file.exists():
        raise RuntimeError(f"demo (seed {seed}, {'direct' if direct else 'balanced'}) left no metrics: "
                           f"exit {done.returncode}\n{done.stdout[-1500:]}{done.stderr[-1500:]}")
    return json.loads(metrics_file.read_text())


def add_form_flag(p: argparse.ArgumentParser) -> None:
    """--attitude-form, as every MAVLink bench takes it (see ``form_flags``)."""
    p.add_argument("--attitude-form", choices=ATTITUDE_FORMS, default=None,
                   help="the GUIDED path's target (default: the companion's; tau also gives the simulator "
                        "deploy/otter-guided-tau.parm)")


def form_flags(output: str, attitude_form: str | None) -> list[str]:
    """The demo flags for the GUIDED path's ``attitude_form`` (None: the companion's default); the tau form also
    gives the simulator deploy/otter-guided-tau.parm (I and D gains 0, WP_SPEED 3.5), as that form needs."""
    if output != "attitude_target" or not attitude_form:
        return []
    form = ["--attitude-form", attitude_form]
    if attitude_form == "tau":
        form += ["--sim-params", str(Path(__file__).resolve().parents[1] / "deploy" / "otter-guided-tau.parm")]
    return form


def row(seed: int, output: str, balanced: dict[str, Any], direct: dict[str, Any]) -> tuple[str, float | None]:
    """The table line of one seed and its cut (None if a run did not arrive)."""
    def cell(m: dict[str, Any]) -> str:
        arrived = m["phase"] == "ARRIVED"
        return (f"{m['avg_roll_deg']:6.2f} {m['time_to_waypoint_s'] if arrived else 'n/a':>7} "
                f"{m['waves']['roll_term_fraction']:6.2f} {m['waves'].get('imu_sample_share') or 0:5.2f}")

    both = balanced["phase"] == "ARRIVED" and direct["phase"] == "ARRIVED"
    cut = 100.0 * (1.0 - balanced["avg_roll_deg"] / direct["avg_roll_deg"]) if both else None
    return f"{output:>15} {seed:>5} | {cell(balanced)} | {cell(direct)} | " + (f"{cut:5.1f} %" if cut is not None else
                                                                   "  n/a (not arrived)"), cut


def demo_parser(description: str, default_seeds: list[int]) -> argparse.ArgumentParser:
    """The flags every lockstep-demo bench takes: --seeds, --speedup, --keep."""
    p = argparse.ArgumentParser(description=description)
    p.add_argument("--seeds", type=seeds, default=default_seeds,
                   help=f"simulator seeds (default {','.join(map(str, default_seeds))})")
    p.add_argument("--speedup", type=float, default=10.0, help="the demo's speedup (default 10)")
    p.add_argument("--keep", type=Path, help="keep the run folders under this (new) folder")
    return p


def parse_demo_flags(p: argparse.ArgumentParser) -> argparse.Namespace:
    """Parsed flags; --speedup outside [0.5, 50] is one line and exit 2."""
    args = p.parse_args()
    if not 0.5 <= args.speedup <= 50:
        p.error(f"--speedup: {args.speedup:g} is outside [0.5, 50]")
    return args


def exit_with(main: Callable[[], int]) -> None:
    """Run a bench's ``main`` and exit with its status; a run that left no figures (RuntimeError) is one
    message on stderr and exit 1."""
    try:
        sys.exit(main())
    except RuntimeError as exc:
        print(exc, file=sys.stderr)
        sys.exit(1)


def main() -> int:
    p = demo_parser(__doc__.splitlines()[0], [1, 2, 3])
    p.add_argument("--output", choices=("rc_override", "attitude_target", "both"), default="rc_override",
                   help="the companion's output path (default rc_override)")
    add_form_flag(p)
    args = parse_demo_flags(p)
    root = args.keep or Path(tempfile.mkdtemp(prefix="mavlink-estimated-"))
    outputs = ("rc_override", "attitude_target") if args.output == "both" else (args.output,)
    print("    output      seed | Balanced: roll deg, arrival s, roll term, IMU | Direct (same)         | cut")
    complete = True
    for output in outputs:
        cuts = []
        for seed in args.seeds:
            form = form_flags(output, args.attitude_form)
            balanced = run_demo(seed, False, args.speedup, root / f"{output}-seed{seed}-balanced", output, *form)
            direct = run_demo(seed, True, args.speedup, root / f"{output}-seed{seed}-direct", output, *form)
            line, cut = row(seed, output, balanced, direct)
            print(line, flush=True)
            if cut is not None:
                cuts.append(cut)
        complete = complete and len(cuts) == len(args.seeds)
        if cuts:
            print(f"{output}: mean cut over {len(cuts)} seed(s): {sum(cuts) / len(cuts):.1f} %  (runs in {root})")
    return 0 if complete else 1


if __name__ == "__main__":
    sys.exit(main())
