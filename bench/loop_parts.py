"""Where a realistic in-process run's CPU time goes, per component of the loop (the NMPC and everything else).

    OMP_NUM_THREADS=1 python bench/loop_parts.py ["paper sea, balanced"] [--repeat 3]

One case of ``closed_loop_speed`` (nrti), run once to warm up and then ``--repeat`` times; the fastest run's CPU
seconds per component are printed, with ms per simulated second (watch plus run). The components are the loop's
own calls, each timed around the call (``process_time``); they nest (the plant's advance includes the sensing at
its half period, the watch includes both), so only the total and the NMPC's parts add up: the line "not NMPC" is
the total less the NMPC's solve, prepare and construction.
"""

from __future__ import annotations

import argparse
import collections
import time
from collections.abc import Callable
from typing import Any

from closed_loop_speed import CASES, scenario_of, simulated_s

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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("case", nargs="?", default="paper sea, balanced", choices=sorted(CASES))
    parser.add_argument("--repeat", type=int, default=3, help="timed runs, fastest kept (default: 3)")
    args = parser.parse_args()
    from mavbridge.lab.experiment import run_scenario

    spent: collections.Counter = collections.Counter()
    instrument(spent)
    scenario = scenario_of(args.case)
    run_scenario(scenario, None, plots=False)  # warm-up
    best: tuple[float, dict[str, float], float] | None = None
    for _ in range(max(1, args.repeat)):
        spent.clear()
        start = time.process_time()
        metrics = run_scenario(scenario, None, plots=False).metrics
        total = time.process_time() - start
        if best is None or total < best[0]:
            best = (total, dict(spent), simulated_s(scenario, metrics))
    assert best is not None
    total, parts, simulated = best
    print(f"{args.case}: {total:.3f} CPU s for {simulated:.1f} simulated s ({simulated / total:.0f}× real time)")
    for label, seconds in sorted(parts.items(), key=lambda item: -item[1]):
        print(f"  {label:32s} {seconds:7.3f} s {1e3 * seconds / simulated:7.2f} ms per simulated s")
    rest = total - sum(parts.get(label, 0.0) for label in NMPC)
    print(f"  {'not NMPC':32s} {rest:7.3f} s {1e3 * rest / simulated:7.2f} ms per simulated s")


if __name__ == "__main__":
    main()
