"""How well and how fast the wave estimator finds the paper's wave, and what it costs per control step.

Run: python bench/wave_estimation.py [--seeds 3] [--duration 60] [--speeds 0.5,1,1.5] [--no-imu]
     [--ideal-sensors] [--cost-only]

Kinematic truth (``mavbridge.waves.kinematic``): a point riding the paper's regular sea (1.75 m, 35 m,
6 s, travelling West, a hidden random phase, a random autopilot boot time), seen through the default
sensor model of ``vessel.sensors``, heading 0–330° every 30° at each speed, several seeds. For each
cell: the median time to the first confident estimate (s; "—" if none within the run), how many seeds
were confident at the end, and the median absolute errors at the end: direction °, period %,
wavelength %, height % and the predicted phase 4 s ahead (the horizon end) °; "ok" counts the seeds
inside the issue's bounds (10°, 5 %, 15 %, 15 %, 30°). The relative wave heading μ is 180° for head
seas, 0° for following seas. Irregular seas: a row follows once ``vessel`` has them (issue 11).
The closed-loop roll reduction part needs the in-process runner and is added by the lead.
Cost: ``observe`` twice (20 Hz) plus ``estimate`` once (10 Hz) per 0.1 s control step, median and p99.
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import time

import numpy as np

from mavbridge.waves import WaveEstimator
from mavbridge.waves.kinematic import KinematicBoat, estimate_errors, motion_samples, paper_sea
from vessel.sensors import SensorParams

HORIZON_S = 4.0


def one_run(heading_deg: float, speed: float, seed: int, duration: float, with_imu: bool,
            sensors: SensorParams) -> tuple[float | None, object | None]:
    """(time to first confidence s, errors at the end or None if not confident then)."""
    rng = np.random.default_rng(1000 + seed)
    sea = paper_sea(float(rng.uniform(-math.pi, math.pi)))
    t0 = float(rng.uniform(50.0, 5000.0))
    psi = math.radians(heading_deg)
    boat = KinematicBoat(sea, speed, lambda t: psi)
    est = WaveEstimator()
    first, last, sample = None, None, None
    for i, sample in enumerate(motion_samples(boat, duration, seed=seed, t0=t0, with_imu=with_imu,
                                              sensors=sensors)):
        est.observe(sample)
        if i % 2 == 1:
            last = est.estimate(sample.t_s)
            if last is not None and first is None:
                first = sample.t_s - t0
    if last is None or sample is None:
        return first, None
    north = sample.position_ned[0] + speed * HORIZON_S * math.cos(psi)
    east = sample.position_ned[1] + speed * HORIZON_S * math.sin(psi)
    return first, estimate_errors(last, sea, sample.t_s + HORIZON_S, north, east, t0)


def _median(values: list[float]) -> str:
    return f"{statistics.median(values):5.1f}" if values else "    —"


def table(args: argparse.Namespace, sensors: SensorParams) -> None:
    """The accuracy and convergence table over headings × speeds × seeds."""
    print(f"# paper's regular sea, kinematic truth, {args.seeds} seeds, {args.duration:g} s runs, "
          f"{'IMU + GPS' if not args.no_imu else 'GPS only (no IMU)'}, "
          f"{'ideal' if args.ideal_sensors else 'default'} sensors")
    print(" hdg°   μ°  U m/s  t_conf s  conf  dir°   T%    λ%    H%  phase°  ok")
    all_ok = total = 0
    for heading in range(0, 360, 30):
        mu = math.degrees(math.remainder(paper_sea().travel_dir_rad - math.radians(heading), 2 * math.pi))
        for speed in args.speeds:
            runs = [one_run(heading, speed, s, args.duration, not args.no_imu, sensors) for s in range(args.seeds)]
            firsts = [f for f, _ in runs if f is not None]
            errs = [e for _, e in runs if e is not None]
            ok = sum(1 for e in errs if e.within())
            all_ok, total = all_ok + ok, total + len(runs)
            cols = [_median([abs(getattr(e, name)) for e in errs])
                    for name in ("direction_deg", "period_pct", "length_pct", "height_pct", "phase_deg")]
            print(f"{heading:4d} {abs(mu):5.0f} {speed:5.1f} {_median(firsts):>9} {len(errs):3d}/{len(runs)} "
                  + " ".join(cols) + f" {ok:2d}/{len(runs)}")
    print(f"# within bounds at the end of the run: {all_ok}/{total}")


def cost(seconds: float = 120.0) -> tuple[float, float]:
    """Median and p99 wall time (ms) of one control step: two observe() and one estimate()."""
    boat = KinematicBoat(paper_sea(0.4), 1.5, lambda t: math.pi / 2)
    samples = list(motion_samples(boat, seconds, seed=3))
    est = WaveEstimator()
    steps = []
    for i in range(0, len(samples) - 1, 2):
        start = time.perf_counter()
        est.observe(samples[i])
        est.observe(samples[i + 1])
        est.estimate(samples[i + 1].t_s)
        steps.append(time.perf_counter() - start)
    ms = np.array(steps[20:]) * 1e3
    return float(np.median(ms)), float(np.percentile(ms, 99))


def parse(argv: list[str] | None) -> argparse.Namespace:
    """Command line; a bad value prints one line and exits 2."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3, help="seeds per cell (>= 1)")
    parser.add_argument("--duration", type=float, default=60.0, help="seconds per run, 10..3600")
    parser.add_argument("--speeds", default="0.5,1,1.5", help="comma-separated speeds in m/s, 0..5")
    parser.add_argument("--no-imu", action="store_true", help="no SCALED_IMU stream: heave from GPS height")
    parser.add_argument("--ideal-sensors", action="store_true", help="exact sensors (no noise, lag)")
    parser.add_argument("--cost-only", action="store_true", help="only the cost per control step")
    args = parser.parse_args(argv)
    try:
        args.speeds = [float(v) for v in args.speeds.split(",")]
    except ValueError:
        parser.exit(2, f"--speeds: {args.speeds!r} is not a comma-separated list of numbers in 0..5 m/s\n")
    if args.seeds < 1:
        parser.exit(2, f"--seeds: {args.seeds} is outside the allowed range >= 1\n")
    if not 10 <= args.duration <= 3600:
        parser.exit(2, f"--duration: {args.duration:g} is outside the allowed range [10, 3600] s\n")
    if not all(0 <= v <= 5 for v in args.speeds):
        parser.exit(2, f"--speeds: {args.speeds} has a value outside the allowed range [0, 5] m/s\n")
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse(argv)
    sensors = SensorParams.ideal() if args.ideal_sensors else SensorParams()
    if not args.cost_only:
        table(args, sensors)
    median, p99 = cost()
    print(f"# cost per control step (2 × observe at 20 Hz + estimate at 10 Hz): median {median:.3f} ms, "
          f"p99 {p99:.3f} ms (budget 0.15 ms median)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
