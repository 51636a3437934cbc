"""Closed-loop speed: the realistic in-process loop's real-time factor per core, and where its time goes.

    OMP_NUM_THREADS=1 python bench/closed_loop_speed.py [--repeat 3] [--compare REV]
    OMP_NUM_THREADS=1 python bench/closed_loop_speed.py --parts "paper sea, balanced"   # where one run's CPU goes

Six runs as ``mavbridge experiment`` flies them (no files): Direct and Balanced in the paper's sea, a JONSWAP
sea and NATO sea state 4, each realistic (estimator on simulated sensors, hidden phase, heave, the disturbance
observer) on nrti. A run's simulated time is its watch (the estimator's, before t = 0) plus the run to the
waypoint; its cost is the process's CPU time (every thread: per core, as a sweep of one run per core pays it)
and its wall time. Each case is timed ``--repeat`` times after one warm-up run (compiled code cached, imports
done) and its fastest kept; every run watches afresh (``MAVBRIDGE_WATCH_CACHE=0`` unless set: a sweep's runs
reuse a watch of their process, ``mavbridge.lab.watch``, a single run does not). Prints the real-time factor
(simulated / CPU seconds) per run, their median, and the top five entries (own time) of a cProfile of the
paper-sea Balanced run.

``--as-max-iterations N`` sets nrti's preparation to at most N SQP iterations (default: the controller's own, 30,
which converges; 1 is plain RTI): faster, and no longer the same numbers, so the table gives each run's average
roll and the cut of Balanced against Direct in each sea to show what it changes.

``--compare REV`` runs the same measurement on the code of git revision REV (a temporary worktree put first
on the path of a second process) and prints both, before and after, in one table.
"""

from __future__ import annotations

import argparse
import collections
import cProfile
import dataclasses
import io
import json
import os
import pstats
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
CASES = {  # name -> (scenario file, run, R or None for the run's own)
    "paper sea, direct": ("estimated.yaml", "direct", None),
    "paper sea, balanced": ("estimated.yaml", "balanced", None),
    "JONSWAP, direct": ("jonswap_estimated.yaml", "direct", None),
    "JONSWAP, balanced": ("jonswap_estimated.yaml", "balanced", None),
    "NATO SS4, direct": ("nato_ss4_estimated.yaml", "nato_ss4_estimated", 0.0),
    "NATO SS4, balanced": ("nato_ss4_estimated.yaml", "nato_ss4_estimated", 1550.0),
}
PROFILED = "paper sea, balanced"


ITERATIONS: dict[str, int] = {}  # ``--as-max-iterations``: {"as_max_iterations": N}, or none


def scenario_of(case: str) -> Any:
    """The case's scenario on nrti (and its R), as the code on the path loads it."""
    from mavbridge.lab.scenario import load_scenarios

    file, run, r = CASES[case]
    scenario = {sc.name: sc for sc in load_scenarios(ROOT / "scenarios" / file)}[run]
    controller = scenario.controller.replace(solver="nrti", **({"r": r} if r is not None else {}), **ITERATIONS)
    return dataclasses.replace(scenario, controller=controller)


def simulated_s(scenario: Any, metrics: dict[str, Any]) -> float:
    """The watch before t = 0 plus the run itself (s of simulated time)."""
    watch = scenario.estimation.watch_s if scenario.estimation.realistic else 0.0
    return float(watch) + float(metrics["simulated_s"])


def time_case(case: str, repeat: int) -> dict[str, float]:
    """The fastest of ``repeat`` runs: CPU s, wall s, simulated s."""
    from mavbridge.lab.experiment import run_scenario

    scenario = scenario_of(case)
    best: dict[str, float] = {}
    for _ in range(repeat):
        cpu, wall = time.process_time(), time.perf_counter()
        metrics = run_scenario(scenario, None, plots=False).metrics
        cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
        if not best or cpu < best["cpu_s"]:
            best = {"cpu_s": cpu, "wall_s": wall, "simulated_s": simulated_s(scenario, metrics),
                    "avg_roll_deg": float(metrics["avg_roll_deg"])}
    return best


def profile_top(case: str, entries: int = 5) -> list[str]:
    """The top ``entries`` of a cProfile of one run, by own time, as pstats prints them."""
    from mavbridge.lab.experiment import run_scenario

    scenario = scenario_of(case)
    profiler = cProfile.Profile()
    profiler.enable()
    run_scenario(scenario, None, plots=False)
    profiler.disable()
    text = io.StringIO()
    pstats.Stats(profiler, stream=text).sort_stats("tottime").print_stats(entries)
    lines = text.getvalue().splitlines()
    start = next(i for i, line in enumerate(lines) if line.lstrip().startswith("ncalls"))
    return [line.rstrip() for line in lines[start:start + entries + 1]]


