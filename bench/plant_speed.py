"""How many times faster than real time the Otter plant runs, and what one dynamics evaluation costs.

Run: python bench/plant_speed.py [--duration 180] [--dt 0.01] [--repeats 3] [--components 100]
Prints the best of the repeats for RK4 and semi-implicit Euler, calm water and the paper's waves, then
RK4 in a JONSWAP sea (Hs 1.75 m, Tp 6 s, γ 3.3, hull-averaged) of ``--components`` components, with and
without surface-relative heave, on CasADi's virtual machine ("vm") and compiled by the C compiler
("jit", see vessel.jit; the Plant's default for such large steps). "x real" is simulated time over
wall time; "x cpu" over this process's CPU time, the steadier figure on a shared machine.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from vessel import SEA_PRESETS, Plant, otter_parameters, plant_ode
from vessel.sea.irregular_sea import IrregularSea


def time_run(waves: object, integrator: str, duration: float, dt: float, repeats: int,
             surface_heave: bool = False, compile_step: bool | None = False) -> tuple[float, float]:
    """Best (wall s, CPU s) of a closed run of ``duration`` simulated seconds with constant commands."""
    params = otter_parameters()
    plant = Plant(params, waves, dt=dt, integrator=integrator, surface_heave=surface_heave,  # type: ignore[arg-type]
                  compile_step=compile_step)
    steps = round(duration / dt)
    command = (0.7 * params.matrices().n_max, 0.3 * params.matrices().n_max)
    best_wall = best_cpu = float("inf")
    for _ in range(repeats):
        plant.reset()
        start, start_cpu = time.perf_counter(), time.process_time()
        plant.advance(command, steps)
        best_wall = min(best_wall, time.perf_counter() - start)
        best_cpu = min(best_cpu, time.process_time() - start_cpu)
    return best_wall, best_cpu


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
    parser.add_argument("--components", type=int, default=100, help="wave components of the irregular sea")
    args = parser.parse_args()
    print(f"plant: {args.duration:g} s simulated at dt {args.dt:g} s, best of {args.repeats}")
    print(f"{'integrator':<10} {'sea':<18} {'code':<4} {'wall s':>8} {'x real':>8} {'x cpu':>8} {'us/step':>8}")
    irregular = IrregularSea(hs_m=1.75, tp_s=6.0, n_components=args.components).wave_field(otter_parameters())
    cases = [(integrator, name, waves, False, False) for integrator in ("rk4", "euler")
             for name, waves in (("calm", SEA_PRESETS["calm"].waves()), ("paper", SEA_PRESETS["paper"].waves()))]
    cases += [("rk4", "paper+heave", SEA_PRESETS["paper"].waves(), True, False)]
    cases += [("rk4", f"jonswap{args.components}{'+heave' if heave else ''}", irregular, heave, jit)
              for heave in (False, True) for jit in (False, True)]
    for integrator, name, waves, heave, jit in cases:
        wall, cpu = time_run(waves, integrator, args.duration, args.dt, args.repeats, heave, jit)
        per_step_us = wall / (args.duration / args.dt) * 1e6
        print(f"{integrator:<10} {name:<18} {'jit' if jit else 'vm':<4} {wall:8.3f} {args.duration / wall:8.0f} "
              f"{args.duration / cpu:8.0f} {per_step_us:8.2f}", flush=True)
    print(f"one dynamics evaluation (paper waves): {time_dynamics_evaluation():.2f} us")


if __name__ == "__main__":
    main()
