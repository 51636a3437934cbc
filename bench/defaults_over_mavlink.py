"""Benchmark: the roll cut over MAVLink flown exactly as `mavbridge demo` runs by default (issue 29).

Run: OMP_NUM_THREADS=1 python bench/defaults_over_mavlink.py [--paths rc_override,attitude_target]
     [--seas paper,other] [--seeds 1,2,3] [--keep DIR]

Per output path × sea × seed, one pair of `mavbridge demo` runs with every flag at its default — paced (no
lockstep), the demo's speedup (5), the nrti solver, waves estimated from the boat's own motion, the GUIDED path
in its default form with the simulator's stock Rover gains, the companion engaging 30 s (autopilot time) after it
connects as a pilot would — once with the scenario's Balanced weights and once with `--direct` (R = 0). Only
`--scenario`, `--output`, `--seed` (the simulator's hidden wave phase and sensor noise) and `--out` are given.
Seas: ``paper`` (scenarios/balanced.yaml, 1.75 m / 35 m / 6 s towards West) and ``other``
(scenarios/balanced_other_sea.yaml, 1.5 m / 30 m / 5.5 s towards 150°, a sea the controller was not tuned on).

Prints per pair: Direct's and Balanced's average roll and arrival time (from engaging), the cut, the bound
1.25 × T_direct / (1 − cut) on Balanced's arrival and the ratio to it, the time from the estimator's first motion
sample to its first confident wave estimate (autopilot time), and, from the simulator's true path after engaging,
how far Balanced went past the waypoint along the line from where it engaged and how many turns it made around it
within 25 m (``mavbridge.lab.path_metrics``); then per path × sea the mean and smallest cut. Paced runs on a
shared machine are not exactly repeatable: the seed fixes the sea, not the scheduler. About 1.5 minutes a pair.
"""

from __future__ import annotations

import argparse
import csv
import json
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from mavbridge.lab.path_metrics import loops_around, overshoot_m

ROOT = Path(__file__).resolve().parents[1]
SEAS = {"paper": ROOT / "scenarios" / "balanced.yaml", "other": ROOT / "scenarios" / "balanced_other_sea.yaml"}
PATHS = ("rc_override", "attitude_target")
BOUND_FACTOR = 1.25  # issue 29: arrival <= 1.25 x T_direct / (1 - cut)


def _list(kind: type, allowed: tuple[str, ...] | None = None) -> Any:
    def parse(text: str) -> list:
        try:
            values = [kind(part) for part in text.split(",") if part]
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a comma-separated list, got {text!r}") from None
        bad = [v for v in values if allowed is not None and v not in allowed]
        if not values or bad or (kind is int and min(values) < 0):
            what = ", ".join(allowed) if allowed else "whole numbers >= 0"
            raise argparse.ArgumentTypeError(f"{text!r}: allowed {what}")
        return values
    return parse


def fly(scenario: Path, output: str, seed: int, direct: bool, out: Path) -> dict[str, Any]:
    """One default demo; its companion metrics plus the true path's figures after engaging."""
    cmd = [sys.executable, "-m", "mavbridge.cli", "demo", "--scenario", str(scenario), "--output", output,
           "--seed", str(seed), "--out", str(out), *(["--direct"] if direct else [])]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=1200)
    metrics_file = out / "companion" / "metrics.json"
    if not metrics_file.exists():
        raise RuntimeError(f"demo {' '.join(cmd[3:])} left no metrics (exit {done.returncode}):\n"
                           f"{done.stdout[-1500:]}{done.stderr[-1500:]}")
    metrics = json.loads(metrics_file.read_text())
    metrics.update(true_path(out, metrics))
    return metrics


