"""Payload mass from the steady speed curve, where the base model counts the payload's weight a second time.

The published model's payload load term (``payload_load_term``: the payload's weight counted again in body axes,
g_0) trims the bow down and pushes the hull forward, the harder the faster it goes: a heavier payload makes the
model faster, more so at higher speed, and trims it more. A hull faster than the model at the log's steady
commands may be so because it carries more payload or because its surge is less damped (``max_speed``, which
changes every speed alike). Both are fitted to the log's steady forward windows at every command above a crawl
(flown on the model, ``plant_steady``), and the payload is kept only when

- it explains the speeds clearly better than ``max_speed`` does (an RMS of the log-speed errors BETTER of
  max_speed's or less: on a hull that is the base both fit alike, and noise must not pick one),
- the model then trims as the log does (mean pitch of the windows within TRIM_TOL_RAD at every command),
- the fitted mass lies above zero and below RUNAWAY_MARGIN of the mass at which the model runs away at full command (the
  published model with 60 kg: tests/vessel/test_payload_load_runaway.py), and
- its interval (the windows bootstrapped, the fit linearised about the fitted mass) leaves out the base's mass.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from mavbridge.identify.analyse import Identification
from mavbridge.identify.estimate import Z95, Estimate, r_squared
from mavbridge.identify.model import calibrate_max_speed, plant_steady
from mavbridge.identify.surge import MIN_FRACTION
from vessel import OtterParameters
from vessel.wording import counted

TRIM_TOL_RAD = math.radians(0.2)  # the load term trims the published hull 0.08°/kg: 0.2° is about 2.5 kg
BETTER = 0.5
RUNAWAY_S = 60.0  # a model that stays finite this long at full command is taken not to run away
RUNAWAY_MARGIN = 0.95  # the fit stays below this share of the runaway mass (the model near it is barely stable)
MAX_MASS_KG = 400.0
MASS_STEP_KG = 0.05  # the golden-section search's resolution
BOOTSTRAP = 400
MAX_LEVELS = 6  # steady commands the fit flies the model at, at most (more are merged: see forward_levels)
GOLDEN = (math.sqrt(5) - 1) / 2


@dataclass(frozen=True)
class Level:
    """One steady forward command of the log: its thrust fraction, and the mean speed (m/s) and pitch (rad) of
    each of its windows."""

    fraction: float
    speeds: tuple[float, ...]
    pitches: tuple[float, ...]

    @property
    def speed(self) -> float:
        """Mean speed (m/s) over the windows."""
        return float(np.mean(self.speeds))

    @property
    def pitch(self) -> float:
        """Mean pitch (rad) over the windows."""
        return float(np.mean(self.pitches))


@dataclass(frozen=True)
class PayloadChoice:
    """The fitted payload (an estimate, kg) and whether it goes into vessel.yaml in place of ``max_speed``, or the
    line saying why not."""

    estimate: Estimate
    chosen: bool
    why_not: str = ""


def forward_levels(result: Identification) -> list[Level]:
    """The log's steady forward commands above a crawl (MIN_FRACTION), grouped by thrust fraction; a log that held
    more than MAX_LEVELS commands (a day of operations: an hour's log held 54) has them merged, in order of
    fraction, into MAX_LEVELS levels of about as many commands each, flown at their windows' mean fraction (the
    model is flown at every level for every mass the fit tries: 54 levels took the identification of an hour's
    log from seconds to 130 s)."""
    groups: dict[float, list[tuple[float, float, float]]] = {}
    for point in result.surge.get("points", []):
        if point.fraction > MIN_FRACTION and point.speed_m_s > 0:
            groups.setdefault(round(point.fraction, 2), []).append((point.fraction, point.speed_m_s,
                                                                   point.pitch_rad))
    if len(groups) <= MAX_LEVELS:
        return [_level(fraction, windows) for fraction, windows in sorted(groups.items())]
    ordered = [windows for _, windows in sorted(groups.items())]
    edges = np.linspace(0, len(ordered), MAX_LEVELS + 1).astype(int)
    merged = [[w for windows in ordered[i:j] for w in windows] for i, j in itertools.pairwise(edges)]
    return [_level(float(np.mean([f for f, _, _ in windows])), windows) for windows in merged]


def _level(fraction: float, windows: list[tuple[float, float, float]]) -> Level:
    """A level at ``fraction`` of windows (fraction, speed m/s, pitch rad)."""
    return Level(fraction, tuple(u for _, u, _ in windows), tuple(q for _, _, q in windows))


def model_errors(p: OtterParameters, levels: list[Level]) -> tuple[np.ndarray, np.ndarray] | None:
    """(log of the model's speed over the log's, model's pitch − log's in rad) at each level; None when the model
    diverges at one."""
    speed, trim = [], []
    for level in levels:
        got = plant_steady(p, math.sqrt(level.fraction))
        if got is None or not got[0] > 0:
            return None
        speed.append(math.log(got[0] / level.speed))
        trim.append(got[1] - level.pitch)
    return np.asarray(speed), np.asarray(trim)


def _cost(p: OtterParameters, levels: list[Level], mass: float) -> float:
    got = model_errors(p.replace(payload_mass=mass), levels)
    return math.inf if got is None else float(np.sum(got[0] ** 2))


def runaway_mass(p: OtterParameters) -> float:
    """The smallest payload (kg, to MASS_STEP_KG·10) at which the model runs away at full command (not finite within
    RUNAWAY_S); MAX_MASS_KG when none up to it does."""
    def runs_away(mass: float) -> bool:
        return plant_steady(p.replace(payload_mass=mass), 1.0, RUNAWAY_S) is None

    lo, hi = 0.0, MAX_MASS_KG
    if not runs_away(hi):
        return hi
    if runs_away(lo):
        return lo
    while hi - lo > 10 * MASS_STEP_KG:
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if runs_away(mid) else (mid, hi)
    return hi


def fit_mass(p: OtterParameters, levels: list[Level], limit: float) -> float:
    """The payload (kg, in [0, limit]) whose model flies the log's steady commands at the log's speeds, least
    squares in the log of the speeds (golden-section search: the cost has one minimum, speed grows with mass)."""
    a, b = 0.0, limit
    c, d = b - GOLDEN * (b - a), a + GOLDEN * (b - a)
    fc, fd = _cost(p, levels, c), _cost(p, levels, d)
    while b - a > MASS_STEP_KG:
        if fc <= fd:
            b, d, fd = d, c, fc
            c = b - GOLDEN * (b - a)
            fc = _cost(p, levels, c)
        else:
            a, c, fc = c, d, fd
            d = a + GOLDEN * (b - a)
            fd = _cost(p, levels, d)
    return 0.5 * (a + b)


def mass_interval(p: OtterParameters, levels: list[Level], mass: float, residuals: np.ndarray) -> tuple[float, float]:
    """About 95 % of the fitted mass, the fit linearised at ``mass`` (the slope of each level's log speed on mass):
    the windows resampled within each level (seeded), each draw's level means turned into a mass, and never
    narrower than ±1.96 standard errors of the fit's own ``residuals`` (log speed, one per level) allow — what the
    model cannot follow of the log's curve is not shrunk by many windows."""
    step = max(0.5, 0.02 * mass)
    up, down = model_errors(p.replace(payload_mass=mass + step), levels), \
        model_errors(p.replace(payload_mass=max(mass - step, 0.0)), levels)
    if up is None or down is None:
        return math.nan, math.nan
    slope = (up[0] - down[0]) / (mass + step - max(mass - step, 0.0))
    norm = float(slope @ slope)
    if not norm > 0:
        return math.nan, math.nan
    rng = np.random.default_rng(0)
    draws = []
    for _ in range(BOOTSTRAP):
        shift = np.array([math.log(np.mean(rng.choice(v.speeds, len(v.speeds))) / v.speed) for v in levels])
        draws.append(mass + float(slope @ shift / norm))
    half = Z95 * math.sqrt(float(residuals @ residuals) / max(len(levels) - 1, 1) / norm)
    return min(float(np.percentile(draws, 2.5)), mass - half), max(float(np.percentile(draws, 97.5)), mass + half)


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(x**2)))