NMPC = ("nmpc.solve", "nmpc.prepare", "nmpc.init")


def _timed(owner: Any, name: str, label: str, spent: collections.Counter) -> None:
    """Replace ``owner.name`` by a wrapper adding its CPU seconds to ``spent[label]``."""
    original: Callable[..., Any] = getattr(owner, name)

    def wrapper(*args: Any, **kwargs: Any) -> Any:
        start = time.process_time()
        try:
            return original(*args, **kwargs)
        finally:
            spent[label] += time.process_time() - start

    setattr(owner, name, wrapper)


def instrument(spent: collections.Counter) -> None:
    """Time the loop's components (this process only)."""
    import mavbridge.lab.experiment as experiment
    import mavbridge.lab.runlog as runlog
    import mavbridge.lab.sensed_plant as sensed_plant
    import mavbridge.nmpc.controller as controller
    import mavbridge.nmpc.disturbance as disturbance
    import mavbridge.waves.inloop as inloop
    import mavbridge.waves.window_estimator as window_estimator
    import vessel.sensors as sensors

    for owner, name, label in (
            (controller.RollAwareNmpc, "solve", "nmpc.solve"), (controller.RollAwareNmpc, "prepare", "nmpc.prepare"),
            (controller.RollAwareNmpc, "__init__", "nmpc.init"), (sensors.SensorModel, "sample", "sensors.sample"),
            (window_estimator.WindowEstimator, "observe", "estimator.observe (incl. fit)"),
            (window_estimator.WindowEstimator, "_advance_fit", "estimator fit"),
            (disturbance.DisturbanceObserver, "update", "observer.update"),
            (inloop.WaveFeed, "step", "feed.step (incl. sense)"),
            (sensed_plant.SensedPlant, "sense", "plant.sense (all)"),
            (sensed_plant.SensedPlant, "advance", "plant.advance (incl. sense)"),
            (sensed_plant.SensedPlant, "watch", "watch"),
            (experiment, "_sea_columns", "_sea_columns"), (runlog.RunRecorder, "state", "recorder rows")):
        _timed(owner, name, label, spent)


def print_parts(case: str, repeat: int) -> None:
    """``--parts``: one case's CPU seconds per part of the loop, the fastest of ``repeat`` runs after a warm-up. The
    parts are the loop's own calls, each timed around the call; they nest (the plant's advance includes the sensing
    at its half period, the watch both), so only the total and the NMPC's parts add up: "not NMPC" is the total
    less the NMPC's solve, prepare and construction."""
    from mavbridge.lab.experiment import run_scenario

    spent: collections.Counter = collections.Counter()
    instrument(spent)
    scenario = scenario_of(case)
    run_scenario(scenario, None, plots=False)  # warm-up
    best: tuple[float, dict[str, float], float] | None = None
    for _ in range(repeat):
        spent.clear()
        start = time.process_time()
        metrics = run_scenario(scenario, None, plots=False).metrics
        total = time.process_time() - start
        if best is None or total < best[0]:
            best = (total, dict(spent), simulated_s(scenario, metrics))
    assert best is not None
    total, parts, simulated = best
    print(f"{case}: {total:.3f} CPU s for {simulated:.1f} simulated s ({simulated / total:.0f}× real time)")
    for label, seconds in sorted(parts.items(), key=lambda item: -item[1]):
        print(f"  {label:32s} {seconds:7.3f} s {1e3 * seconds / simulated:7.2f} ms per simulated s")
    rest = total - sum(parts.get(label, 0.0) for label in NMPC)
    print(f"  {'not NMPC':32s} {rest:7.3f} s {1e3 * rest / simulated:7.2f} ms per simulated s")



def measure(repeat: int) -> dict[str, Any]:
    """Every case timed, and the profile; what ``--json`` writes and the table prints."""
    time_case(PROFILED, 1)  # warm-up: imports, compiled code loaded or built
    runs = {case: time_case(case, repeat) for case in CASES}
    return {"runs": runs, "profile": profile_top(PROFILED)}


