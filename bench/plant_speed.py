"""How many times faster than real time the Otter plant runs, and what one dynamics evaluation costs.

Run: python bench/plant_speed.py [--duration 180] [--dt 0.01] [--repeats 3]
Prints the best of the repeats for RK4 and semi-implicit Euler, calm water and the paper's waves.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from vessel import SEA_PRESETS, Plant, otter_parameters, plant_ode


def time_run(waves: object, integrator: str, duration: float, dt: float, repeats: int) -> float:
    """Best wall time (s) of a closed run of ``duration`` simulated seconds with constant commands."""
    params = otter_parameters()
    plant = Plant(params, waves, dt=dt, integrator=integrator)  # type: ignore[arg-type]
    steps = round(duration / dt)
    command = (0.7 * params.matrices().n_max, 0.3 * params.matrices().n_max)
    best = float("inf")
    for _ in range(repeats):
        plant.reset()
        start = time.perf_counter()
        plant.advance(command, steps)
        best = min(best, time.perf_counter() - start)
    return best


def time_dynamics_evaluation(evaluations: int = 200_000) -> float:
    """Cost of one ẋ evaluation (µs) through the zero-overhead buffer interface."""
    ode = plant_ode(otter_parameters(), SEA_PRESETS["paper"].waves())
    x, u, t, out = np.zeros(14), np.array([50.0, 40.0]), np.zeros(1), np.zeros(14)
    x[6] = 1.0
    buffer, evaluate = ode.buffer()
    for i, arg in enumerate((x, u, t)):
        buffer.set_arg(i, memoryview(arg))
    buffer.set_res(0, memoryview(out))
    start = time.perf_counter()
    for _ in range(evaluations):
        evaluate()
    return (time.perf_counter() - start) / evaluations * 1e6


def main() -> None:
    """Print the plant speed table."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--duration", type=float, default=180.0)
    parser.add_argument("--dt", type=float, default=0.01)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    print(f"plant: {args.duration:g} s simulated at dt {args.dt:g} s, best of {args.repeats}")
    print(f"{'integrator':<10} {'sea':<6} {'wall s':>8} {'x real time':>12} {'us/step':>8}")
    for integrator in ("rk4", "euler"):
        for name in ("calm", "paper"):
            waves = SEA_PRESETS[name].waves()
            wall = time_run(waves, integrator, args.duration, args.dt, args.repeats)
            per_step_us = wall / (args.duration / args.dt) * 1e6
            print(f"{integrator:<10} {name:<6} {wall:8.3f} {args.duration / wall:12.0f} {per_step_us:8.2f}")
    print(f"one dynamics evaluation (paper waves): {time_dynamics_evaluation():.2f} us")


if __name__ == "__main__":
    main()
