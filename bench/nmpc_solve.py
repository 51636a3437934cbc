"""Solve-time distribution of each NMPC solver configuration over a whole closed-loop run.

    python bench/nmpc_solve.py [--scenario scenarios/balanced.yaml] [--configs ipopt,rti,asrti,nrti] [--t-max 180]
                               [--plant tau|propellers]

For each configuration: median, p95, p99 and max wall time per control step (ms) over the whole run, and
the run's closed-loop metrics (average and maximum roll, time to the waypoint), printed as a table. For
the fast solvers the cold, full solve is done by ``RollAwareNmpc.prepare`` before the loop and reported on
its own (prepare ms); every step inside the loop counts. The ipopt reference has no prepare: its first
step is the cold solve, counted in its figures. asrti: the background solve's wall time (median / max) is given
too; it runs on the second core during the period and must fit in it, the step time is the main loop's.
Run it alone on the machine (one process, OMP_NUM_THREADS=1) for clean timings.

``nrti`` is asrti's closed loop with the step split in a preparation (background: converged SQP, QP
condensed in C) and a feedback (the measured state into the prepared QP: one native call); its step time
is the feedback plus the controller's Python glue. acados is not a backend here: the PyPI build
(``comma-deps-acados``) installs its own casadi package (no IPOPT or HPIPM plugin) over the project's CasADi
(see the final note printed); its published figures on this problem are quoted there for comparison.

The ``*-setwave`` rows call ``RollAwareNmpc.set_wave`` before every step with a freshly built wave, as the
companion does with its wave source's estimate (``WaveEstimate.field()``); that call's time is added to
the step's. ``asrti-setwave`` feeds the scenario's true wave (the closed loop must equal ``asrti``'s),
``asrti-setwave-noisy`` the truth with seeded noise on phase and height (an estimator's jitter).
The ``*-estimated`` rows fly on the wave estimator in the realistic loop (``ESTIMATED``); their step time
is the solve plus the estimator's work for that step. Compare ``asrti-estimated`` with ``asrti`` of the same run.
``nrti-predicted`` adds the phase predictor's bank (K = 12, used while confident 0.5 s ahead) to the estimator
(``PREDICTED``): issue 33's budget for it, in an irregular sea (``--scenario scenarios/jonswap_estimated.yaml
--run balanced``). In the in-process loop the wave source's time includes simulating the sensors that feed it.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import os
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

os.environ.setdefault("OMP_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import mavbridge.lab.experiment
from mavbridge.lab.experiment import run_scenario
from mavbridge.lab.scenario import load_scenarios
from mavbridge.nmpc import NmpcResult, RollAwareNmpc
from mavbridge.waves.source import WaveEstimate
from vessel import RegularWaves

# name -> controller overrides
CONFIGS: dict[str, dict] = {
    "ipopt": {"solver": "ipopt"},  # reference: SX, warm start, Euler 2×0.05 s
    "ipopt-rk4": {"solver": "ipopt", "integrator": "rk4", "substeps": 1},  # one RK4 step of 0.1 s
    "rti": {"solver": "rti"},  # Gauss–Newton SQP, HPIPM: 2 iterations per step, QP capped at 4 iterations
    # The same iterated until the input step is below 0.01 (up to 30 iterations): converged GN-SQP.
    "rti-converged": {"solver": "rti", "rti_max_iterations": 30, "rti_step_tol": 0.01, "rti_qp_iter_max": 0},
    # Advanced-step RTI: a converged SQP for the predicted next state runs in a background thread during the
    # period; the step itself is 1 (asrti) or 2 (asrti2) Gauss–Newton iterations from that plan.
    "asrti": {"solver": "asrti"},
    "asrti2": {"solver": "asrti", "as_iterations": 2},
    "asrti-process": {"solver": "asrti", "as_worker": "process"},  # the background solve in a worker process
    "asrti-tight": {"solver": "asrti", "as_step_tol": 0.01},  # background solved to 0.01 N instead of 0.3 N
    "asrti-cap15": {"solver": "asrti", "as_max_iterations": 15},  # background capped at 15 SQP iterations
    # asrti's closed loop with a native preparation/feedback split: the step is one C call on a condensed QP.
    "nrti": {"solver": "nrti"},
    # The actuator-aware model: u = the two propeller thrusts within their limits, τ = B·u (NmpcConfig.inputs).
    "nrti-propellers": {"solver": "nrti", "inputs": "propellers"},
    "asrti-propellers": {"solver": "asrti", "inputs": "propellers"},
    "asrti-setwave": {"solver": "asrti"},  # set_wave every step with the true wave
    "asrti-setwave-noisy": {"solver": "asrti"},  # set_wave every step, truth + noise
    "asrti-estimated": {"solver": "asrti"},  # the wave estimator in the loop (see ESTIMATED)
    "rti-estimated": {"solver": "rti"},
    "nrti-estimated": {"solver": "nrti"},
    # The estimator and the phase predictor's bank of 12 components (issue 33's step budget: an irregular-sea
    # scenario, e.g. --scenario scenarios/jonswap_estimated.yaml --run balanced).
    "nrti-predicted": {"solver": "nrti", "wave_components": 12},
}
# Configurations flown on the wave estimator: the realistic in-process loop (hull heaving with the sea, hidden
# phase, default sensors at 20 Hz); the step time is the solve plus the estimator's share of that step
# (two observe at 20 Hz, one estimate, set_wave).
ESTIMATED = {"waves": "estimated", "surface_heave": True, "hidden_phase": True, "seed": 1, "hold_s": 30.0,
             "watch_s": 60.0}  # as scenarios/estimated.yaml: the estimator has watched the boat, the roll term is on
# the *-predicted rows: ESTIMATED with the predictor's bank, used while it is confident 0.5 s ahead (as the
# bank's closed-loop tables; at the default 1 s it is rarely on and the timing would miss its compression)
PREDICTED = {**ESTIMATED, "waves": "predicted", "bank_lead_s": 0.5}
LOOPS = {"-estimated": ESTIMATED, "-predicted": PREDICTED}  # a configuration's suffix -> its realistic loop
# name -> (phase noise σ rad, relative height noise σ) of the wave handed to set_wave every step
WAVE_FEEDS: dict[str, tuple[float, float]] = {"asrti-setwave": (0.0, 0.0), "asrti-setwave-noisy": (0.05, 0.03)}


class WaveFedNmpc(RollAwareNmpc):
    """A controller told the wave before every step, like the companion with an estimator (see the docstring)."""

    noise: ClassVar[tuple[float, float]] = (0.0, 0.0)  # set by ``wave_fed``
    set_wave_s: ClassVar[list[float]] = []  # seconds per set_wave, appended by every instance

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._truth = self.waves
        self._rng = np.random.default_rng(12)

    def solve(self, x0: Any, t: float, waypoint_ne: Any, deadline_s: float | None = None) -> NmpcResult:
        """set_wave with this step's wave, then the solve; the step's wall time includes set_wave."""
        start = time.perf_counter()
        w = self._truth
        if isinstance(w, RegularWaves):
            phase_sd, height_sd = self.noise
            estimate = WaveEstimate(w.height_m * (1 + height_sd * self._rng.standard_normal()), w.period_s,
                                    w.length_m, w.travel_dir_rad, w.phase_rad + phase_sd * self._rng.standard_normal(),
                                    roll_sign=w.roll_sign)
            self.set_wave(estimate.field())
        cost = time.perf_counter() - start
        type(self).set_wave_s.append(cost)
        result = super().solve(x0, t, waypoint_ne, deadline_s)
        return dataclasses.replace(result, wall_time_s=result.wall_time_s + cost)


@contextlib.contextmanager
def wave_fed(noise: tuple[float, float]) -> Iterator[type[WaveFedNmpc]]:
    """The experiment runner builds WaveFedNmpc controllers while inside (it builds its own controller)."""
    original = mavbridge.lab.experiment.RollAwareNmpc
    WaveFedNmpc.noise = noise
    WaveFedNmpc.set_wave_s = []
    mavbridge.lab.experiment.RollAwareNmpc = WaveFedNmpc
    try:
        yield WaveFedNmpc
    finally:
        mavbridge.lab.experiment.RollAwareNmpc = original


def main(argv: list[str] | None = None) -> int:
    """Run each configuration and print the table."""
    root = Path(__file__).resolve().parents[1]
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default=str(root / "scenarios" / "balanced.yaml"))
    parser.add_argument("--configs", default="ipopt,rti,asrti,nrti", help=f"comma-separated, from {', '.join(CONFIGS)}")
    parser.add_argument("--run", default=None, help="the scenario file's run to time (default its first)")
    parser.add_argument("--t-max", type=float, default=None, help="override the scenario's t_max_s")
    parser.add_argument("--plant", choices=("tau", "propellers"), default=None, help="override the scenario's plant")
    args = parser.parse_args(argv)
    names = [n.strip() for n in args.configs.split(",") if n.strip()]
    unknown = [n for n in names if n not in CONFIGS]
    if unknown:
        parser.error(f"unknown configuration {unknown[0]!r} (choose from {', '.join(CONFIGS)})")
    runs = load_scenarios(args.scenario)
    named = [sc for sc in runs if args.run is None or sc.name == args.run]
    if not named:
        parser.error(f"--run: {args.run!r} is not a run of {args.scenario} ({', '.join(sc.name for sc in runs)})")
    base = named[0]
    if args.t_max is not None:
        base = dataclasses.replace(base, t_max_s=args.t_max)
    if args.plant is not None:
        base = dataclasses.replace(base, plant=args.plant)
    rows = []
    notes = []
    for name in names:
        scenario = dataclasses.replace(base, controller=base.controller.replace(**CONFIGS[name]))
        loop = next((fields for suffix, fields in LOOPS.items() if name.endswith(suffix)), None)
        if loop is not None:
            scenario = dataclasses.replace(scenario, estimation=dataclasses.replace(scenario.estimation, **loop))
        start = time.perf_counter()
        feed = wave_fed(WAVE_FEEDS[name]) if name in WAVE_FEEDS else contextlib.nullcontext()
        with feed as fed:
            result = run_scenario(scenario, None, plots=False)
        wall = time.perf_counter() - start
        if fed is not None:
            us = np.array(fed.set_wave_s) * 1e6
            notes.append(f"{name}: set_wave (WaveEstimate.field() + set_wave) per step median {np.median(us):.1f} µs, "
                         f"p99 {np.percentile(us, 99):.1f} µs, max {us.max():.1f} µs over {len(us)} steps")
        ms = np.array(result.solve_ms)
        if result.estimator_ms:  # the estimator's share of each step counts in the step time
            ms = ms + np.array(result.estimator_ms[:len(ms)])
        m = result.metrics
        arrival = f"{m['time_to_waypoint_s']:.1f}" if m["time_to_waypoint_s"] is not None else "N/A"
        background = "–"
        if m.get("background_solve_ms_median") is not None:
            background = f"{m['background_solve_ms_median']:.1f} / {m['background_solve_ms_max']:.1f}"
        rows.append((name, len(ms), np.median(ms), np.percentile(ms, 95), np.percentile(ms, 99), ms.max(),
                     m["prepare_ms"], m["iterations_median"], m["failures"], m["avg_roll_deg"], m["max_roll_deg"],
                     arrival, background, wall))
        print(f"{name}: done in {wall:.1f} s", file=sys.stderr, flush=True)
    print(f"scenario {Path(args.scenario).name} ({base.name}), plant {base.plant}, horizon {base.controller.horizon}, "
          f"period {base.controller.period_s} s; solve ms per control step (wall clock)")
    print("| config | steps | median ms | p95 ms | p99 ms | max ms | prepare ms | iters (median) "
          "| failures | avg roll ° | max roll ° | t_wpt s | background ms median / max | run wall s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        prepare = "–" if r[6] is None else f"{r[6]:.1f}"
        print(f"| {r[0]} | {r[1]} | {r[2]:.2f} | {r[3]:.2f} | {r[4]:.2f} | {r[5]:.2f} | {prepare} | {r[7]:g} "
              f"| {r[8]} | {r[9]:.2f} | {r[10]:.2f} | {r[11]} | {r[12]} | {r[13]:.1f} |")
    for note in notes:
        print(note)
    print(acados_note())
    return 0


def acados_note() -> str:
    """Whether acados is importable here, and the figures measured with it on this problem (issue 18)."""
    try:
        import acados_template  # noqa: F401  (optional; never a dependency)
    except ImportError:
        return ("acados: not installed (its PyPI wheel puts its own casadi package, without the IPOPT and HPIPM "
                "plugins, in place of the project's CasADi); "
                "measured on this problem elsewhere: SQP_RTI + HPIPM SPEED_ABS 0.24 ms median solve, "
                "≈ 0.41 ms with setting x0 and parameters from Python")
    return "acados: importable, but no acados backend is wired into this benchmark"


if __name__ == "__main__":
    raise SystemExit(main())
