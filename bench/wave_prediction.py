"""How well the boat predicts the slope of an irregular sea it will meet 1, 2 and 4 s ahead, from its own motion.

Run: python bench/wave_prediction.py [--seeds 2] [--quick]

For each sea (Hs 1.75 m, Tp 6 s: Pierson–Moskowitz — which is JONSWAP γ 1 here, ``vessel.sea.spectra`` — JONSWAP
γ 3.3 and γ 5, and a short-crested JONSWAP γ 3.3 with cos-2s spreading s = 10, 200 components, each seed its own
sea) and each heading relative to the waves (head, beam, quartering = waves 45° off the stern, following) the boat
runs a straight line at 1.75 m/s; a last case turns 90° (head to beam seas, 4.5°/s) in the middle of the scored
part. The truth is the simulator's sea at the hull: ``IrregularSea.wave_field(otter_parameters())`` (averaged over
the waterplane), its gradient (∂ζ/∂N, ∂ζ/∂E) along the path. What the predictor is fed is kinematic, not the 6-DOF
plant: the hull is taken to lie along that surface (roll and pitch = its slope angles, as
``mavbridge.waves.kinematic``), with Gaussian noise of 0.5° on roll and pitch and 0.2° on heading at 20 Hz, and
the position with a slow error (0.3 m RMS, 30 s time constant: the window estimator's dead-reckoned track, not
raw GPS fixes — white noise of 0.1 m on the position alone cut the following-sea skill at 1 s from 0.99 to 0.78); no
heave.

The predictor (``mavbridge.waves.phase.predictor``, default settings) watches 60 s, then every fit over the next
60 s predicts along the true path ahead; the columns are, pooled over both slope components, fits and seeds: the
correlation r and the RMS error (°) of the predicted against the true slope at 1, 2 and 4 s ahead; r of two
baselines at 1 s — persistence (the slope measured now) and a 20-lag autoregressive model of each measured slope
channel at 10 Hz (fitted on the same 40 s window; it predicts in the boat's frame) — and the share of fits the
predictor called confident at each lead with r over those. ``rms°`` is the true slope's RMS per component.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import dataclass

import numpy as np

from mavbridge.waves.phase.bank import slope_from_attitude
from mavbridge.waves.phase.predictor import PhasePredictor
from vessel import otter_parameters
from vessel.sea.irregular_sea import IrregularSea

RATE_HZ = 20.0
SPEED_MPS = 1.75
WATCH_S, SCORED_S = 60.0, 60.0
LEADS_S = (1.0, 2.0, 4.0)
AR_ORDER, AR_RATE_HZ, AR_WINDOW_S = 20, 10.0, 40.0
SEAS = {"pm (jonswap γ 1)": dict(spectrum="pm"), "jonswap γ 3.3": dict(gamma=3.3), "jonswap γ 5": dict(gamma=5.0),
        "short-crested s 10": dict(gamma=3.3, spreading_s=10.0)}
# heading of the boat relative to the waves' travel direction (deg): 180 = head seas, 0 = following
CASES = {"head": 180.0, "beam": 90.0, "quartering": 45.0, "following": 0.0, "turn head→beam": None}
TURN_RATE_DEG_S = 4.5
POSITION_NOISE_M = [0.3]  # RMS of the track's error, m
TRACK_TAU_S = 30.0  # its time constant (the window estimator pulls its track to GPS over 30 s)
SETTINGS: list = [None]  # the predictor's settings (None: its defaults)


@dataclass
class Pairs:
    """Predicted and true slope components (rad) per lead, with the predictor's confidence, and the baselines."""

    predicted: dict[float, list[np.ndarray]]
    truth: dict[float, list[np.ndarray]]
    confident: dict[float, list[np.ndarray]]
    persistence: list[np.ndarray]
    ar: list[np.ndarray]
    truth_1s: list[np.ndarray]


def new_pairs() -> Pairs:
    """Empty pairs for every lead."""
    return Pairs({h: [] for h in LEADS_S}, {h: [] for h in LEADS_S}, {h: [] for h in LEADS_S}, [], [], [])


def heading_schedule(case: str, t: np.ndarray) -> np.ndarray:
    """The boat's heading (rad NED) over time; the waves travel North (0)."""
    relative = CASES[case]
    if relative is not None:
        return np.full(t.size, math.radians(relative))
    start = WATCH_S + 0.5 * SCORED_S - 10.0  # head (180°) to beam (90°) at 4.5°/s, centred in the scored part
    turned = np.clip((t - start) * TURN_RATE_DEG_S, 0.0, 90.0)
    return np.radians(180.0 - turned)


