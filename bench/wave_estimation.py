"""How well and how fast the wave estimator finds the waves, and what it costs per control step.

Run: python bench/wave_estimation.py [--seeds 3]                      # issue 29's table (the default)
     python bench/wave_estimation.py --kinematic [--duration 60] [--speeds 0.5,1,1.5] [--no-imu]
     [--ideal-sensors] [--cost-only] [--plant] [--no-calibration]

Default: the first confident estimate of the companion's estimator on the realistic hull (``estimation_table``):
the paper's sea and three other regular seas from other directions, drifting and under way on two headings,
each seed its own hidden phase and sensor noise; seconds to the first confident answer and its errors against
issue 29's bounds (within 15 s; period 3 %, direction 10°, wavelength 10 %, height 15 %).

``--kinematic``: the older table below, the recursive estimator's design bench (``--method`` picks either).

Kinematic truth (``mavbridge.waves.kinematic``): a point riding the paper's regular sea (1.75 m, 35 m,
6 s, travelling West, a hidden random phase, a random autopilot boot time), seen through the default
sensor model of ``vessel.sensors``, heading 0–330° every 30° at each speed, several seeds. For each
cell: the median time to the first confident estimate (s; "—" if none within the run), how many seeds
were confident at the end, and the median absolute errors at the end: direction °, period %,
wavelength %, height % and the predicted phase 4 s ahead (the horizon end) °; "ok" counts the seeds
inside the issue's bounds (10°, 5 %, 15 %, 15 %, 30°). The relative wave heading μ is 180° for head
seas, 0° for following seas. Irregular seas: a row follows once ``vessel`` has them (issue 11).
``--no-imu`` tells the estimator the GPS height stream's lag (fix lag + half the fix interval).
``--plant``: the same table from ``vessel.Plant`` (equal shaft speeds of 70 rad/s, ≈ 1.5 m/s) with the
IMU computed from the plant's own ẋ; if the vessel model offers heave that follows the sea
(``Plant(surface_heave=True)``, issue 11) it is switched on, else the paper's hull does not heave and
only ω_e and the wave's axis can be seen (the table then says so). The hull's roll/pitch response is
calibrated once (``mavbridge.waves.calibration``, heading 45°, another phase) unless ``--no-calibration``.
``--closed-loop``: the roll reduction of Balanced against Direct, both flown on the estimate, in the
in-process runner (``scenarios/estimated.yaml``: heave, hidden phase from each seed, default sensors),
beside the same runs on the truth (the true regular wave: it is a single component, so fit = field).
``--closed-loop --sea jonswap|ss3|ss4|short``: the same in irregular long-crested seas, or short-crested
(cos-2s, s = 10) (``scenarios/jonswap_estimated.yaml``: JONSWAP Hs 1.75 m, Tp 6 s, γ 3.3, or NATO sea state 3 / 4 with
Table I's values), each seed drawing its own sea; the truth is then the full 200-component field built
into the NMPC's model, the estimate a regular wave when confident plus the sea's slope statistics.
Cost: ``observe`` twice (20 Hz) plus ``estimate`` once (10 Hz) per 0.1 s control step, median and p99.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import statistics
import sys
import time

import numpy as np
from closed_loop_table import SEAS, closed_loop_table, weights_flag
from estimation_table import print_table

from mavbridge.waves import EstimatorSettings, make_estimator
from mavbridge.waves.calibration import hull_response, record_plant, settings_for
from mavbridge.waves.kinematic import KinematicBoat, estimate_errors, motion_samples, paper_sea, to_motion_sample
from mavbridge.waves.settings import METHODS
from vessel import Plant, otter_parameters
from vessel.sensors import SensorModel, SensorParams

HORIZON_S = 4.0
METHOD = ["window"]  # the estimator the tables use (--method)


def one_run(heading_deg: float, speed: float, seed: int, duration: float, with_imu: bool,
            sensors: SensorParams) -> tuple[float | None, object | None]:
    """(time to first confidence s, errors at the end or None if not confident then)."""
    rng = np.random.default_rng(1000 + seed)
    sea = paper_sea(float(rng.uniform(-math.pi, math.pi)))
    t0 = float(rng.uniform(50.0, 5000.0))
    psi = math.radians(heading_deg)
    boat = KinematicBoat(sea, speed, lambda t: psi)
    # without the IMU the heave comes from GPS height: tell the estimator the stream's lag (fix lag + hold)
    lag = sensors.gps_lag_ms / 1000 + (0.5 / sensors.gps_hz if sensors.gps_hz > 0 else 0.0)
    est = make_estimator(EstimatorSettings(method=METHOD[0]) if with_imu else
                         EstimatorSettings(position_lag_s=lag, method=METHOD[0]))
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


def _plant_and_imu(sea: object, heading: float, heave: bool) -> tuple[Plant, object]:
    """A plant heading ``heading`` rad in ``sea`` and its ideal IMU (x, t) -> specific force."""
    import casadi as ca

    from vessel.dynamics import OceanCurrent, plant_ode
    from vessel.imu import specific_force

    params = otter_parameters()
    x0 = np.zeros(14)
    x0[5] = heading
    options = {"surface_heave": True} if heave else {}
    plant = Plant(params, sea, dt=0.01, x0=x0, **options)
    ode = plant_ode(params, sea, OceanCurrent(), **options)
    x, t = ca.SX.sym("x", 14), ca.SX.sym("t")
    xdot = ode(x, ca.DM.zeros(2), t)
    imu = ca.Function("imu", [x, t], [specific_force(x[6:12], xdot[6:12], x[3], x[4], params.g)])
    return plant, imu


def heave_available() -> bool:
    """True if the vessel model can make the hull heave with the sea (issue 11's option)."""
    import inspect

    return "surface_heave" in inspect.signature(Plant.__init__).parameters


def calibrated_settings(heave: bool) -> EstimatorSettings:
    """The hull's roll/pitch response measured once: heading 45°, 80 s, another wave phase."""
    sea = paper_sea(2.0)
    plant, _ = _plant_and_imu(sea, math.radians(45), heave)
    return settings_for(*hull_response(*record_plant(plant, sea, (70.0, 70.0), 80.0)))


def one_plant_run(heading_deg: float, seed: int, duration: float, settings: EstimatorSettings | None,
                  heave: bool) -> tuple[float | None, object | None, float, float]:
    """(time to first confidence, errors at the end or None, encounter-frequency error %, yaw drift °)."""
    rng = np.random.default_rng(2000 + seed)
    sea = paper_sea(float(rng.uniform(-math.pi, math.pi)))
    t0 = float(rng.uniform(50.0, 5000.0))
    plant, imu = _plant_and_imu(sea, math.radians(heading_deg), heave)
    sensors = SensorModel(SensorParams(), np.random.default_rng(seed))
    est = make_estimator(dataclasses.replace(settings or EstimatorSettings(), method=METHOD[0]))
    first, last, phases, drift = None, None, [], 0.0
    chi = sea.travel_dir_rad
    for i in range(round(duration / 0.05)):
        x, t = plant.state, plant.time
        f = np.asarray(imu(x, t)).ravel()
        est.observe(to_motion_sample(sensors.sample(t0 + t, x[0:6], x[6:12], f)))
        phases.append(sea.frequency * t - sea.wavenumber * (x[0] * math.cos(chi) + x[1] * math.sin(chi)))
        drift = max(drift, abs(math.degrees(math.remainder(x[5] - math.radians(heading_deg), 2 * math.pi))))
        if i % 2 == 1:
            last = est.estimate(t0 + t)
            first = t if first is None and last is not None else first
        plant.advance((70.0, 70.0), 5)
    n = min(len(phases) - 1, 400)
    omega_e = (phases[-1] - phases[-1 - n]) / (0.05 * n)
    we_err = 100 * (est.encounter_frequency() / omega_e - 1)
    if last is None:
        return first, None, we_err, drift
    x = plant.state
    speed = math.hypot(x[0], x[1]) / plant.time
    north, east = x[0] + speed * HORIZON_S * math.cos(x[5]), x[1] + speed * HORIZON_S * math.sin(x[5])
    return first, estimate_errors(last, sea, t0 + plant.time + HORIZON_S, north, east, t0), we_err, drift


def plant_table(args: argparse.Namespace) -> None:
    """The table from the vessel plant (heave if the model has it)."""
    heave = heave_available()
    settings = None if args.no_calibration else calibrated_settings(heave)
    cal = ("no calibration" if settings is None else
           f"calibrated roll {settings.roll_gain:.3f}/{settings.roll_phase_deg:+.1f}°, "
           f"pitch {settings.pitch_gain:.3f}/{settings.pitch_phase_deg:+.1f}°")
    print(f"# vessel.Plant in the paper's sea, shaft speeds 70 rad/s, {args.seeds} seeds, {args.duration:g} s, "
          f"{'heave follows the sea' if heave else 'paper hull: no heave (only ω_e and the axis are seen)'}, {cal}")
    print("# open loop, no heading controller: away from head/following seas the hull yaws freely (ψ drift)")
    print(" hdg°   μ°  ψ drift°  ω_e err%  t_conf s  conf  dir°   T%    λ%    H%  phase°  ok")
    for heading in range(0, 360, 30):
        mu = math.degrees(math.remainder(paper_sea().travel_dir_rad - math.radians(heading), 2 * math.pi))
        runs = [one_plant_run(heading, s, args.duration, settings, heave) for s in range(args.seeds)]
        firsts = [f for f, _, _, _ in runs if f is not None]
        errs = [e for _, e, _, _ in runs if e is not None]
        cols = [_median([abs(getattr(e, name)) for e in errs])
                for name in ("direction_deg", "period_pct", "length_pct", "height_pct", "phase_deg")]
        print(f"{heading:4d} {abs(mu):5.0f} {_median([d for *_, d in runs]):>9} "
              f"{_median([abs(w) for _, _, w, _ in runs]):>9} {_median(firsts):>9} "
              f"{len(errs):3d}/{len(runs)} " + " ".join(cols) + f" {sum(e.within() for e in errs):2d}/{len(runs)}")


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
    est = make_estimator(EstimatorSettings(method=METHOD[0]))
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
    parser.add_argument("--kinematic", action="store_true", help="the older kinematic/plant tables instead of the "
                                                                   "first-confident table")
    parser.add_argument("--method", choices=METHODS, default="window", help="the estimator (default window)")
    parser.add_argument("--duration", type=float, default=60.0, help="seconds per run, 10..3600")
    parser.add_argument("--speeds", default="0.5,1,1.5", help="comma-separated speeds in m/s, 0..5")
    parser.add_argument("--no-imu", action="store_true", help="no SCALED_IMU stream: heave from GPS height")
    parser.add_argument("--ideal-sensors", action="store_true", help="exact sensors (no noise, lag)")
    parser.add_argument("--cost-only", action="store_true", help="only the cost per control step")
    parser.add_argument("--plant", action="store_true", help="the table from vessel.Plant instead of kinematics")
    parser.add_argument("--no-calibration", action="store_true", help="with --plant: no hull-response calibration")
    parser.add_argument("--closed-loop", action="store_true", help="Balanced vs Direct on the estimate and truth")
    parser.add_argument("--sea", choices=tuple(SEAS), default="paper", help="with --closed-loop: the sea")
    parser.add_argument("--sources", default="estimated,truth",
                        help="with --closed-loop: comma-separated wave sources to fly on: estimated, predicted "
                             "(the estimator and the phase predictor's bank), oracle (the bank made of the true sea's "
                             "K strongest components: simulation only, a bound on the bank), trueslope (the predictor "
                             "fed the true slope instead of the attitude: simulation only), truestats (the estimator "
                             "with the sea's true slope covariance in place of its own: simulation only), truth")
    parser.add_argument("--components", type=int, default=12, help="with --sources predicted: K of the bank, 1..32")
    parser.add_argument("--bank-spread", choices=("full", "residual", "none"), default="full",
                        help="with --sources predicted: the statistics term while the bank is in use")
    parser.add_argument("--bank-fade", choices=("on", "off"), default="on",
                        help="with --sources predicted: fade the bank out where the predictor's skill halves")
    parser.add_argument("--bank-select", choices=("compressed", "strongest"), default="compressed",
                        help="with --sources predicted/oracle: the fit compressed over the horizon to K, or its K "
                             "strongest components")
    parser.add_argument("--bank-lead", type=float, default=1.0, metavar="S",
                        help="with --sources predicted: use the bank while confident this far ahead, 0..4 s")
    parser.add_argument("--solver", choices=("ipopt", "rti", "asrti", "nrti"), default=None,
                        help="with --closed-loop: the NMPC solver of every run (default: the scenario's)")
    parser.add_argument("--weights", default=None, metavar="Q,R,S",
                        help="with --closed-loop: Balanced's weights (e.g. those `mavbridge tune` chose), and Direct's "
                             "Q and S with R 0 (default: the scenario's); the NATO tunes fly nrti: add --solver nrti")
    parser.add_argument("--watch", type=float, default=None, metavar="S",
                        help="with --closed-loop: seconds the estimator watches the drifting boat first (default: "
                             "the scenario's, 60; 0: a cold start)")
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
    if not set(args.sources.split(",")) <= {"estimated", "predicted", "oracle", "trueslope", "truestats", "truth"}:
        parser.exit(2, f"--sources: {args.sources!r} is not a comma-separated list of estimated, predicted, oracle, "
                    "trueslope, truestats, truth\n")
    if "truestats" in args.sources.split(",") and args.sea not in ("jonswap", "short", "ss3", "ss4"):
        parser.exit(2, f"--sources truestats: needs an irregular sea (--sea jonswap, short, ss3 or ss4), not "
                    f"{args.sea!r}\n")
    if not 0 <= args.bank_lead <= 4:
        parser.exit(2, f"--bank-lead: {args.bank_lead:g} is outside the allowed range [0, 4] s\n")
    if not 1 <= args.components <= 256:
        parser.exit(2, f"--components: {args.components} is outside the allowed range [1, 256]\n")
    if args.watch is not None and not 0 <= args.watch <= 3600:
        parser.exit(2, f"--watch: {args.watch:g} is outside the allowed range [0, 3600] s\n")
    args.weights = weights_flag(parser, args.weights)
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse(argv)
    METHOD[0] = args.method
    sensors = SensorParams.ideal() if args.ideal_sensors else SensorParams()
    if not (args.kinematic or args.closed_loop or args.cost_only or args.plant):
        print_table(args.seeds)
    elif args.closed_loop:
        closed_loop_table(args.seeds, args.watch, args.sea, args.sources,
                          {"components": args.components, "bank_spread": args.bank_spread, "solver": args.solver,
                           "bank_fade": args.bank_fade == "on", "bank_lead_s": args.bank_lead,
                           "bank_select": args.bank_select, "weights": args.weights})
        return 0
    if args.plant and not args.cost_only:
        plant_table(args)
    elif args.kinematic and not args.cost_only:
        table(args, sensors)
    median, p99 = cost()
    print(f"# cost per control step (2 × observe at 20 Hz + estimate at 10 Hz): median {median:.3f} ms, "
          f"p99 {p99:.3f} ms (budget 0.15 ms median)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