def measure_revision(rev: str, repeat: int) -> dict[str, Any]:
    """``measure`` in a second process on the code of git revision ``rev`` (a temporary worktree)."""
    with tempfile.TemporaryDirectory() as tmp:
        tree, out = Path(tmp) / "tree", Path(tmp) / "figures.json"
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", "-q", str(tree), rev], check=True)
        try:
            env = {**os.environ, "PYTHONPATH": str(tree), "OMP_NUM_THREADS": os.environ.get("OMP_NUM_THREADS", "1")}
            extra = [f"--as-max-iterations={ITERATIONS['as_max_iterations']}"] if ITERATIONS else []
            subprocess.run([sys.executable, __file__, "--repeat", str(repeat), "--json", str(out), *extra], check=True,
                           env=env, cwd=tree)
            return json.loads(out.read_text(encoding="utf-8"))
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(tree)], check=False)


def factor(run: dict[str, float]) -> float:
    """Real-time factor per core: simulated seconds per CPU second."""
    return run["simulated_s"] / run["cpu_s"]


def print_table(after: dict[str, Any], before: dict[str, Any] | None, rev: str | None) -> None:
    """Markdown: per case simulated s, CPU s, wall s and the factor (before and after with ``--compare``)."""
    head = "| run | avg roll ° | simulated s | CPU s | wall s | × real time per core |"
    rule = "|---|---|---|---|---|---|"
    if before is not None:
        head += f" before ({rev}) × | speed-up |"
        rule += "---|---|"
    print(head + "\n" + rule)
    for case, run in after["runs"].items():
        line = (f"| {case} | {run['avg_roll_deg']:.3f} | {run['simulated_s']:.1f} | {run['cpu_s']:.2f} "
                f"| {run['wall_s']:.2f} | {factor(run):.0f} |")
        if before is not None:
            old = before["runs"][case]
            line += f" {factor(old):.0f} | {old['cpu_s'] / run['cpu_s']:.2f}× |"
        print(line)
    print_cuts(after["runs"])
    median = statistics.median(factor(run) for run in after["runs"].values())
    print(f"\nmedian: {median:.0f}× real time per core", end="")
    if before is not None:
        print(f" (before: {statistics.median(factor(run) for run in before['runs'].values()):.0f}×)", end="")
    print()
    for label, figures in (("before", before), ("after", after)):
        if figures is not None:
            print(f"\nprofile of '{PROFILED}' ({label}), top five by own time:")
            print("\n".join(figures["profile"]))


def print_cuts(runs: dict[str, dict[str, float]]) -> None:
    """Balanced's cut of the average roll against Direct, per sea."""
    seas = sorted({case.split(",")[0] for case in runs})
    def cut(sea: str) -> float:
        return 100 * (1 - runs[f"{sea}, balanced"]["avg_roll_deg"] / runs[f"{sea}, direct"]["avg_roll_deg"])

    cuts = [f"{sea} {cut(sea):.1f} %" for sea in seas]
    print("\ncut of Balanced against Direct: " + ", ".join(cuts))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="timed runs per case, fastest kept (default: 3)")
    parser.add_argument("--compare", metavar="REV", help="also measure git revision REV (before) in a worktree")
    parser.add_argument("--as-max-iterations", type=int, help="nrti's SQP iterations per preparation, 1..200 "
                        "(default: the controller's own; not the same numbers)")
    parser.add_argument("--parts", metavar="CASE", choices=sorted(CASES),
                        help="instead: one case's CPU seconds per part of the loop (e.g. 'paper sea, balanced')")
    parser.add_argument("--json", type=Path, help=argparse.SUPPRESS)  # (the second process's output)
    args = parser.parse_args()
    # a run's figure includes its watch: each timed run watches afresh, not from the warm-up's (``lab.watch``)
    os.environ.setdefault("MAVBRIDGE_WATCH_CACHE", "0")
    if args.repeat < 1:
        parser.error("--repeat: must be >= 1")
    if args.as_max_iterations is not None:
        if not 1 <= args.as_max_iterations <= 200:
            parser.error("--as-max-iterations: must be in 1..200")
        ITERATIONS["as_max_iterations"] = args.as_max_iterations
    if args.parts is not None:
        print_parts(args.parts, args.repeat)
        return
    before = measure_revision(args.compare, args.repeat) if args.compare else None
    after = measure(args.repeat)
    if args.json is not None:
        args.json.write_text(json.dumps(after), encoding="utf-8")
        return
    print_table(after, before, args.compare)


if __name__ == "__main__":
    main()