def true_path(out: Path, metrics: dict[str, Any]) -> dict[str, float]:
    """Overshoot (m) and loops around the waypoint of the simulator's true path after engaging."""
    with (out / "sim" / "state.csv").open() as stream:
        rows = [r for r in csv.DictReader(stream) if float(r["t_s"]) >= (metrics.get("engaged_at_s") or 0.0)]
    scenario = yaml.safe_load((out / "scenario.yaml").read_text())
    wp = (float(scenario["waypoint"]["north_m"]), float(scenario["waypoint"]["east_m"]))
    if not rows:
        return {"true_overshoot_m": float("nan"), "true_loops": float("nan")}
    north = np.array([float(r["north_m"]) for r in rows])
    east = np.array([float(r["east_m"]) for r in rows])
    return {"true_overshoot_m": overshoot_m(north, east, (north[0], east[0]), wp),
            "true_loops": loops_around(north, east, wp)}


def first_confident_after_connect(m: dict[str, Any]) -> float | None:
    """Autopilot seconds from the estimator's first motion sample (shortly after the companion connects: home and
    a position known) to its first confident wave estimate."""
    waves = m.get("waves") or {}
    first, start = waves.get("first_confident_at_s"), waves.get("first_sample_at_s")
    return None if first is None or start is None else first - start


def arrived(m: dict[str, Any]) -> float | None:
    return m.get("time_to_waypoint_s") if m.get("phase") == "ARRIVED" else None


def line(output: str, sea: str, seed: int, balanced: dict[str, Any], direct: dict[str, Any]) -> float | None:
    """Print one pair's row; returns the cut (None when a run did not arrive)."""
    tb, td = arrived(balanced), arrived(direct)
    cut = 100 * (1 - balanced["avg_roll_deg"] / direct["avg_roll_deg"]) if tb and td else None
    bound = BOUND_FACTOR * td / (1 - cut / 100) if cut is not None and cut < 100 else None
    conf = first_confident_after_connect(balanced)
    cells = [f"{output:>15} {sea:>5} {seed:>4}",
             f"{direct['avg_roll_deg']:6.3f} {td if td else 'n/a':>6}",
             f"{balanced['avg_roll_deg']:6.3f} {tb if tb else 'n/a':>6}",
             f"{cut:5.1f} %" if cut is not None else "  n/a ",
             f"{bound:6.1f} {tb / bound:5.2f}" if bound and tb else "   n/a   n/a",
             f"{conf:5.1f}" if conf is not None else "  n/a",
             f"{balanced['true_overshoot_m']:5.1f} {balanced['true_loops']:4.2f}",
             f"{balanced.get('skipped_ticks', 0):4d}/{direct.get('skipped_ticks', 0):<4d}"]
    print(" | ".join(cells), flush=True)
    return cut


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--paths", type=_list(str, PATHS), default=list(PATHS), help="output paths (default both)")
    p.add_argument("--seas", type=_list(str, tuple(SEAS)), default=list(SEAS), help="seas (default paper,other)")
    p.add_argument("--seeds", type=_list(int), default=[1, 2, 3], help="simulator seeds (default 1,2,3)")
    p.add_argument("--keep", type=Path, help="keep the run folders under this folder")
    args = p.parse_args()
    root = args.keep or Path(tempfile.mkdtemp(prefix="defaults-over-mavlink-"))
    print("           path   sea seed | Direct roll arr | Balanced roll arr | cut     | bound  ratio | t_conf "
          "| over loops | skipped B/D")
    complete = True
    for output in args.paths:
        for sea in args.seas:
            cuts = []
            for seed in args.seeds:
                base = root / f"{output}-{sea}-seed{seed}"
                balanced = fly(SEAS[sea], output, seed, False, base.with_name(base.name + "-balanced"))
                direct = fly(SEAS[sea], output, seed, True, base.with_name(base.name + "-direct"))
                cut = line(output, sea, seed, balanced, direct)
                if cut is not None:
                    cuts.append(cut)
            complete = complete and len(cuts) == len(args.seeds)
            if cuts:
                print(f"# {output} {sea}: mean cut {statistics.mean(cuts):.1f} %, smallest {min(cuts):.1f} % "
                      f"over {len(cuts)} seed(s)  (runs in {root})", flush=True)
    return 0 if complete else 1


if __name__ == "__main__":
    sys.exit(main())
