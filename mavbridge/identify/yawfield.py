"""The model's yaw time constant, fitted by flying the model through the log's own commands.

A first-order Nomoto model's T is not the Otter model's ``yaw_time_constant``: that field sizes only the linear
yaw damping (N_r = M66/T_yaw), and the model adds a damping that grows with the yaw rate (N_r|r|). Turning hard,
the hull answers faster than T_yaw says (the simulated Otter, T_yaw 1 s: T 0.39 s from a steering step of 0.3,
1.04 s from one of 0.05), so writing the log's T into the field made the model's yaw too damped (Balanced on such
a model lost 4–6 points of its roll cut). Instead the model, with every other identified field, is flown on
``vessel.Plant`` through the log's own propulsion commands over its stretches under way (at most ``REPLAY_S``,
from the log's speed and yaw rate at each stretch's start), and ``yaw_time_constant`` is the value whose yaw rate
comes closest to the log's (an output-error fit: noise on the log's yaw rate does not bend it; on a simulated
identification run it gave 0.76 s by matching the Nomoto T instead, against the plant's 1.0 s).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mavbridge.identify.logdata import RPM
from mavbridge.identify.series import Stretch
from vessel import OtterParameters, Plant, tau_to_shaft_speeds

REPLAY_S = 300.0
FIELD_RANGE_S = (0.05, 20.0)
GRID = 13
REFINE = 10
PLANT_DT = 0.01


@dataclass(frozen=True)
class YawReplay:
    """The stretches the yaw was identified on, with what the model needs to fly them: columns the propulsion
    command of ``kind`` (two), the steering ``names``, the yaw rate (rad/s), and the speed (m/s) when ``speed``."""

    kind: str
    names: tuple[str, ...]
    stretches: list[Stretch]
    speed: bool


def steering_of(kind: str, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The steering command of two propulsion columns: n1 − n2 in rpm for shafts; for the motors' outputs half
    the difference of their thrust fractions (o·|o|), which the yaw moment follows whatever the throttle (half
    the outputs' difference would give one steering four times the moment at full throttle as at a quarter)."""
    if kind == "shafts":
        return (a - b) / RPM
    return 0.5 * (a * np.abs(a) - b * np.abs(b))


def shafts_of(p: OtterParameters, kind: str, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Left and right shaft speeds (rad/s) of the model for two command columns of ``kind``."""
    if kind == "shafts":
        return a, b
    m = p.matrices()
    if kind == "motors":
        def speed(o: np.ndarray) -> np.ndarray:
            return np.where(o >= 0, o * float(m.n_max), o * abs(float(m.n_min)))

        return speed(a), speed(b)
    pairs = np.array([tau_to_shaft_speeds(p, float(x), float(n)) for x, n in zip(a, b, strict=True)])
    return pairs[:, 0], pairs[:, 1]


def _steering(replay: YawReplay, s: Stretch) -> np.ndarray:
    return s.y[:, 2] if len(replay.names) == 1 else steering_of(replay.kind, s.y[:, 2], s.y[:, 3])


def _fly(p: OtterParameters, replay: YawReplay, s: Stretch) -> np.ndarray:
    """The model's yaw rate (rad/s) through one stretch's commands, from the log's speed and yaw rate at its start."""
    n1, n2 = shafts_of(p, replay.kind, s.y[:, 0], s.y[:, 1])
    r_col = 2 + len(replay.names)
    x0 = np.zeros(14)
    x0[6] = s.y[0, r_col + 1] if replay.speed else 0.0
    x0[11], x0[12], x0[13] = s.y[0, r_col], n1[0], n2[0]
    plant = Plant(p, dt=PLANT_DT, x0=x0)
    steps = max(1, round(s.dt / PLANT_DT))
    out = np.empty(s.t.size)
    for k in range(s.t.size):
        out[k] = plant.state[11]
        plant.advance((float(n1[k]), float(n2[k])), steps)
    return out


def replay_error(p: OtterParameters, replay: YawReplay) -> float | None:
    """The rms difference (rad/s) between the model's yaw rate flown through the replay and the log's; None if the
    model cannot fly it."""
    r_col = 2 + len(replay.names)
    try:
        squares = [float(np.sum((_fly(p, replay, s) - s.y[:, r_col]) ** 2)) for s in replay.stretches]
    except FloatingPointError:
        return None
    return math.sqrt(sum(squares) / sum(s.t.size for s in replay.stretches))


def longest(stretches: list[Stretch], seconds: float = REPLAY_S) -> list[Stretch]:
    """The longest stretches, cut to ``seconds`` in all."""
    out, left = [], seconds
    for s in sorted(stretches, key=lambda s: -s.duration_s):
        if left <= 0:
            break
        n = min(s.t.size, int(left / s.dt) + 1) if s.dt > 0 else s.t.size
        if n > 3:
            out.append(Stretch(s.t[:n], s.y[:n]))
        left -= n * s.dt
    return out


def yaw_time_constant(p: OtterParameters, replay: YawReplay) -> float | None:
    """``yaw_time_constant`` (s) with which the model, flown through the log's commands, comes closest to the log's
    yaw rate (least rms difference: a coarse log-spaced search over FIELD_RANGE_S, then golden sections between
    the best one's neighbours); None when the model cannot fly the commands or the best is at the range's end."""
    short = YawReplay(replay.kind, replay.names, longest(replay.stretches), replay.speed)
    if not short.stretches:
        return None

    def error(field: float) -> float:
        got = replay_error(p.replace(yaw_time_constant=field), short)
        return math.inf if got is None else got

    grid = np.geomspace(*FIELD_RANGE_S, GRID)
    errors = [error(float(g)) for g in grid]
    best = int(np.argmin(errors))
    if not math.isfinite(errors[best]) or best in (0, GRID - 1):
        return None
    lo, hi = math.log(grid[best - 1]), math.log(grid[best + 1])
    golden = (math.sqrt(5) - 1) / 2
    for _ in range(REFINE):
        a, b = hi - golden * (hi - lo), lo + golden * (hi - lo)
        if error(math.exp(a)) < error(math.exp(b)):
            hi = b
        else:
            lo = a
    return math.exp(0.5 * (lo + hi))