def path(case: str, duration: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(t s, north m, east m, heading rad) at ``RATE_HZ``, the boat at ``SPEED_MPS`` along its heading."""
    t = np.arange(0.0, duration, 1.0 / RATE_HZ)
    psi = heading_schedule(case, t)
    north = np.concatenate(([0.0], np.cumsum(SPEED_MPS * np.cos(psi[:-1]) / RATE_HZ)))
    east = np.concatenate(([0.0], np.cumsum(SPEED_MPS * np.sin(psi[:-1]) / RATE_HZ)))
    return t, north, east, psi


def measured_attitude(sea: object, t: np.ndarray, north: np.ndarray, east: np.ndarray, psi: np.ndarray,
                      rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(roll, pitch, heading) rad of a hull lying along the surface (geometric roll sign), with sensor noise."""
    a_n, a_e = sea.slope_angles(north, east, t)
    pitch = a_n * np.cos(psi) + a_e * np.sin(psi)
    roll = -(a_e * np.cos(psi) - a_n * np.sin(psi))
    noise = rng.normal(0.0, 1.0, (3, t.size)) * np.radians([[0.5], [0.5], [0.2]])
    return roll + noise[0], pitch + noise[1], psi + noise[2]


def track_error(rng: np.random.Generator, n: int) -> np.ndarray:
    """A dead-reckoned track's error (m): slow (first-order, ``TRACK_TAU_S``), ``POSITION_NOISE_M`` RMS."""
    g = 1.0 / (TRACK_TAU_S * RATE_HZ)
    drive = rng.normal(0.0, POSITION_NOISE_M[0] * math.sqrt(2 * g), n)
    out = np.empty(n)
    out[0] = rng.normal(0.0, POSITION_NOISE_M[0])
    for i in range(1, n):
        out[i] = out[i - 1] * (1 - g) + drive[i]
    return out


def ar_forecast(series: np.ndarray, steps: int) -> float:
    """The ``AR_ORDER``-lag least-squares autoregressive forecast ``steps`` samples past the end of ``series``."""
    x = series - series.mean()
    lags = np.column_stack([x[AR_ORDER - 1 - i: x.size - 1 - i] for i in range(AR_ORDER)])
    normal = lags.T @ lags
    coef = np.linalg.solve(normal + 1e-3 * np.trace(normal) / AR_ORDER * np.eye(AR_ORDER), lags.T @ x[AR_ORDER:])
    history = list(x[-AR_ORDER:][::-1])
    for _ in range(steps):
        history.insert(0, float(coef @ np.asarray(history[:AR_ORDER])))
    return history[0]


def one_run(sea_name: str, case: str, seed: int, pairs: Pairs) -> None:
    """One boat in one sea: feed the predictor, collect its predictions after the watch against the truth."""
    sea = IrregularSea(hs_m=1.75, tp_s=6.0, travel_dir_deg=0.0, seed=seed, **SEAS[sea_name]).wave_field(
        otter_parameters())
    rng = np.random.default_rng(10_000 + seed)
    t, north, east, psi = path(case, WATCH_S + SCORED_S + max(LEADS_S) + 1.0)
    t_clock = t + float(rng.uniform(100.0, 5000.0))  # the autopilot's clock: its own origin
    true_n, true_e = (np.asarray(v) for v in sea.gradient(north, east, t))
    roll, pitch, heading = measured_attitude(sea, t, north, east, psi, rng)
    pos_n, pos_e = north + track_error(rng, t.size), east + track_error(rng, t.size)
    predictor = PhasePredictor(SETTINGS[0])
    stride = round(RATE_HZ / AR_RATE_HZ)
    for i in range(t.size):
        fits = predictor.fits
        predictor.observe_attitude(t_clock[i], pos_n[i], pos_e[i], roll[i], pitch[i], heading[i])
        if predictor.fits == fits or not WATCH_S <= t[i] <= WATCH_S + SCORED_S:
            continue
        ahead = [i + round(h * RATE_HZ) for h in LEADS_S]
        pn, pe, _, ok = predictor.predict(t_clock[ahead], north[ahead], east[ahead])
        for j, h in enumerate(LEADS_S):
            pairs.predicted[h].append(np.array([pn[j], pe[j]]))
            pairs.truth[h].append(np.array([true_n[ahead[j]], true_e[ahead[j]]]))
            pairs.confident[h].append(np.array([ok[j], ok[j]]))
        window = slice(max(0, i + 1 - round(AR_WINDOW_S * RATE_HZ)), i + 1)
        sn, se = slope_from_attitude(roll[window][::-1][::stride][::-1], pitch[window][::-1][::stride][::-1],
                                     heading[window][::-1][::stride][::-1])
        pairs.persistence.append(np.array([sn[-1], se[-1]]))
        steps = round(LEADS_S[0] * AR_RATE_HZ)
        pairs.ar.append(np.array([ar_forecast(sn, steps), ar_forecast(se, steps)]))
        pairs.truth_1s.append(pairs.truth[LEADS_S[0]][-1])


def _r(a: list[np.ndarray], b: list[np.ndarray], mask: list[np.ndarray] | None = None) -> float:
    """Correlation of the concatenated ``a`` and ``b`` (only where ``mask``), NaN when too few points."""
    x, y = np.concatenate(a), np.concatenate(b)
    if mask is not None:
        keep = np.concatenate(mask).astype(bool)
        x, y = x[keep], y[keep]
    if x.size < 4 or np.std(x) == 0 or np.std(y) == 0:
        return math.nan
    return float(np.corrcoef(x, y)[0, 1])


def row(sea_name: str, case: str, pairs: Pairs) -> tuple[str, dict[float, float]]:
    """One table row and its correlations per lead."""
    r = {h: _r(pairs.predicted[h], pairs.truth[h]) for h in LEADS_S}
    rmse = {h: math.degrees(math.sqrt(np.mean((np.concatenate(pairs.predicted[h])
                                              - np.concatenate(pairs.truth[h])) ** 2))) for h in LEADS_S}
    share = {h: 100 * float(np.mean(np.concatenate(pairs.confident[h]))) for h in LEADS_S}
    r_conf = {h: _r(pairs.predicted[h], pairs.truth[h], pairs.confident[h]) for h in LEADS_S}
    rms = math.degrees(math.sqrt(np.mean(np.concatenate(pairs.truth[LEADS_S[0]]) ** 2)))
    text = (f"| {sea_name} | {case} | {rms:.1f} | " + " | ".join(f"{r[h]:.2f}" for h in LEADS_S) + " | "
            + " | ".join(f"{rmse[h]:.1f}" for h in LEADS_S)
            + f" | {_r(pairs.persistence, pairs.truth_1s):.2f} | {_r(pairs.ar, pairs.truth_1s):.2f} | "
            + " | ".join(f"{share[h]:.0f} ({r_conf[h]:.2f})" if share[h] > 0 else "0 (–)" for h in LEADS_S) + " |")
    return text, r


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=2, help="seas per cell (>= 1), each its own components")
    parser.add_argument("--quick", action="store_true", help="one seed, JONSWAP γ 3.3 head and following only")
    args = parser.parse_args(argv)
    if args.seeds < 1:
        parser.exit(2, f"--seeds: {args.seeds} is outside the allowed range >= 1\n")
    seas, cases, seeds = (["jonswap γ 3.3"], ["head", "following"], 1) if args.quick else (list(SEAS), list(CASES),
                                                                                           args.seeds)
    print(f"# Hs 1.75 m, Tp 6 s, {SPEED_MPS} m/s, {seeds} seed(s), kinematic hull + noise (roll/pitch 0.5°), "
          f"scored {SCORED_S:g} s after {WATCH_S:g} s of watching")
    print("| sea | case | rms° | r 1 s | r 2 s | r 4 s | rmse° 1 s | rmse° 2 s | rmse° 4 s | persist r 1 s "
          "| AR r 1 s | confident % (r) 1 s | 2 s | 4 s |")
    print("|---" * 14 + "|")
    start = time.perf_counter()
    summary = {}
    for sea_name in seas:
        summary[sea_name] = {h: [] for h in LEADS_S}
        for case in cases:
            pairs = new_pairs()
            for seed in range(1, seeds + 1):
                one_run(sea_name, case, seed, pairs)
            text, r = row(sea_name, case, pairs)
            print(text, flush=True)
            for h in LEADS_S:
                summary[sea_name][h].append(r[h])
    for sea_name, per_lead in summary.items():
        print(f"# {sea_name}: mean r over cases " + ", ".join(f"{h:g} s {np.nanmean(v):.2f}"
                                                                 for h, v in per_lead.items()))
    print(f"# {time.perf_counter() - start:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