def fit_payload(p: OtterParameters, result: Identification) -> PayloadChoice | None:
    """The payload fitted to the log's steady speeds and whether it explains them (see the module docstring);
    None where the base has no payload load term or the log holds fewer than two steady forward commands."""
    levels = forward_levels(result)
    if not p.payload_load_term or len(levels) < 2:
        return None
    limit = RUNAWAY_MARGIN * runaway_mass(p)
    mass = fit_mass(p, levels, limit)
    errors = model_errors(p.replace(payload_mass=mass), levels)
    low, high = (math.nan, math.nan) if errors is None else mass_interval(p, levels, mass, errors[0])
    speed_rms = math.inf if errors is None else _rms(errors[0])
    calibrated = calibrate_max_speed(p, {"max_speed": p.max_speed}, [(v.fraction, v.speed, 1) for v in levels])
    other = model_errors(p.replace(**calibrated), levels)
    other_rms = math.inf if other is None else _rms(other[0])
    source = (f"{counted(sum(len(v.speeds) for v in levels), 'steady forward window')} at "
              f"{counted(len(levels), 'command')}, the model flown at each; speed RMS {100 * speed_rms:.1f} % "
              f"(max_speed alone: {100 * other_rms:.1f} %)")
    trim = math.inf if errors is None else float(np.max(np.abs(np.nan_to_num(errors[1], nan=math.inf))))
    speeds = np.array([v.speed for v in levels])
    fit = math.nan if errors is None else r_squared(speeds, speeds * np.exp(errors[0]))
    estimate = Estimate(mass, low, high, "kg", source, fit)
    why = _why_not(p, mass, (low, high), limit, speed_rms, other_rms, trim)
    return PayloadChoice(estimate, not why, why)


