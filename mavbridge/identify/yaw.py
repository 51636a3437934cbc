"""A first-order Nomoto model from the steering command to the yaw rate, and the propellers' asymmetry.

T ṙ + r = K δ + r₀ on the gap-free stretches under way: first by least squares on the discretised model
r[k+1] = a r[k] + b δ[k] + c (a = e^(−dt/T), K = b/(1−a), r₀ = c/(1−a)), then instrumental-variable steps
whose instruments are the last model's own simulated yaw rate, repeated until T settles (noise on the measured
rate, the yaw's differences, lengthens T less: on a simulated zig-zag 0.80 s after one step, 0.68 s settled,
0.63 s from the true rate). r₀ is
the yaw rate with no steering: the propellers' asymmetry (a weaker motor, a bent shaft, a fouled hull). The
fit figure is the R² of the yaw rate simulated from the command alone; the interval is the spread of the same
fit over independent blocks of the log.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mavbridge.identify.estimate import Estimate, r_squared, spread_interval
from mavbridge.identify.series import Stretch, blocks

MIN_S = 30.0
MIN_R2 = 0.3
BLOCK_S = 60.0
MIN_BLOCK_STEERING = 0.1  # a block whose steering varies less than this share of the whole's says nothing of K, T
SHORT_BLOCK_S = 20.0  # blocks of this (or 10 T) when BLOCK_S gives fewer than two fits: one zig-zag leg
T_RANGE_S = (0.05, 30.0)
IV_ITERATIONS = 6
IV_SETTLED = 0.005


@dataclass(frozen=True)
class Nomoto:
    """K (yaw rate per unit of command, rad/s per unit), T (s) and r₀ (rad/s) at the grid step ``dt``."""

    K: float
    T: float
    r0: float
    dt: float

    def simulate(self, delta: np.ndarray, r_start: float) -> np.ndarray:
        """The yaw rate the model gives for the command ``delta`` from ``r_start``."""
        a = math.exp(-self.dt / self.T)
        out = np.empty(delta.size)
        r = r_start
        for k in range(delta.size):
            out[k] = r
            r = a * r + (1 - a) * (self.K * delta[k] + self.r0)
        return out


def _regression(items: list[Stretch], instruments: list[np.ndarray] | None) -> np.ndarray | None:
    """(a, b, c) of r[k+1] = a r[k] + b δ[k] + c by least squares, or by instrumental variables."""
    X, Z, y = [], [], []
    for n, s in enumerate(items):
        delta, r = s.y[:, 0], s.y[:, 1]
        X.append(np.column_stack([r[:-1], delta[:-1], np.ones(r.size - 1)]))
        z = r[:-1] if instruments is None else instruments[n][:-1]
        Z.append(np.column_stack([z, delta[:-1], np.ones(r.size - 1)]))
        y.append(r[1:])
    Xs, Zs, ys = np.vstack(X), np.vstack(Z), np.concatenate(y)
    try:
        return np.linalg.solve(Zs.T @ Xs, Zs.T @ ys)
    except np.linalg.LinAlgError:
        return None


def _model(theta: np.ndarray | None, dt: float) -> Nomoto | None:
    if theta is None:
        return None
    a, b, c = (float(v) for v in theta)
    if not 0 < a < 1:
        return None
    T = -dt / math.log(a)
    if not T_RANGE_S[0] <= T <= T_RANGE_S[1]:
        return None
    return Nomoto(b / (1 - a), T, c / (1 - a), dt)


def fit_nomoto(items: list[Stretch]) -> Nomoto | None:
    """The Nomoto model of stretches with columns (steering command, yaw rate rad/s) on one grid step."""
    items = [s for s in items if s.t.size > 3]
    if not items:
        return None
    dt = items[0].dt
    model = _model(_regression(items, None), dt)
    if model is None:
        return None
    for _ in range(IV_ITERATIONS):  # each step's instruments from the last step's model, until T settles
        simulated = [model.simulate(s.y[:, 0], float(s.y[0, 1])) for s in items]
        better = _model(_regression(items, simulated), dt)
        if better is None:
            break
        settled = abs(better.T / model.T - 1) < IV_SETTLED
        model = better
        if settled:
            break
    return model


def simulated_r2(model: Nomoto, items: list[Stretch]) -> float:
    """R² of the yaw rate simulated from the command alone, over every stretch."""
    measured = np.concatenate([s.y[:, 1] for s in items])
    sim = np.concatenate([model.simulate(s.y[:, 0], float(s.y[0, 1])) for s in items])
    return r_squared(measured, sim)


def interval_parts(items: list[Stretch], model: Nomoto) -> tuple[list[Nomoto], float]:
    """The fits over independent blocks of the log (for the interval) and the blocks' length: blocks of BLOCK_S (or
    10 T) where they give two fits or more, else of SHORT_BLOCK_S (or 10 T): an identification run turns only in
    its zig-zag, about 70 s, so that 60 s blocks hold one fit and no interval. A block whose steering hardly moves
    (a standard deviation under MIN_BLOCK_STEERING of the whole's: a heading hold) is left out: its fit is
    anything (K −69, T 6.7 s from 20 s of a held heading on a simulated hull) and would swamp the interval."""
    parts: list[Nomoto] = []
    length = BLOCK_S
    floor = MIN_BLOCK_STEERING * float(np.std(np.concatenate([s.y[:, 0] for s in items])))
    for length in (max(BLOCK_S, 10 * model.T), max(SHORT_BLOCK_S, 10 * model.T)):
        parts = [m for b in blocks(items, length)
                 if float(np.std(np.concatenate([s.y[:, 0] for s in b]))) >= floor and (m := fit_nomoto(b)) is not None]
        if len(parts) >= 2:
            break
    return parts, length


def nomoto_estimates(items: list[Stretch], command: str, unit: str) -> tuple[dict[str, Estimate], Nomoto] | str:
    """{gain, time constant, zero-steering yaw rate} and the model, or one line saying why yaw is not
    identifiable. ``command`` names the steering command, ``unit`` its unit (the gain is deg/s per it)."""
    seconds = sum(s.duration_s for s in items)
    steering = np.concatenate([s.y[:, 0] for s in items]) if items else np.empty(0)
    if seconds < MIN_S or steering.size < 10 or float(np.std(steering)) <= 1e-9:
        return f"no turns at steady speed ({seconds:.0f} s under way with {command} changing): yaw not identifiable"
    model = fit_nomoto(items)
    fit = simulated_r2(model, items) if model else math.nan
    if model is None or not fit >= MIN_R2:
        return (f"the yaw rate does not follow {command} as a first-order Nomoto model (R² {fit:.2f}, "
                f"{MIN_R2:g} needed): yaw not identifiable")
    parts, block_s = interval_parts(items, model)
    source = (f"{command} to yaw rate, {seconds:.0f} s under way ({len(parts)} blocks of {block_s:.0f} s for the "
              "interval)")
    deg = math.degrees(1.0)
    K_low, K_high = spread_interval(model.K, [m.K for m in parts])
    T_low, T_high = spread_interval(model.T, [m.T for m in parts])
    r_low, r_high = spread_interval(model.r0, [m.r0 for m in parts])
    return ({"yaw_nomoto_gain": Estimate(model.K * deg, K_low * deg, K_high * deg, f"deg/s per {unit}", source, fit),
             "yaw_nomoto_time_constant_s": Estimate(model.T, T_low, T_high, "s", source, fit),
             "yaw_rate_zero_steering_deg_s": Estimate(model.r0 * deg, r_low * deg, r_high * deg, "deg/s", source,
                                                      fit)}, model)
