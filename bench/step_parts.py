"""Benchmark: where the companion's paced control step spends its time, part by part.

Run: OMP_NUM_THREADS=1 python bench/step_parts.py [--duration 60] [--watch 60] [--seed 1] [--realtime]
     [--estimator process|inline]

The step and its replay are ``step_under_load``'s (its recording of `sim-vehicle` in the paper's waves, paced at
speedup 1 on the wall clock); here each part of the step is timed on its own, per step (every call since the
previous step summed): the messages' handling (the state, the delay clock, the estimator's samples) and the
control step's parts (the clock, the wave hand-over, the prediction over the delay, the NMPC's solve and, inside
it, its backend's take of the background plan and native feedback, the RC command, the next period's
preparation started). ``--realtime`` runs it beside two spinners under `mavbridge run --realtime`'s settings, as
``step_under_load``'s last condition. Parts nest (the solve holds the backend's), so the shares do not add up to
one; each timer adds about a microsecond to the step. Why it matters: hot, each part costs a few microseconds
(``timeit``); paced, after 100 ms of other work, two to ten times that, so this says where a step's time goes as
it flies.
"""

from __future__ import annotations

import argparse
import gc
import tempfile
import time
from collections import defaultdict
from collections.abc import Callable
from contextlib import nullcontext
from pathlib import Path
from typing import Any

import numpy as np
from step_under_load import CompanionStep, record, replay, replay_arguments, spinners

from mavbridge.cli.args import single_scenario
from mavbridge.companion.flight import build_nmpc, ready_for_loop
from mavbridge.companion.wave_gate import make_wave_source

Parts = dict[str, list[float]]


def timed(owner: Any, method: str, label: str, running: dict[str, int]) -> None:
    """Replace ``owner.method`` by itself timed: its wall nanoseconds added to ``running[label]``."""
    inner: Callable[..., Any] = getattr(owner, method)
    clock = time.perf_counter_ns

    def wrapper(*args: Any, **kwargs: Any) -> Any:
        start = clock()
        try:
            return inner(*args, **kwargs)
        finally:
            running[label] += clock() - start

    setattr(owner, method, wrapper)


def instrument(step: CompanionStep, running: dict[str, int]) -> list[str]:
    """Time the step's parts (see the module docstring); returns their labels, in the step's order."""
    backend = step.nmpc._backend  # the solve's own parts: the background plan's take and the native feedback
    labels: list[str] = []
    for owner, method, label in ((step.state, "on_message", "handling: state"),
                                 (step.delay, "on_message", "handling: delay clock"),
                                 (step.gate, "observe", "handling: estimator samples"),
                                 (step.delay, "compensate", "clock (state's age)"),
                                 (step.gate, "step", "wave hand-over"),
                                 (step.delay, "predict", "prediction over the delay"),
                                 (step.nmpc, "solve", "NMPC solve"),
                                 (backend, "solve", "  its backend"),
                                 (getattr(backend, "advanced", None), "take", "    background plan taken"),
                                 (backend, "feedback", "    native feedback"),
                                 (step.output, "compute", "RC command"),
                                 (step.nmpc, "advance", "next preparation started")):
        if owner is not None and hasattr(owner, method):
            timed(owner, method, label, running)
            labels.append(label)
    return labels


def run(args: argparse.Namespace, rec: Any) -> tuple[Parts, list[float]]:
    """The paced replay with the parts timed: (ms per step of each part, in the step's order; the steps' ms)."""
    scenario = single_scenario(None, "nrti")
    waves = make_wave_source("estimated", scenario.sea.waves(), 1.0, 0.0, scenario.params(),
                             process=args.estimator == "process")
    running: dict[str, int] = defaultdict(int)
    parts: Parts = defaultdict(list)
    try:
        if args.realtime:
            from mavbridge.cli.realtime import DEFAULT_PRIORITY, apply_realtime
            from mavbridge.cli.run import realtime_for_estimator

            print(apply_realtime().line(), flush=True)
            print(realtime_for_estimator(waves, DEFAULT_PRIORITY) or "", flush=True)
        with build_nmpc(scenario, waves) as nmpc, spinners(2) if args.realtime else nullcontext():
            step = CompanionStep(nmpc, waves, scenario)
            labels = instrument(step, running)
            control = step.control

            def control_and_collect(now_ms: int) -> float:
                ready = control(now_ms)
                for label in labels:  # (0 for a part not called this step: a feedback that fell back, say)
                    parts[label].append(running.get(label, 0) / 1e6)
                running.clear()
                return ready

            step.control = control_and_collect  # type: ignore[method-assign]
            ready_for_loop()
            timings = replay(rec, step, args.watch, args.duration)
    finally:
        gc.unfreeze()
        getattr(waves, "close", lambda: None)()
    ordered = {label: parts[label] for label in labels if any(parts[label])}
    return ordered, timings.steps_ms[1:]  # (the first step's handling began before the timers' first step)


def main() -> None:
    """Record, replay with the parts timed, print them."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    replay_arguments(p)
    p.add_argument("--realtime", action="store_true", help="beside two spinners, under --realtime's settings")
    args = p.parse_args()
    with tempfile.TemporaryDirectory(prefix="step_parts_") as work:
        rec = record(args.watch + args.duration + 1, args.seed, Path(work))
    parts, steps = run(args, rec)
    median = float(np.median(steps))
    print(f"\n{len(steps)} paced steps ({'2 spinners + realtime' if args.realtime else 'quiet'}): step median "
          f"{median:.3f} ms, p99 {np.percentile(steps, 99):.3f} ms\n")
    print(f"{'part (ms per step, wall clock)':<34} {'median':>8} {'p90':>8} {'mean':>8} {'median share':>13}")
    for label, values in parts.items():
        v = np.asarray(values[1:], float)
        print(f"{label:<34} {np.median(v):>8.4f} {np.percentile(v, 90):>8.4f} {v.mean():>8.4f} "
              f"{np.median(v) / median:>13.0%}")


if __name__ == "__main__":
    main()