def _why_not(p: OtterParameters, mass: float, interval: tuple[float, float], limit: float, speed_rms: float,
             other_rms: float, trim: float) -> str:
    """Why the fitted payload does not go into vessel.yaml ('' when it does)."""
    head = f"payload_mass_kg {mass:.3g}: "
    if mass >= limit - 2 * MASS_STEP_KG:
        return head + f"at the bound where the model runs away at full command ({limit:.3g} kg): max_speed is " \
                      "fitted instead"
    if mass <= 2 * MASS_STEP_KG:
        return head + "at no payload, the bound: the speeds want less than the payload can give; max_speed is " \
                      "fitted instead"
    if not (math.isfinite(interval[0]) and math.isfinite(interval[1])):
        return head + "no interval (the model's speeds do not change with the mass about it, or it runs away "\
                      "there): max_speed is fitted instead"
    if interval[0] <= p.payload_mass <= interval[1]:
        return head + f"its interval [{interval[0]:.3g}, {interval[1]:.3g}] holds the base's {p.payload_mass:g} kg: " \
                      "max_speed is fitted instead"
    if not speed_rms < BETTER * other_rms:
        return head + f"explains the steady speeds not {1 / BETTER:g} times better than max_speed " \
                      f"({100 * speed_rms:.1f} % against {100 * other_rms:.1f} % RMS): max_speed is fitted instead"
    if not trim <= TRIM_TOL_RAD:
        return head + f"the model would trim {math.degrees(trim):.2f}° off the log's pitch (more than " \
                      f"{math.degrees(TRIM_TOL_RAD):g}°): max_speed is fitted instead"
    return ""
