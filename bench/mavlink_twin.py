"""Benchmark: Balanced and Direct over MAVLink in an irregular sea, each beside its in-process twin (issue 33).

Run: OMP_NUM_THREADS=1 python bench/mavlink_twin.py [--paths rc_override,attitude_target] [--sea-seeds 1]
     [--seeds 1] [--keep DIR]

An irregular sea never repeats, so a MAVLink run and an in-process run compare only on the same stretch of it.
`sim-vehicle --seed N` hides the sea's time origin (``sim_vehicle.scenario.hidden_time_origin_s``) and the
companion engages some seconds after it connects; a run starting at t = 0 in-process meets other waves, and a
30 s look at an irregular sea varies by tens of percent from one stretch to the next (and the expected-roll
term with its square). So each MAVLink run gets a twin: the experiment runner on the same scenario with
``sea.spectrum.start_s`` = the scenario's own + the hidden origin + the autopilot time the companion engaged at,
and a watch as long as the companion's (from its connection to engaging); the twin's hull floats unwatched for
``SETTLE_S`` (10 s) before, as the simulator's did for its first 9-11 s before the companion connected (the one
second either way, and the 0.2 s from connecting to the estimator's first sample, are not matched). Each twin
is written beside its MAVLink run (``...-twin``).

The MAVLink runs are `mavbridge demo` with every flag at its default (paced, speedup 5, nrti, waves estimated,
the GUIDED path in its default form, engaged 30 s after connecting); only `--scenario`, `--output`, `--seed`,
`--out` (and `--direct`) are given. The scenario is scenarios/jonswap_estimated.yaml's base (Hs 1.75 m, Tp 6 s,
γ 3.3, towards West) with the sea seed given and the companion's defaults (nrti). Prints per path × sea seed ×
simulator seed: Direct's and Balanced's roll and arrival over MAVLink and in the twin, both cuts and their
difference in points (issue 33 asks for ≤ 5). About 2 minutes a pair.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import tempfile
from pathlib import Path
from typing import Any

import yaml
from defaults_over_mavlink import PATHS, _list, fly  # this folder is on sys.path when run as a script

from mavbridge.lab.experiment import run_scenario
from mavbridge.lab.scenario import load_scenarios
from sim_vehicle.scenario import hidden_time_origin_s

ROOT = Path(__file__).resolve().parents[1]
SOURCE = ROOT / "scenarios" / "jonswap_estimated.yaml"


def single_scenario_file(sea_seed: int, folder: Path) -> Path:
    """The JONSWAP scenario's base as a one-run file (sea seed ``sea_seed``, the companion's solver nrti)."""
    base = yaml.safe_load(SOURCE.read_text())["base"]
    base["sea"]["seed"] = sea_seed
    base["controller"]["solver"] = "nrti"
    path = folder / f"jonswap-sea{sea_seed}.yaml"
    path.write_text(yaml.safe_dump({"name": f"jonswap-sea{sea_seed}", **base}, sort_keys=False))
    return path


def twin(scenario_file: Path, sim_seed: int, metrics: dict[str, Any], direct: bool,
         out: Path | None = None) -> dict[str, Any]:
    """The in-process run on the stretch of sea the MAVLink run met (see the module docstring); the simulator adds
    its hidden origin to the scenario's own ``start_s``, and so does the twin. Written to ``out`` when given."""
    scenario = load_scenarios(scenario_file)[0]
    engaged, connected = metrics["engaged_at_s"], metrics["connected_at_s"]
    start_s = scenario.sea.spectrum.start_s + hidden_time_origin_s(sim_seed) + engaged
    spectrum = dataclasses.replace(scenario.sea.spectrum, start_s=start_s)
    controller = scenario.controller.replace(r=0.0) if direct else scenario.controller
    world = dataclasses.replace(scenario.world, sea=dataclasses.replace(scenario.sea, spectrum=spectrum))
    scenario = dataclasses.replace(scenario, world=world, controller=controller,
                                   estimation=dataclasses.replace(scenario.estimation,
                                                                  watch_s=round(engaged - connected, 1)))
    return run_scenario(scenario, out, plots=False).metrics


def cut(balanced: dict[str, Any], direct: dict[str, Any]) -> float:
    """Balanced's average-roll cut against Direct, %."""
    return 100.0 * (1.0 - balanced["avg_roll_deg"] / direct["avg_roll_deg"])


def cell(m: dict[str, Any]) -> str:
    """Average roll and arrival of one run."""
    arrival = m.get("time_to_waypoint_s")
    return f"{m['avg_roll_deg']:5.2f} {arrival if arrival is not None else float('nan'):6.1f}"


def pair(path: str, scenario_file: Path, sim_seed: int, root: Path) -> tuple[str, float]:
    """One Balanced/Direct pair over MAVLink and their twins: the table line and the cuts' difference."""
    runs: dict[str, dict[str, Any]] = {}
    for name, direct in (("balanced", False), ("direct", True)):
        folder = root / f"{path}-{scenario_file.stem}-seed{sim_seed}-{name}"
        runs[name] = fly(scenario_file, path, sim_seed, direct, folder)
        runs[name + "_twin"] = twin(scenario_file, sim_seed, runs[name], direct,
                                    folder.with_name(folder.name + "-twin"))
    over, inproc = cut(runs["balanced"], runs["direct"]), cut(runs["balanced_twin"], runs["direct_twin"])
    line = (f"{path:>15} {scenario_file.stem:>13} {sim_seed:>4} | {cell(runs['direct'])} {cell(runs['balanced'])} "
            f"{over:6.1f} | {cell(runs['direct_twin'])} {cell(runs['balanced_twin'])} {inproc:6.1f} | "
            f"{over - inproc:+6.1f} | {runs['balanced']['engaged_at_s']:6.1f}")
    return line, over - inproc


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--paths", type=_list(str, PATHS), default=list(PATHS), help="output paths (default both)")
    p.add_argument("--sea-seeds", type=_list(int), default=[1], help="the JONSWAP sea's seeds (default 1)")
    p.add_argument("--seeds", type=_list(int), default=[1], help="simulator seeds: the sea's hidden time origin "
                   "and the sensor noise (default 1)")
    p.add_argument("--keep", type=Path, help="keep the run folders under this (new) folder")
    args = p.parse_args()
    if args.keep:
        args.keep.mkdir(parents=True, exist_ok=False)
    root = args.keep or Path(tempfile.mkdtemp(prefix="mavlink-twin-"))
    print("           path           sea  sim | over MAVLink: Direct roll deg, s; Balanced; cut % "
          "| twin in-process: (same)        | MAVLink - twin | engaged at s")
    gaps = []
    for path in args.paths:
        for sea_seed in args.sea_seeds:
            scenario_file = single_scenario_file(sea_seed, root)
            for sim_seed in args.seeds:
                line, gap = pair(path, scenario_file, sim_seed, root)
                print(line, flush=True)
                gaps.append(gap)
    print(f"largest difference between a cut over MAVLink and its twin's: {max(map(abs, gaps)):.1f} points "
          f"(runs in {root})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
