"""Predicting the boat's state forward over the link's delay with the NMPC's own model.

The state the companion acts on is already old when it is read (the downlink's delay) and the command it
plans takes effect later still (the uplink's). Planning from the state *when the command will act* —
a Smith predictor — keeps the NMPC from steering a boat that is no longer where it was. The prediction
uses the model the NMPC plans with (``mavbridge.nmpc.problem.model_ode``: the Otter's rigid-body
dynamics from ``vessel``, with the wave as a run-time input), RK4 in steps of at most ``MAX_STEP_S``,
and the commands the boat is executing over the interval: each command sent is recorded with the
autopilot time it takes effect (``CommandHistory``); before the first one the boat has none (zero).

x = [N, E, D, φ, θ, ψ, u, v, w, p, q, r]: NED position relative to home, Euler angles, body velocities
and rates (m, rad, m/s, rad/s); τ = (τ_X N, τ_N N·m).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from mavbridge.nmpc import compile_native_function
from mavbridge.nmpc.layout import wave_input_size
from mavbridge.nmpc.problem import NO_DISTURBANCE, model_ode
from mavbridge.nmpc.wave_model import CALM_PARAMETERS, is_parametric, wave_parameters
from vessel import OceanCurrent, OtterParameters, WaveField

MAX_STEP_S = 0.05  # RK4 steps no longer than this (the NMPC's substep is 0.025-0.05 s)
HISTORY = 64  # commands remembered (6.4 s at 10 Hz: far more than any delay predicted over)


@dataclass
class CommandHistory:
    """The commands sent, each with the autopilot time (s) from which the boat executes it."""

    entries: deque[tuple[float, np.ndarray]] = field(default_factory=lambda: deque(maxlen=HISTORY))

    def add(self, effective_s: float, tau: np.ndarray) -> None:
        """A command that takes effect at autopilot time ``effective_s`` (a reboot's earlier clock restarts)."""
        if self.entries and not effective_s >= self.entries[-1][0]:  # (a NaN time too: the entries stay in order)
            self.entries.clear()
        self.entries.append((effective_s, np.asarray(tau, float).copy()))

    def segments(self, t0: float, t1: float) -> list[tuple[float, float, np.ndarray]]:
        """[(from, to, τ)] covering [t0, t1]: the command in effect over each piece (zero before the first).

        Read from the newest back to the command in effect at t0 (entries are in time order): a few entries a
        step rather than the whole history twice (a fifth of the prediction's time, issue 32)."""
        current: np.ndarray | None = None
        later: list[tuple[float, np.ndarray]] = []  # the commands taking effect within (t0, t1), newest first
        for when, tau in reversed(self.entries):
            if when <= t0:
                current = tau
                break
            if when < t1:
                later.append((when, tau))
        pieces, start = [], t0
        current = np.zeros(2) if current is None else current
        for when, tau in reversed(later):
            pieces.append((start, when, current))
            start, current = when, tau
        pieces.append((start, t1, current))
        return [p for p in pieces if p[1] > p[0]]


class StatePredictor:
    """x(t0) -> x(t1) with the NMPC's model and the commands in effect; built once (one CasADi Function)."""

    def __init__(self, params: OtterParameters, current: OceanCurrent, fixed_waves: WaveField | None = None) -> None:
        """``fixed_waves``: a field built into the model (a controller that does not take run-time waves)."""
        self._fixed = fixed_waves is not None and not is_parametric(fixed_waves)
        ode = model_ode(params, fixed_waves if self._fixed else None, current)
        x, tau, t, h = ca.SX.sym("x", 12), ca.SX.sym("tau", 2), ca.SX.sym("t"), ca.SX.sym("h")
        wave = ca.SX.sym("wave", wave_input_size(0))  # the regular wave, then the disturbance
        k1 = ode(x, tau, t, wave)
        k2 = ode(x + h / 2 * k1, tau, t + h / 2, wave)
        k3 = ode(x + h / 2 * k2, tau, t + h / 2, wave)
        k4 = ode(x + h * k3, tau, t + h, wave)
        step = ca.Function("predict_step", [x, tau, t, wave, h], [x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)])
        # C, cached (the SX machine took a sixth of the loop), and the same library called through its C API:
        # CasADi's Python call converts each argument to a DM and back (≈ 90 µs a step, most of the prediction)
        self._step, self._native, self.how = compile_native_function(step)
        self._inputs = (np.zeros(12), np.zeros(2), np.zeros(1), np.zeros(wave_input_size(0)), np.zeros(1))
        if self._native is not None:
            self._native.bind(*self._inputs)  # (x, τ, t, wave, h), refilled each step
        self._wave_of: object = None  # the field ``_wave`` was made from (fields are immutable): no rebuild a step
        self._wave = np.concatenate([self.wave_vector(None), NO_DISTURBANCE])  # the model's whole wave input

    def wave_vector(self, waves: WaveField | None) -> np.ndarray:
        """The model's wave input for the field the NMPC plans with now (calm when fixed or not regular)."""
        if self._fixed or not is_parametric(waves):
            return CALM_PARAMETERS.copy()
        try:
            return wave_parameters(waves)  # type: ignore[arg-type]
        except (TypeError, ValueError):
            return CALM_PARAMETERS.copy()

    def predict(self, x: np.ndarray, t0: float, t1: float, history: CommandHistory,
                waves: WaveField | None = None, disturbance: np.ndarray = NO_DISTURBANCE) -> np.ndarray:
        """The state at autopilot time t1 from x at t0 (x itself when t1 <= t0, or if the model diverges), with the
        NMPC's estimated ``disturbance`` (``RollAwareNmpc.disturbance``)."""
        x_now = np.asarray(x, float).ravel().copy()  # a (12, 1) column too, as CasADi's call took it
        if not t1 > t0:
            return x_now
        if waves is not self._wave_of:
            self._wave_of = waves
            self._wave[:len(CALM_PARAMETERS)] = self.wave_vector(waves)
        self._wave[len(CALM_PARAMETERS):] = disturbance
        for start, end, tau in history.segments(t0, t1):
            steps = max(1, math.ceil((end - start) / MAX_STEP_S - 1e-9))
            h = (end - start) / steps
            for i in range(steps):
                x_now = self._rk4(x_now, tau, start + i * h, h)
        return x_now if np.isfinite(x_now).all() else np.asarray(x, float).copy()

    def _rk4(self, x: np.ndarray, tau: np.ndarray, t: float, h: float) -> np.ndarray:
        """One RK4 step of ``h`` s from x at t under τ and the current wave input (a new array)."""
        if self._native is None:
            return np.asarray(self._step(x, tau, t, self._wave, h)).ravel()
        x_in, tau_in, t_in, wave_in, h_in = self._inputs
        x_in[:], tau_in[:], t_in[0], wave_in[:], h_in[0] = x, tau, t, self._wave, h
        return self._native.call()[0].copy()
