"""The wave estimator's first confident answer on the realistic hull: how soon, and how true (issue 29).

Used by ``bench/wave_estimation.py`` (its default table). Per sea × motion × seed: the in-process plant
(``mavbridge.waves.inloop.SensedPlant``: the Otter's rigid body heaving with the sea, the default sensors at
20 Hz, the sea's phase hidden) floats 30 s unwatched, then the companion's estimator (``make_estimator`` with the
hull's calibrated response, as ``mavbridge run`` builds it) watches it drifting, or under way at a constant surge
force with its heading held by a PD yaw moment. The table gives the seconds of watching until the first
confident estimate and that estimate's errors (period %, direction °, wavelength %, height %), checked against
issue 29's bounds: confident within 15 s, and 3 %, 10°, 10 %, 15 %.
"""

from __future__ import annotations

import math
import statistics
from dataclasses import dataclass

import numpy as np

from mavbridge.lab.sensed_plant import SensedPlant
from mavbridge.waves import make_estimator
from mavbridge.waves.inloop import calibrated_settings, estimate_metrics, sensor_model
from vessel import RegularWaves, otter_parameters
from vessel.dynamics import OceanCurrent

# (height m, length m, period s, travel direction deg): the paper's and three others, from other directions
SEAS = {"paper": (1.75, 35.0, 6.0, -90.0), "A": (1.0, 25.0, 4.5, 30.0), "B": (1.5, 30.0, 5.5, 150.0),
        "C": (2.0, 45.0, 7.0, -160.0)}
# (name, surge force N, heading deg): drifting, and under way on two headings held by the yaw moment
MOTIONS = (("drifting", 0.0, 0.0), ("under way N", 120.0, 0.0), ("under way E", 120.0, 90.0))
BOUNDS = (("period_err_pct", 3.0), ("direction_err_deg", 10.0), ("length_err_pct", 10.0), ("height_err_pct", 15.0))
WITHIN_S = 15.0
WATCH_S = 40.0


class _Unwatched:
    def observe(self, sample: object) -> None:
        """Nobody watches while the hull settles."""


@dataclass(frozen=True)
class FirstAnswer:
    """Seconds of watching to the first confident estimate (None: none in ``WATCH_S``) and its errors."""

    seconds: float | None
    errors: dict[str, float]

    def ok(self) -> bool:
        """Confident within ``WITHIN_S`` and every error within its bound."""
        return (self.seconds is not None and self.seconds <= WITHIN_S
                and all(abs(self.errors[name]) <= bound for name, bound in BOUNDS))


def first_answer(sea_name: str, surge_n: float, heading_deg: float, seed: int) -> FirstAnswer:
    """One watch of the realistic hull (see the module docstring)."""
    params = otter_parameters()
    height, length, period, direction = SEAS[sea_name]
    phase = float(np.random.default_rng([31, seed]).uniform(-math.pi, math.pi))
    sea = RegularWaves(height, length, period, math.radians(direction), phase_rad=phase)
    x0 = np.zeros(12)
    x0[5] = psi_ref = math.radians(heading_deg)
    plant = SensedPlant(params, sea, OceanCurrent(), x0, 0.1, 0.01, True, sensor_model("default", seed),
                           _Unwatched())
    t = -30.0
    while t < 0:
        plant.advance(t, np.zeros(2), (0.0, 0.0))
        t += 0.1
    plant.source = estimator = make_estimator(calibrated_settings(params, True, 1.0))
    while t < WATCH_S:
        plant.sense(t)
        answer = estimator.estimate(t)
        if answer is not None:
            return FirstAnswer(t, estimate_metrics(answer, sea, t, plant.rigid_state, 0.0))
        x = plant.rigid_state
        yaw = 0.0 if surge_n == 0 else float(np.clip(-60.0 * math.remainder(x[5] - psi_ref, 2 * math.pi)
                                                     - 40.0 * x[11], -73.6, 73.6))
        plant.advance(t, np.array([surge_n, yaw]), (0.0, 0.0))
        t += 0.1
    return FirstAnswer(None, {})


def print_table(seeds: int) -> int:
    """The table over SEAS × MOTIONS × seeds; returns how many runs met the bounds."""
    print(f"# first confident estimate, realistic hull (heave, default sensors, hidden phase), {seeds} seed(s); "
          f"bounds: confident within {WITHIN_S:g} s, period 3 %, direction 10 deg, wavelength 10 %, height 15 %")
    print("| sea | motion | seed | first confident s | period % | direction deg | wavelength % | height % | ok |")
    print("|---|---|---|---|---|---|---|---|---|")
    ok, times = 0, []
    for sea_name, (height, length, period, direction) in SEAS.items():
        for motion, surge, heading in MOTIONS:
            for seed in range(1, seeds + 1):
                answer = first_answer(sea_name, surge, heading, seed)
                ok += answer.ok()
                label = f"{sea_name} {height:g} m / {length:g} m / {period:g} s towards {direction:g}"
                if answer.seconds is None:
                    print(f"| {label} | {motion} | {seed} | none in {WATCH_S:g} s | | | | | no |", flush=True)
                    continue
                times.append(answer.seconds)
                e = answer.errors
                print(f"| {label} | {motion} | {seed} | {answer.seconds:.1f} | {e['period_err_pct']:+.1f} | "
                      f"{e['direction_err_deg']:+.1f} | {e['length_err_pct']:+.1f} | {e['height_err_pct']:+.1f} | "
                      f"{'yes' if answer.ok() else 'no'} |", flush=True)
    total = len(SEAS) * len(MOTIONS) * seeds
    median = f"{statistics.median(times):.1f}" if times else "-"
    print(f"# within the bounds: {ok}/{total}; median time to the first confident estimate {median} s")
    return ok
